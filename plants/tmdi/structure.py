"""The TMDI-equipped nonlinear SDOF of S1 under base acceleration: full model and RTHS substructure.

Equations of motion, S1 Eq.12, with ``u_I`` and ``u_T`` relative to the ground (shaking table)::

    m_I ü_I + F_I = -m_I ü_G + F_T
    m_T ü_T       = -m_T ü_G - F_B - F_T

``F_I = F_EI(u_I) + c_I u̇_I`` and ``F_T = F_ET(u_TI) + c_T u̇_TI`` (``u_TI = u_T - u_I``) are HDRB
isolators (S1 Eq.8, :mod:`plants.tmdi.hdrb`); ``F_B`` is the restoring force of the grounded inerter
(:mod:`plants.tmdi.inerter`).  Two uses share one integration kernel (:mod:`plants.tmdi.kernel`):

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
:mod:`plants.tmdi.calibration`.  Its result is the preset
:data:`plants.tmdi.hdrb.S1_PRIMARY_UNCONTROLLED`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

from plants.base import Specimen
from plants.tmdi import kernel as kern
from plants.tmdi import layout
from plants.tmdi.calibration import (
    S1_UNCONTROLLED,
    PSCalibration,
    UncontrolledObservations,
    calibrate_uncontrolled_ps,
    harmonic_balance_crest,
    stepped_sine_crest,
)
from plants.tmdi.hdrb import (
    S1_PRIMARY,
    S1_PRIMARY_AMPLITUDE,
    S1_PRIMARY_IDEAL_INERTER,
    S1_PRIMARY_IDEAL_INERTER_AMPLITUDE,
    S1_PRIMARY_UNCONTROLLED,
    S1_SECONDARY,
    S1_SECONDARY_AMPLITUDE,
    S1_SECONDARY_IDEAL_INERTER,
    S1_SECONDARY_IDEAL_INERTER_AMPLITUDE,
)
from plants.tmdi.inerter import (
    IdealInerter,
    RackPinionInerter,
    ideal_inerter_preset,
    rack_pinion_preset,
)
from plants.tmdi.kernel import IntegrationError
from plants.tmdi.linear import EQ7_QUANTITIES, linear_frf, linearised_frequencies
from plants.tmdi.parameters import (
    PRIMARY_MASS,
    SECONDARY_MASSES,
    SUBSTEP_FRACTION,
    TMDIParameters,
)
from plants.tmdi.substructure import NominalInerter, TMDISubstructure
from rths.core.errors import (
    ParameterError,
    check_positive,
    format_choices,
)

__all__ = [
    "EQ7_QUANTITIES",
    "HDRB_MODELS",
    "IntegrationError",
    "NominalInerter",
    "PRIMARY_MASS",
    "PSCalibration",
    "S1_UNCONTROLLED",
    "SECONDARY_MASSES",
    "TMDIParameters",
    "TMDIResponse",
    "TMDIStructure",
    "TMDISubstructure",
    "UncontrolledObservations",
    "calibrate_uncontrolled_ps",
    "harmonic_balance_crest",
    "linear_frf",
    "linearised_frequencies",
    "s1_configuration",
    "stepped_sine_crest",
]

#: HDRB damping models of :func:`s1_configuration`.
HDRB_MODELS: Final[tuple[str, ...]] = ("viscous", "amplitude")


def s1_configuration(
    mass: str | None,
    flywheel: str | None = None,
    inerter: str = "rack_pinion",
    hdrb: str = "viscous",
) -> tuple[TMDIParameters, Specimen | None]:
    """A physical model of S1 Table 1 as (structure, inerter specimen).

    Parameters
    ----------
    mass
        Secondary mass ``"SM"`` (6 kg), ``"IM"`` (10 kg), ``"LM"`` (20 kg), or None for the
        uncontrolled PS (``flywheel`` must then be None).
    flywheel
        ``"NF"``, ``"IF"``, ``"LF"`` (S1 Table 1), or None for a TMD without inerter.
    inerter
        ``"rack_pinion"``: the S1 Eq.9-11 device (:func:`plants.tmdi.inerter.rack_pinion_preset`)
        with the isolators identified with it (c_I = 538.13, c_T = 409.15 N s/m);
        ``"ideal"``: the ideal-inerter variant of S1 §4.2 (b = 48.7 kg for IF, scaled for NF/LF;
        c_I = 743.3, c_T = 324.7 N s/m).  Ignored for the uncontrolled PS.
    hdrb
        ``"viscous"``: the S1 §4.2 isolators as identified (constant dashpots); for the
        uncontrolled PS the TMDI's primary bearing (S1 identifies no PS-alone model).
        ``"amplitude"``: the dashpots follow the amplitude law of :mod:`plants.tmdi.hdrb` -- with a
        TMDI the S1 §4.2 bearings anchored where S1 identified them (``S1_*_AMPLITUDE``
        presets), for the uncontrolled PS the bearing calibrated on S1's uncontrolled tests
        (:data:`~plants.tmdi.hdrb.S1_PRIMARY_UNCONTROLLED`).
    """
    if inerter not in ("rack_pinion", "ideal"):
        raise ParameterError(f"inerter must be 'rack_pinion' or 'ideal'; got {inerter!r}")
    if hdrb not in HDRB_MODELS:
        raise ParameterError(f"hdrb must be one of {format_choices(HDRB_MODELS)}; got {hdrb!r}")
    ideal = inerter == "ideal"
    amplitude = hdrb == "amplitude"
    if mass is None:
        if flywheel is not None:
            raise ParameterError(f"the uncontrolled PS has no inerter; got flywheel {flywheel!r}")
        return TMDIParameters(PRIMARY_MASS, S1_PRIMARY_UNCONTROLLED if amplitude else S1_PRIMARY
                              ), None
    if mass not in SECONDARY_MASSES:
        raise ParameterError(
            f"secondary mass must be one of {format_choices(list(SECONDARY_MASSES))} or None; "
            f"got {mass!r}"
        )
    if ideal and amplitude:
        primary = S1_PRIMARY_IDEAL_INERTER_AMPLITUDE
        secondary = S1_SECONDARY_IDEAL_INERTER_AMPLITUDE
    elif ideal:
        primary, secondary = S1_PRIMARY_IDEAL_INERTER, S1_SECONDARY_IDEAL_INERTER
    elif amplitude:
        primary, secondary = S1_PRIMARY_AMPLITUDE, S1_SECONDARY_AMPLITUDE
    else:
        primary, secondary = S1_PRIMARY, S1_SECONDARY
    structure = TMDIParameters(PRIMARY_MASS, primary, SECONDARY_MASSES[mass], secondary)
    if flywheel is None:
        return structure, None
    if ideal:
        return structure, IdealInerter(ideal_inerter_preset(flywheel))
    return structure, RackPinionInerter(rack_pinion_preset(flywheel))


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


def _initial_state(rack: RackPinionInerter | None) -> NDArray[np.float64]:
    s = np.zeros(layout.N_STATE)
    if rack is not None and rack.parameters.total_clearance == 0.0:
        s[layout.S_MODE] = layout.FORWARD
    return s


class TMDIStructure:
    """Full model of S1 Eq.12 with the inerter inside, driven by a ground-acceleration history.

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

    Notes
    -----
    Other :class:`~plants.base.Specimen` types cannot be embedded monolithically; couple them
    through :class:`TMDISubstructure` instead.
    """

    def __init__(self, parameters: TMDIParameters, inerter: Specimen | None, dt: float) -> None:
        self.parameters: Final[TMDIParameters] = parameters
        self.dt: Final[float] = check_positive(dt, "time step dt")
        self._rack: RackPinionInerter | None = None
        if inerter is not None and not parameters.has_tmd:
            raise ParameterError("an inerter needs a secondary mass; got secondary mass 0.0")
        if isinstance(inerter, IdealInerter):
            self._p = layout.pack_parameters(parameters, inertance=inerter.inertance)
        elif isinstance(inerter, RackPinionInerter):
            self._rack = inerter
            self._p = layout.pack_parameters(parameters, device=inerter.parameters)
        elif inerter is None:
            self._p = layout.pack_parameters(parameters)
        else:
            raise ParameterError(
                "inerter must be IdealInerter, RackPinionInerter or None; got "
                f"{type(inerter).__name__} (couple other specimens through TMDISubstructure)"
            )
        self.substeps: Final[int] = self._substeps()

    def _substeps(self) -> int:
        if self._rack is None:
            return 1
        device = self._rack.parameters
        # the rack's own scales and the secondary mass on the series spring k_S / r_P²
        coupled = math.sqrt(
            self.parameters.secondary_mass * device.pinion_radius**2 / device.series_stiffness
        )
        h_max = min(device.max_substep(), SUBSTEP_FRACTION * coupled)
        return max(1, math.ceil(self.dt / h_max - 1e-9))

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
        out, failures = kern.simulate(ag, self.dt, self.substeps, self._p,
                                      _initial_state(self._rack))
        if failures or not np.all(np.isfinite(out)):
            raise IntegrationError(
                f"TMDI integration failed to converge in {failures} segments with dt={self.dt!r}"
            )
        fields = {name: out[:, col].copy() for name, col in layout.OUTPUT_FIELDS.items()}
        if not self.parameters.has_tmd:
            for name in _SECONDARY_KINEMATICS:
                fields[name][:] = np.nan
        return TMDIResponse(time=np.arange(ag.size) * self.dt, ground_acceleration=ag.copy(),
                            **fields)
