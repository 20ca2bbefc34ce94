"""The TMDI structure as an RTHS numerical substructure with an optional nominal interface device
(private; re-exported by :mod:`plants.tmdi.structure`, which documents the model)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

from plants.base import Kinematics, Specimen, Substructure
from plants.tmdi import kernel as kern
from plants.tmdi import layout
from plants.tmdi.inerter import IdealInerter, RackPinionInerter
from plants.tmdi.kernel import IntegrationError
from plants.tmdi.linear import EQ7_QUANTITIES
from rths.core.errors import ParameterError, check_nonnegative, check_positive

if TYPE_CHECKING:
    from plants.tmdi.parameters import TMDIParameters

__all__ = ["NominalInerter", "TMDISubstructure"]


@dataclass(frozen=True, slots=True)
class NominalInerter:
    """Nominal model of a grounded inerter specimen, carried implicitly by the substructure.

    Restoring force (sign convention of :mod:`plants.base`)
    ``F_n = b_n ü_T + c_n u̇_T``: an ideal inerter (S1 Fig.1a) with an optional parallel
    dashpot, between the interface DOF ``u_T`` and the ground.

    Parameters
    ----------
    inertance
        ``b_n`` [kg], >= 0.
    damping
        ``c_n`` [N s/m], >= 0.
    """

    inertance: float
    damping: float = 0.0

    def __post_init__(self) -> None:
        check_nonnegative(self.inertance, "nominal inertance b_n")
        check_nonnegative(self.damping, "nominal damping c_n")

    @classmethod
    def matching(cls, specimen: Specimen) -> NominalInerter:
        """The rigid-limit model of an inerter specimen.

        Parameters
        ----------
        specimen
            :class:`~plants.tmdi.inerter.IdealInerter`: ``b_n = b``, ``c_n = 0``;
            :class:`~plants.tmdi.inerter.RackPinionInerter` (S1 Eq.9-10 with ``k_S → ∞``, no play,
            no friction): ``b_n = J_B / r_P²`` and ``c_n = c_B / r_P²``.  Other specimens
            raise :class:`~rths.core.errors.ParameterError`.
        """
        if isinstance(specimen, IdealInerter):
            return cls(specimen.inertance)
        if isinstance(specimen, RackPinionInerter):
            p = specimen.parameters
            return cls(p.nominal_inertance, p.flywheel_damping / p.pinion_radius**2)
        raise ParameterError(
            f"no nominal inerter for a {type(specimen).__name__}; give NominalInerter(b_n, c_n)"
        )


class TMDISubstructure(Substructure):
    """PS + TMD of S1 Eq.12 as the numerical substructure of an RTHS with the inerter physical.

    The interface DOF is ``u_T`` (relative to the ground, where the inerter is fixed); the loop
    supplies the inerter's restoring force ``F_B``, held constant over each step (it enters
    both ends of the trapezoidal rule).  The substructure owns the base excitation.

    Nominal device.  An inerter of ``b/m_T = 4.8`` (S1 IM-IF) fed back one step late turns
    into a negative mass that destabilises the secondary DOF, whatever the step.  With
    ``device`` the substructure carries a :class:`NominalInerter` ``F_n = b_n ü_T + c_n u̇_T``
    in its implicit system (``b_n`` joins ``m_T`` in the mass matrix, ``c_n`` the damping), so
    the step is as stable as the structure alone; :attr:`device_force` is ``F_n`` now, and the
    force passed to :meth:`step` is the *correction* ``F_B - F_n`` (the loop's
    ``force_scale * F - device_force``, :mod:`rths.runtime.loop`).  A specimen equal to the nominal
    device then gives a zero correction and the partitioned run is the monolithic one.

    Parameters
    ----------
    parameters
        The structure; it must have a secondary mass.
    ground_acceleration
        ``ü_G`` [m/s²]: a callable of time [s], or samples at spacing ``excitation_dt``
        (linearly interpolated, zero after the last sample).
    dt
        Loop step [s].
    excitation_dt
        Spacing [s] of sampled ``ground_acceleration``; defaults to ``dt``.
    device
        Nominal interface device integrated with the structure, or None (plain RTHS: the
        step's force is the whole ``F_B``).
    """

    def __init__(
        self,
        parameters: TMDIParameters,
        ground_acceleration: Callable[[float], float] | ArrayLike,
        dt: float,
        excitation_dt: float | None = None,
        device: NominalInerter | None = None,
    ) -> None:
        super().__init__(dt)
        if not parameters.has_tmd:
            raise ParameterError("the TMDI substructure needs a secondary mass; got 0.0 kg")
        if device is not None and not isinstance(device, NominalInerter):
            raise ParameterError(f"device must be a NominalInerter or None; got {device!r}")
        self.parameters: Final[TMDIParameters] = parameters
        self.device: Final[NominalInerter | None] = device
        spacing = self.dt if excitation_dt is None else excitation_dt
        self._ground = _ground_motion(ground_acceleration, spacing)
        nominal = device or NominalInerter(0.0)
        self._p = layout.pack_parameters(
            parameters, inertance=nominal.inertance, grounded_damping=nominal.damping
        )
        self._state = np.zeros(layout.N_STATE)
        self._input = np.zeros(layout.N_INPUT)
        self._out = np.zeros(layout.N_OUTPUT)
        self.reset()

    def _reset_impl(self) -> None:
        """Rest at ``t = 0`` with no interface force."""
        self._state[:] = 0.0
        self._force = 0.0
        self._ag_now = self._ground(0.0)

    @property
    def interface(self) -> Kinematics:
        """``u_T``, ``u̇_T``, ``ü_T`` (relative to the ground) now, with the last force."""
        return self._kinematics(self._state, self._ag_now, self._force)

    @property
    def device_force(self) -> float:
        """Restoring force [N] of the nominal device now, ``b_n ü_T + c_n u̇_T`` (0 without one);
        ``ü_T`` is the equilibrium acceleration with the last correction."""
        if self.device is None:
            return 0.0
        kin = self.interface
        return self.device.inertance * kin.acceleration + self.device.damping * kin.velocity

    def _kinematics(self, s: NDArray[np.float64], ag: float, force: float) -> Kinematics:
        a_t = kern.accelerations(s, ag, force, self._p)[1]
        return Kinematics(float(s[layout.S_U_T]), float(s[layout.S_V_T]), float(a_t))

    def _advance(self, s: NDArray[np.float64], force: float) -> float:
        ag1 = self._ground((self.steps + 1) * self.dt)
        inp = self._input
        inp[layout.I_AG0] = self._ag_now
        inp[layout.I_AG1] = ag1
        inp[layout.I_FEXT] = force
        if kern.step(s, self.dt, 1, inp, self._p) or not np.all(np.isfinite(s)):
            raise IntegrationError(
                f"TMDI substructure step failed at t={self.time!r} s with force {force!r} N"
            )
        return ag1

    def _step_impl(self, restoring_force: float) -> Kinematics:
        ag1 = self._advance(self._state, restoring_force)
        self._ag_now = ag1
        self._force = restoring_force
        return self._kinematics(self._state, ag1, restoring_force)

    def predict(self, restoring_force: float) -> Kinematics:
        """What :meth:`step` would return for ``restoring_force`` [N]; no state changes."""
        trial = self._state.copy()
        ag1 = self._advance(trial, float(restoring_force))
        return self._kinematics(trial, ag1, float(restoring_force))

    def outputs(self) -> dict[str, float]:
        """S1 Eq.7 quantities now, plus ``a_G``; ``F_B`` is the last interface force (with a
        nominal device: :attr:`device_force` plus the last correction)."""
        kern.outputs(self._state, self._ag_now, self._force, self._p, self._out)
        result = {name: float(self._out[layout.OUTPUT_FIELDS[name]]) for name in EQ7_QUANTITIES}
        result["a_G"] = float(self._ag_now)
        return result


def _ground_motion(
    source: Callable[[float], float] | ArrayLike, spacing: float
) -> Callable[[float], float]:
    """``ü_G(t)`` from a callable or from samples (linear interpolation, 0 after the end)."""
    if callable(source):
        def checked(t: float) -> float:
            value = float(source(t))
            if not math.isfinite(value):
                raise ParameterError(
                    f"ground acceleration at t={t!r} s must be finite; got {value!r}"
                )
            return value
        return checked
    samples = np.asarray(source, dtype=float)
    if samples.ndim != 1 or samples.size == 0:
        raise ParameterError(
            f"ground acceleration samples must be a non-empty 1-D array; got shape {samples.shape}"
        )
    if not np.all(np.isfinite(samples)):
        raise ParameterError("ground acceleration samples must be finite; got NaN or inf")
    spacing = check_positive(spacing, "excitation_dt")
    values = samples.tolist()
    last = len(values) - 1

    def sampled(t: float) -> float:
        position = max(t, 0.0) / spacing
        i = int(position)
        if i >= last:
            return values[last] if position <= last + 1e-9 else 0.0
        frac = position - i
        return values[i] + frac * (values[i + 1] - values[i])

    return sampled
