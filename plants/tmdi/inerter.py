"""Grounded inerters as physical specimens: the ideal inerter and the S1 rack-and-pinion flywheel.

Both are :class:`plants.base.Specimen` subclasses driven by the rack (secondary-mass) displacement
``u_T`` relative to the ground, so either can be the physical specimen of an RTHS of the TMDI.

Sign convention (restoring force, see :mod:`plants.base`)
---------------------------------------------------------
``F_B`` is the force that must be applied to the rack to impose its motion; the secondary mass
receives ``-F_B`` (S1 Eq.12).  Inside the rack-and-pinion model every angle is positive in the
sense the pinion turns for ``u_T > 0`` (``θ_P = u_T / r_P``) and the series torque is the torque
the pinion applies, through the visco-elastic element, to the massless node ``S`` and, across the
closed gap, to the flywheel:

.. math::

    T = k_S(θ_P - θ_S) + c_S(\\dot θ_P - \\dot θ_S), \\qquad
    T_G = J_B \\ddot θ_G + c_B \\dot θ_G = T \\;\\text{(gap closed)}, \\qquad
    F_B = f_y \\operatorname{sign}(\\dot u_T) + T / r_P .

S1 Eq.9 writes the series torque with the opposite sign (the torque acting *on* the pinion) while
Eq.10 adds it as a restoring force; the convention above is the consistent one, proven by the rigid
limit ``k_S → ∞, ε1 = ε2 = 0, f_y = c_B = 0``: then ``θ_S = θ_G = θ_P`` and
``F_B = J_B θ̈_P / r_P = (J_B / r_P²) ü_T``, an ideal inerter of ``b = J_B/r_P²`` (47.8 kg for the
S1 flywheel IF).  The gap ``g = θ_S - θ_G`` lies in ``[-ε2, ε1]`` (S1 Eq.11 with
``θ_G - θ_S ∈ [-ε1, ε2]``): at ``g = ε1`` the node drives the flywheel forward (``T >= 0``), at
``g = -ε2`` backward (``T <= 0``), and in between ``T = 0``, so the node relaxes through
``c_S`` with time constant ``c_S/k_S`` (4.5 ms) while the flywheel coasts against ``c_B``.

Integration (see :mod:`plants.tmdi.kernel`): trapezoidal rule with the gap's open/closed
switches located inside the step by linear interpolation; the drive between loop samples is the
cubic Hermite interpolant of ``(u, v)``; the number of sub-steps per call follows from the model's
own time scales (:meth:`RackPinionParameters.max_substep`), so any caller ``dt`` is accepted.
The Coulomb friction is regularised, ``f_y tanh(u̇_T / v_eps)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Final

import numpy as np

from plants.tmdi import kernel as kern
from plants.base import Specimen
from rths.core.errors import ParameterError, check_nonnegative, check_positive, format_choices

__all__ = [
    "FLYWHEELS",
    "IdealInerter",
    "RackPinionInerter",
    "RackPinionParameters",
    "S1_IDEAL_INERTANCE",
    "S1_RACK_PINION",
    "ideal_inerter_preset",
    "rack_pinion_preset",
]

#: Nominal inertance [kg] of the S1 flywheel variants, S1 §2.2 and Table 1 (β = b / 125 kg):
#: no flywheel (NF, β = 0.001), intermediate (IF, β = 0.383), large (LF, β = 0.765).
FLYWHEELS: Final[dict[str, float]] = {"NF": 0.1, "IF": 47.9, "LF": 95.6}

#: Inertance [kg] of the ideal-inerter variant of the S1 model (IF specimen), S1 §4.2.
S1_IDEAL_INERTANCE: Final[float] = 48.7

#: Fraction of the shortest model time scale used as the largest internal sub-step.
SUBSTEP_FRACTION: Final[float] = 0.25


@dataclass(frozen=True, slots=True)
class RackPinionParameters:
    """Parameters of the rack-and-pinion flywheel inerter, S1 Eq.9-11 and Fig.16.

    Defaults are the S1 §4.2 values of the IF device.

    Parameters
    ----------
    pinion_radius
        ``r_P`` [m]; ``θ_P = u_T / r_P``.
    flywheel_inertia
        ``J_B`` [kg m^2], as seen at the pinion shaft (gearbox included).
    series_stiffness
        ``k_S`` [N m/rad] of the visco-elastic element between pinion and gap.
    series_damping
        ``c_S`` [N m s/rad] of that element (0 makes the node follow the pinion rigidly while
        the gap is open).
    clearance_forward
        ``ε1`` [rad]: play before the node drives the flywheel forward.
    clearance_backward
        ``ε2`` [rad]: play before the node drives the flywheel backward.
    flywheel_damping
        ``c_B`` [N m s/rad], parasitic viscous damping of the flywheel.
    friction_force
        ``f_y`` [N], Coulomb friction of the rack.
    friction_velocity
        ``v_eps`` [m/s] of the regularisation ``f_y tanh(u̇_T / v_eps)``; below it the
        friction grows linearly.  The hysteresis loop of a sinusoid of amplitude ``A`` and
        frequency ``ω`` loses a fraction ``(π²/24)(v_eps/(Aω))²`` of ``4 f_y A``.
    """

    pinion_radius: float = 0.018
    flywheel_inertia: float = 1.55e-2
    series_stiffness: float = 187.16
    series_damping: float = 0.85
    clearance_forward: float = 0.0084
    clearance_backward: float = 0.0056
    flywheel_damping: float = 0.03
    friction_force: float = 7.3
    friction_velocity: float = 1e-3

    def __post_init__(self) -> None:
        check_positive(self.pinion_radius, "pinion radius r_P")
        check_positive(self.flywheel_inertia, "flywheel inertia J_B")
        check_positive(self.series_stiffness, "series stiffness k_S")
        check_nonnegative(self.series_damping, "series damping c_S")
        check_nonnegative(self.clearance_forward, "forward clearance eps1")
        check_nonnegative(self.clearance_backward, "backward clearance eps2")
        check_nonnegative(self.flywheel_damping, "flywheel damping c_B")
        check_nonnegative(self.friction_force, "friction force f_y")
        check_positive(self.friction_velocity, "friction regularisation velocity v_eps")

    @property
    def nominal_inertance(self) -> float:
        """Rigid-limit inertance ``b = J_B / r_P²`` [kg]."""
        return self.flywheel_inertia / self.pinion_radius**2

    @property
    def total_clearance(self) -> float:
        """Total play ``ε1 + ε2`` [rad]."""
        return self.clearance_forward + self.clearance_backward

    def max_substep(self) -> float:
        """Largest internal sub-step [s]: a quarter of the shortest time scale of the device.

        The scales are the node relaxation ``c_S/k_S``, the flywheel's viscous time
        ``J_B/(c_S + c_B)`` and the inverse contact frequency ``sqrt(J_B/k_S)``.
        """
        scales = [math.sqrt(self.flywheel_inertia / self.series_stiffness)]
        if self.series_damping > 0.0:
            scales.append(self.series_damping / self.series_stiffness)
        if self.series_damping + self.flywheel_damping > 0.0:
            scales.append(self.flywheel_inertia / (self.series_damping + self.flywheel_damping))
        return SUBSTEP_FRACTION * min(scales)


#: The identified IF device of S1 §4.2 (``J_B / r_P² = 47.8 kg``).
S1_RACK_PINION: Final[RackPinionParameters] = RackPinionParameters()


def _check_flywheel(flywheel: str) -> float:
    if flywheel not in FLYWHEELS:
        raise ParameterError(
            f"flywheel must be one of {format_choices(list(FLYWHEELS))}; got {flywheel!r}"
        )
    return FLYWHEELS[flywheel] / FLYWHEELS["IF"]


def rack_pinion_preset(flywheel: str = "IF") -> RackPinionParameters:
    """The S1 §4.2 device with the flywheel of S1 Table 1 (``"NF"``, ``"IF"``, ``"LF"``).

    Only the IF device was identified (S1 §4.2); NF and LF scale ``J_B`` by the ratio of
    nominal inertances (0.1 / 47.9 and 95.6 / 47.9), keeping the transmission parameters.
    """
    return replace(
        S1_RACK_PINION, flywheel_inertia=S1_RACK_PINION.flywheel_inertia * _check_flywheel(flywheel)
    )


def ideal_inerter_preset(flywheel: str = "IF") -> float:
    """Inertance [kg] of the ideal-inerter model for an S1 flywheel variant.

    48.7 kg for IF (S1 §4.2), scaled by the nominal ratio of S1 Table 1 for NF and LF.
    """
    return S1_IDEAL_INERTANCE * _check_flywheel(flywheel)


class IdealInerter(Specimen):
    """Ideal linear inerter ``F = b ü`` (S1 Fig.1a) with one end grounded.

    Parameters
    ----------
    inertance
        ``b`` [kg]; positive.
    """

    kind = "ideal_inerter"

    def __init__(self, inertance: float = S1_IDEAL_INERTANCE) -> None:
        self.inertance: float = check_positive(inertance, "inertance b")

    @property
    def rigid_inertance(self) -> float:
        """The whole force is rigid: ``b`` [kg]."""
        return self.inertance

    def reset(self) -> None:
        """Stateless: nothing to reset."""

    def _step_impl(self, u: float, v: float, a: float, dt: float) -> float:
        return self.inertance * a


class RackPinionInerter(Specimen):
    """Rack-and-pinion flywheel inerter with play, friction and series compliance, S1 Eq.9-11.

    See the module docstring for the sign convention and the scheme.

    Parameters
    ----------
    parameters
        Device parameters; the S1 §4.2 IF device by default.
    """

    kind = "rack_pinion_inerter"

    def __init__(self, parameters: RackPinionParameters = S1_RACK_PINION) -> None:
        if not isinstance(parameters, RackPinionParameters):
            raise ParameterError(
                f"parameters must be RackPinionParameters; got {type(parameters).__name__}"
            )
        self.parameters: Final[RackPinionParameters] = parameters
        self._p = kern.pack_parameters(device=parameters)
        self._state = np.zeros(kern.N_STATE)
        self._input = np.zeros(kern.N_INPUT)
        self._input[kern.I_DRIVEN] = 1.0
        self._substeps: dict[float, int] = {}
        self.reset()

    def reset(self) -> None:
        """Rest at ``u = 0`` with zero gap ``θ_S = θ_G = 0`` (inside the play ``[-ε2, ε1]``, or
        closed if there is no play)."""
        self._state[:] = 0.0
        no_play = self.parameters.total_clearance == 0.0
        self._state[kern.S_MODE] = kern.FORWARD if no_play else kern.OPEN
        self._torque = 0.0

    def substeps(self, dt: float) -> int:
        """Number of internal sub-steps taken over a call of length ``dt`` [s]."""
        n = self._substeps.get(dt)
        if n is None:
            n = max(1, math.ceil(dt / self.parameters.max_substep() - 1e-9))
            self._substeps[dt] = n
        return n

    def _step_impl(self, u: float, v: float, a: float, dt: float) -> float:
        if not (dt > 0.0 and math.isfinite(dt)):
            raise ParameterError(f"time step dt must be positive; got {dt!r}")
        if not (math.isfinite(u) and math.isfinite(v)):
            raise ParameterError(f"drive state must be finite; got u={u!r}, v={v!r}")
        inp = self._input
        inp[kern.I_U0] = self._state[kern.S_U_T]
        inp[kern.I_V0] = self._state[kern.S_V_T]
        inp[kern.I_U1] = u
        inp[kern.I_V1] = v
        if kern.step(self._state, dt, self.substeps(dt), inp, self._p):
            raise kern.IntegrationError(
                f"rack-and-pinion step failed to converge with dt={dt!r}, u={u!r}, v={v!r}"
            )
        mode = int(self._state[kern.S_MODE])
        self._torque = kern.torque(self._state, mode, self._p)
        return kern.friction(v, self._p) + self._torque / self.parameters.pinion_radius

    def state(self) -> dict[str, float]:
        """Node and flywheel angles [rad], flywheel speed [rad/s], gap [rad], torque [N m],
        contact (-1 backward, 0 open, +1 forward) and friction force [N]."""
        s = self._state
        return {
            "theta_S": float(s[kern.S_TH_S]),
            "theta_G": float(s[kern.S_TH_G]),
            "omega_G": float(s[kern.S_OM_G]),
            "gap": float(s[kern.S_TH_S] - s[kern.S_TH_G]),
            "torque": float(self._torque),
            "contact": float(s[kern.S_MODE]),
            "friction": float(kern.friction(s[kern.S_V_T], self._p)),
        }
