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

Integration (see :mod:`plants.tmdi.integration.kernel`): trapezoidal rule with the gap's open/closed
switches located inside the step by linear interpolation; the drive between loop samples is the
cubic Hermite interpolant of ``(u, v)``; the number of sub-steps per call follows from the model's
own time scales (:meth:`RackPinionParameters.max_substep`), so any caller ``dt`` is accepted.
The Coulomb friction is regularised, ``f_y tanh(u̇_T / v_eps)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Final

import numpy as np

from plants.base import Specimen
from plants.tmdi.integration import kernel as kern
from plants.tmdi.integration import laws, layout
from plants.tmdi.parameters import (
    FLYWHEELS,
    S1_IDEAL_INERTANCE,
    S1_RACK_PINION,
    RackPinionParameters,
    ideal_inerter_preset,
    rack_pinion_preset,
)
from rths.core.errors import (
    ParameterError,
    check_positive,
)
from rths.core.registry import SPECIMENS

__all__ = [
    "FLYWHEELS",
    "IdealInerter",
    "IdealInerterOptions",
    "RackPinionInerter",
    "RackPinionParameters",
    "S1_IDEAL_INERTANCE",
    "S1_RACK_PINION",
    "ideal_inerter_preset",
    "rack_pinion_preset",
]


@dataclass(frozen=True)
class IdealInerterOptions:
    """Options of the ``ideal_inerter`` specimen kind.

    Parameters
    ----------
    inertance
        ``b`` [kg], > 0 (default: S1 §4.2's 48.7 kg for the IF device).
    """

    inertance: float = S1_IDEAL_INERTANCE

    def __post_init__(self) -> None:
        check_positive(self.inertance, "inertance b")


@SPECIMENS.register("ideal_inerter", IdealInerterOptions)
class IdealInerter(Specimen):
    """Ideal linear inerter ``F = b ü`` (S1 Fig.1a) with one end grounded.

    Parameters
    ----------
    inertance
        ``b`` [kg]; positive.
    """

    def __init__(self, inertance: float = S1_IDEAL_INERTANCE) -> None:
        super().__init__()
        self.inertance: float = check_positive(inertance, "inertance b")

    @classmethod
    def from_options(cls, options: IdealInerterOptions, **_: object) -> IdealInerter:
        """The ``ideal_inerter`` kind."""
        return cls(options.inertance)

    @property
    def rigid_inertance(self) -> float:
        """The whole force is rigid: ``b`` [kg]."""
        return self.inertance

    def _reset_impl(self) -> None:
        """Stateless: nothing to reset."""

    def _step_impl(self, u: float, v: float, a: float, dt: float) -> float:
        return self.inertance * a


@SPECIMENS.register("rack_pinion", RackPinionParameters)
class RackPinionInerter(Specimen):
    """Rack-and-pinion flywheel inerter with play, friction and series compliance, S1 Eq.9-11.

    See the module docstring for the sign convention and the scheme.

    Parameters
    ----------
    parameters
        Device parameters; the S1 §4.2 IF device by default.
    """

    def __init__(self, parameters: RackPinionParameters = S1_RACK_PINION) -> None:
        super().__init__()
        if not isinstance(parameters, RackPinionParameters):
            raise ParameterError(
                f"parameters must be RackPinionParameters; got {type(parameters).__name__}"
            )
        self.parameters: Final[RackPinionParameters] = parameters
        self._p = layout.pack_parameters(device=parameters)
        self._state = np.zeros(layout.N_STATE)
        self._input = np.zeros(layout.N_INPUT)
        self._input[layout.I_DRIVEN] = 1.0
        self._substeps: dict[float, int] = {}
        self.reset()

    @classmethod
    def from_options(cls, options: RackPinionParameters, **_: object) -> RackPinionInerter:
        """The ``rack_pinion`` kind."""
        return cls(options)

    def _reset_impl(self) -> None:
        """Rest at ``u = 0`` with zero gap ``θ_S = θ_G = 0`` (inside the play ``[-ε2, ε1]``, or
        closed if there is no play)."""
        self._state[:] = 0.0
        no_play = self.parameters.total_clearance == 0.0
        self._state[layout.S_MODE] = layout.FORWARD if no_play else layout.OPEN
        self._torque = 0.0

    def substeps(self, dt: float) -> int:
        """Number of internal sub-steps taken over a call of length ``dt`` [s]."""
        n = self._substeps.get(dt)
        if n is None:
            n = max(1, math.ceil(dt / self.parameters.max_substep() - 1e-9))
            self._substeps[dt] = n
        return n

    def _step_impl(self, u: float, v: float, a: float, dt: float) -> float:
        inp = self._input
        inp[layout.I_U0] = self._state[layout.S_U_T]
        inp[layout.I_V0] = self._state[layout.S_V_T]
        inp[layout.I_U1] = u
        inp[layout.I_V1] = v
        if kern.step(self._state, dt, self.substeps(dt), inp, self._p):
            raise kern.IntegrationError(
                f"rack-and-pinion step failed to converge with dt={dt!r}, u={u!r}, v={v!r}"
            )
        mode = int(self._state[layout.S_MODE])
        self._torque = laws.torque(self._state, mode, self._p)
        return laws.friction(v, self._p) + self._torque / self.parameters.pinion_radius

    def state(self) -> dict[str, float]:
        """Node and flywheel angles [rad], flywheel speed [rad/s], gap [rad], torque [N m],
        contact (-1 backward, 0 open, +1 forward) and friction force [N]."""
        s = self._state
        return {
            "theta_S": float(s[layout.S_TH_S]),
            "theta_G": float(s[layout.S_TH_G]),
            "omega_G": float(s[layout.S_OM_G]),
            "gap": float(s[layout.S_TH_S] - s[layout.S_TH_G]),
            "torque": float(self._torque),
            "contact": float(s[layout.S_MODE]),
            "friction": float(laws.friction(s[layout.S_V_T], self._p)),
        }
