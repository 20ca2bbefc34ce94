"""The TMDI-equipped nonlinear SDOF of S1 under base acceleration: full model and RTHS substructure.

Equations of motion, S1 Eq.12, with ``u_I`` and ``u_T`` relative to the ground (shaking table)::

    m_I ü_I + F_I = -m_I ü_G + F_T
    m_T ü_T       = -m_T ü_G - F_B - F_T

``F_I = F_EI(u_I) + c_I u̇_I`` and ``F_T = F_ET(u_TI) + c_T u̇_TI`` (``u_TI = u_T - u_I``) are HDRB
isolators (S1 Eq.8, :mod:`plants.tmdi.hdrb`); ``F_B`` is the restoring force of the grounded inerter
(:mod:`plants.tmdi.inerter`).  Two uses share one integration kernel
(:mod:`plants.tmdi.integration.kernel`):

* :class:`TMDIStructure` integrates the whole system, inerter included, monolithically: the
  shaking-table emulation.
* :class:`TMDISubstructure` is the numerical part of an RTHS whose physical specimen is the
  inerter: interface DOF ``u_T``, the loop supplies ``F_B``, or with a :class:`NominalInerter`
  carried implicitly (needed for a stable RTHS of the S1 inerter) the correction on top of it.

Scheme: trapezoidal rule (Newmark average acceleration) with Newton iterations on the nonlinear
springs; it is unconditionally stable and conserves the energy of the linear undamped system, and
the HDRB softening only needs a few Newton iterations.  With the rack-and-pinion inerter the
device's internal DOFs are integrated in the same implicit system, sub-stepped on its own time
scales, with the backlash switches located inside the step.

The S1 configurations (Table 1: secondary mass SM/IM/LM × flywheel NF/IF/LF, plus the uncontrolled
PS) are built by :func:`s1_configuration`; the numbers live in :data:`PRIMARY_MASS`,
:data:`SECONDARY_MASSES`, :data:`plants.tmdi.inerter.FLYWHEELS` and the HDRB presets of
:mod:`plants.tmdi.hdrb` (S1 §4.2), either as S1 identified them (viscous dashpots) or with the
amplitude-dependent dashpots of :class:`plants.tmdi.hdrb.AmplitudeDamping`.

S1 identifies no model of the PS alone.  :func:`calibrate_uncontrolled_ps` fits one to the numbers
S1 reports for the uncontrolled tests (:data:`S1_UNCONTROLLED`: 5 mm at 0.05 g, 38 mm at
0.15 g, f0 = 2.25 Hz at 0.10 g) -- harmonic balance (:func:`harmonic_balance_crest`) corrected
to the time-domain crests of this model (:func:`stepped_sine_crest`); see
:mod:`rths.experiments.s1_shake_table.calibration`.  Its result is the preset
:data:`plants.tmdi.hdrb.S1_PRIMARY_UNCONTROLLED`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

from plants.base import Specimen
from plants.tmdi.configuration import HDRB_MODELS, s1_configuration
from plants.tmdi.engine import S1Structure
from plants.tmdi.inerter import (
    IdealInerter,
    RackPinionInerter,
)
from plants.tmdi.integration import kernel as kern
from plants.tmdi.integration import layout
from plants.tmdi.integration.kernel import IntegrationError
from plants.tmdi.linear import EQ7_QUANTITIES, linear_frf, linearised_frequencies
from plants.tmdi.parameters import (
    PRIMARY_MASS,
    SECONDARY_MASSES,
    SUBSTEP_FRACTION,
    TMDIParameters,
)
from rths.core.errors import (
    ParameterError,
    check_positive,
)

__all__ = [
    "EQ7_QUANTITIES",
    "HDRB_MODELS",
    "IntegrationError",
    "PRIMARY_MASS",
    "SECONDARY_MASSES",
    "TMDIParameters",
    "TMDIResponse",
    "TMDIStructure",
    "linear_frf",
    "linearised_frequencies",
    "s1_configuration",
]


@dataclass(frozen=True, slots=True)
class TMDIResponse:
    """Sampled response of :class:`TMDIStructure` (arrays of shape ``(n,)``, SI units).

    The S1 Eq.7 quantities (definitions S1 Eq.1-6): ``u_I``, ``u_TI``, ``u_T`` [m];
    ``a_I_tot``, ``a_T_tot`` (total) and ``a_T`` (relative) [m/s²]; ``F_I``, ``F_T``, ``F_B``
    [N].  Also the velocities ``v_I``, ``v_T`` [m/s] and, for the rack-and-pinion inerter, the
    node and flywheel angles ``theta_S``, ``theta_G`` [rad], flywheel speed ``omega_G`` [rad/s],
    gap torque ``torque`` [N m] and ``contact`` (-1, 0, +1); the HDRB dashpot coefficients
    ``c_I``, ``c_T`` [N s/m] in force at each sample (constant unless a bearing has an
    :class:`~plants.tmdi.hdrb.AmplitudeDamping` law).  For the uncontrolled PS the secondary
    kinematics are NaN and ``F_T = F_B = 0``.

    Sample ``k`` of every array is the state at ``t = k dt``; sample 0 is rest.  Displacements
    and velocities are relative to the ground (the shaking table), as in S1 Eq.12.

    Attributes
    ----------
    time : numpy.ndarray
        Sample times ``k dt`` [s].
    ground_acceleration : numpy.ndarray
        The base (shaking-table) acceleration ``ü_G`` [m/s²] that drove the model.
    u_I : numpy.ndarray
        Primary-mass displacement ``u_I`` [m] (the primary isolator's deformation).
    a_I_tot : numpy.ndarray
        Primary-mass total acceleration ``ü_I^(tot) = ü_I + ü_G`` [m/s²] (S1 Eq.1).
    F_I : numpy.ndarray
        Primary isolator force ``F_I = F_EI + F_DI`` [N] (S1 Eq.8, Eq.12; measured by S1 Eq.6).
    u_TI : numpy.ndarray
        TMDI stroke ``u_TI = u_T - u_I`` [m] (the secondary isolator's deformation, S1 Eq.3).
    a_T_tot : numpy.ndarray
        Secondary-mass total acceleration ``ü_T^(tot) = ü_T + ü_G`` [m/s²].
    F_T : numpy.ndarray
        Secondary isolator force ``F_T = F_ET + F_DT`` [N] (S1 Eq.8, Eq.12; S1 Eq.5).
    u_T : numpy.ndarray
        Secondary-mass displacement ``u_T`` [m] (the inerter's stroke, S1 Eq.3).
    a_T : numpy.ndarray
        Secondary-mass relative acceleration ``ü_T`` [m/s²] (the inerter's, S1 Eq.2).
    F_B : numpy.ndarray
        Inerter restoring force ``F_B`` [N] (S1 Eq.10 for the rack-and-pinion device, ``b ü_T``
        for the ideal inerter; measured by S1 Eq.4); 0 without an inerter.
    v_I : numpy.ndarray
        Primary-mass velocity ``u̇_I`` [m/s].
    v_T : numpy.ndarray
        Secondary-mass velocity ``u̇_T`` [m/s].
    theta_S : numpy.ndarray
        Angle ``θ_S`` [rad] of the node between the series visco-elastic element and the
        backlash gap (S1 Eq.9, Fig.16); 0 without the rack-and-pinion inerter.
    theta_G : numpy.ndarray
        Flywheel angle ``θ_G`` [rad] (S1 Eq.9); 0 without the rack-and-pinion inerter.
    omega_G : numpy.ndarray
        Flywheel angular velocity ``θ̇_G`` [rad/s]; 0 without the rack-and-pinion inerter.
    torque : numpy.ndarray
        Torque ``T_P = T_G`` [N m] transmitted across the gap (S1 Eq.9, Eq.11); 0 while the gap
        is open or without the rack-and-pinion inerter.
    contact : numpy.ndarray
        Contact mode of the gap (S1 Eq.11) [-]: +1 forward contact (``T >= 0``), -1 backward
        contact (``T <= 0``), 0 open (and without the rack-and-pinion inerter).
    c_I : numpy.ndarray
        Primary dashpot coefficient ``c_I`` [N s/m] in force at each sample (S1 Eq.8).
    c_T : numpy.ndarray
        Secondary dashpot coefficient ``c_T`` [N s/m] in force at each sample (S1 Eq.8).
    """

    time: NDArray[np.float64]
    ground_acceleration: NDArray[np.float64]
    u_I: NDArray[np.float64]
    a_I_tot: NDArray[np.float64]
    F_I: NDArray[np.float64]
    u_TI: NDArray[np.float64]
    a_T_tot: NDArray[np.float64]
    F_T: NDArray[np.float64]
    u_T: NDArray[np.float64]
    a_T: NDArray[np.float64]
    F_B: NDArray[np.float64]
    v_I: NDArray[np.float64]
    v_T: NDArray[np.float64]
    theta_S: NDArray[np.float64]
    theta_G: NDArray[np.float64]
    omega_G: NDArray[np.float64]
    torque: NDArray[np.float64]
    contact: NDArray[np.float64]
    c_I: NDArray[np.float64]
    c_T: NDArray[np.float64]

    def quantities(self) -> dict[str, NDArray[np.float64]]:
        """The S1 Eq.7 quantities keyed by name, in the paper's order."""
        return {name: getattr(self, name) for name in EQ7_QUANTITIES}


_SECONDARY_KINEMATICS: Final[tuple[str, ...]] = ("u_TI", "a_T_tot", "u_T", "a_T", "v_T")


class TMDIStructure(S1Structure):
    """Full model of S1 Eq.12 with the inerter inside, under a base excitation.

    A :class:`~plants.base.Substructure` (interface ``u_T``, or ``u_I`` without a TMD; the
    force of :meth:`step` acts there, normally 0) so the S1 sweep and the fully numerical run
    drive it like any other plant; :meth:`run` is the same kernel over a whole
    ground-acceleration record in one compiled call (bit-identical to stepping, tested).

    Parameters
    ----------
    parameters
        The structure (masses and isolators).
    inerter
        :class:`~plants.tmdi.inerter.IdealInerter` (its inertance joins ``m_T`` in the implicit mass
        matrix), :class:`~plants.tmdi.inerter.RackPinionInerter` (its DOFs join the implicit system)
        or None (TMD without inerter, or the PS).  Only its parameters are used; the object's
        own state is left alone.
    dt
        Sampling step [s] of the ground acceleration and of the response.
    ground_acceleration
        ``ü_G`` [m/s²] for :meth:`step`: a callable of time [s] or samples at ``excitation_dt``
        (default: none, ``ü_G = 0``).
    excitation_dt
        Spacing [s] of sampled ``ground_acceleration``; defaults to ``dt``.

    Notes
    -----
    Other :class:`~plants.base.Specimen` types cannot be embedded monolithically; couple them
    through :class:`TMDISubstructure` instead.
    """

    def __init__(
        self,
        parameters: TMDIParameters,
        inerter: Specimen | None,
        dt: float,
        ground_acceleration: Callable[[float], float] | ArrayLike | None = None,
        excitation_dt: float | None = None,
    ) -> None:
        self._rack: RackPinionInerter | None = None
        if inerter is not None and not parameters.has_tmd:
            raise ParameterError("an inerter needs a secondary mass; got secondary mass 0.0")
        if isinstance(inerter, IdealInerter):
            packed = layout.pack_parameters(parameters, inertance=inerter.inertance)
        elif isinstance(inerter, RackPinionInerter):
            self._rack = inerter
            packed = layout.pack_parameters(parameters, device=inerter.parameters)
        elif inerter is None:
            packed = layout.pack_parameters(parameters)
        else:
            raise ParameterError(
                "inerter must be IdealInerter, RackPinionInerter or None; got "
                f"{type(inerter).__name__} (couple other specimens through TMDISubstructure)"
            )
        rigid_contact = self._rack is not None and self._rack.parameters.total_clearance == 0.0
        super().__init__(
            parameters,
            packed,
            _no_excitation if ground_acceleration is None else ground_acceleration,
            dt,
            excitation_dt,
            substeps=self._substeps(parameters, dt),
            initial_mode=layout.FORWARD if rigid_contact else layout.OPEN,
        )

    def _substeps(self, parameters: TMDIParameters, dt: float) -> int:
        if self._rack is None:
            return 1
        device = self._rack.parameters
        # the rack's own scales and the secondary mass on the series spring k_S / r_P²
        coupled = math.sqrt(
            parameters.secondary_mass * device.pinion_radius**2 / device.series_stiffness
        )
        h_max = min(device.max_substep(), SUBSTEP_FRACTION * coupled)
        return max(1, math.ceil(check_positive(dt, "time step dt") / h_max - 1e-9))

    @property
    def device_force(self) -> float:
        """Restoring force ``F_B`` [N] of the inerter inside the model now (0 without one)."""
        return self.outputs()["F_B"] - self._force

    def run(self, ground_acceleration: ArrayLike) -> TMDIResponse:
        """Response from rest to the ground acceleration samples ``ü_G(k dt)`` [m/s²].

        Sample ``k`` of every output is the state at ``t = k dt``; sample 0 is rest.

        Raises
        ------
        IntegrationError
            If a Newton iteration fails (e.g. a spring driven beyond its monotonic range).
        """
        ag = np.ascontiguousarray(ground_acceleration, dtype=float)
        if ag.ndim != 1 or ag.size == 0:
            raise ParameterError(
                f"ground acceleration must be a non-empty 1-D array; got shape {ag.shape}"
            )
        if not np.all(np.isfinite(ag)):
            raise ParameterError("ground acceleration must be finite; got NaN or inf samples")
        initial = np.zeros(layout.N_STATE)
        initial[layout.S_MODE] = self._initial_mode
        out, failures = kern.simulate(ag, self.dt, self.substeps, self._p, initial)
        if failures or not np.all(np.isfinite(out)):
            raise IntegrationError(
                f"TMDI integration failed to converge in {failures} segments with dt={self.dt!r}"
            )
        fields = {name: out[:, col].copy() for name, col in layout.OUTPUT_FIELDS.items()}
        if not self.parameters.has_tmd:
            for name in _SECONDARY_KINEMATICS:
                fields[name][:] = np.nan
        return TMDIResponse(
            time=np.arange(ag.size, dtype=np.float64) * self.dt,
            ground_acceleration=ag.copy(),
            **fields,
        )


def _no_excitation(t: float) -> float:
    """``ü_G = 0`` [m/s²]."""
    return 0.0
