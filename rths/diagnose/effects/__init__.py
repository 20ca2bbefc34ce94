"""Candidate effects: what a nominal model may lack, as grey-box extensions of it.

======================  =========  ============================================  ===============
effect                  subsystem  parameters (reported, SI)                     form
======================  =========  ============================================  ===============
actuator_delay          actuator   delay [s] beyond the nominal (> 1 sample)     pure delay
rate_limit              actuator   velocity_limit [m/s]                          flow limit
coulomb_friction        specimen   friction [N], presliding_stiffness [N/m]      elasto-plastic
backlash                specimen   gap [m] (total clearance), stiffness [N/m]    dead zone +
                                   (contact), contact_damping [N s/m],           contact p^n
                                   exponent n [-]                                (1 or 3/2)
internal_stiffness      specimen   stiffness [N/m], series_damping [N s/m],      series spring
                                   frequency [Hz]                                (S0 Eq.12)
amplitude_damping       specimen   c1 [N s], c2 [m] of ``c1/(A + c2)``           S0 Eq.17-18
======================  =========  ============================================  ===============

A channel's model is its re-calibrated baseline (NOMINAL.toml's own parameters, within the
tolerance of :data:`rths.diagnose.effects.specimen.NOMINAL_TOLERANCE` for the specimen and
:data:`rths.diagnose.effects.actuator.CALIBRATION_TOLERANCE` for the actuator) extended by a
set of effects, built by :func:`models_for`:

``measured``  :class:`~rths.diagnose.effects.actuator.ActuatorModel` (any subset).
``force``     without a series element (no backlash / internal stiffness) the rigid family
              :class:`~rths.diagnose.effects.specimen.RigidSpecimen` (friction, amplitude
              damping -- linear in their levels, fast); with one the inertial chain
              :class:`~rths.diagnose.effects.chain.SeriesChain` (drive -> element -> body
              carrying damping, friction, amplitude damping); friction behind a clearance is
              also tried as the massless play of :class:`RigidSpecimen` (a friction damper
              whose inertia is negligible); a backlash without friction also with a Hertz
              contact (force ~ penetration^(3/2)).  Backlash and internal stiffness share the
              element, so a model holds at most one of them.
``displacement``  the specimen the other way round, force -> displacement
              (:class:`~rths.diagnose.effects.compliance.ComplianceModel`): a stiff series
              element, which no displacement-driven replay can follow, seen from the force.

An effect is named "present" by the greedy selection of :mod:`rths.diagnose.search.selection`
only when it closes enough of the held-out gap for its parameters.
"""

from __future__ import annotations

from dataclasses import dataclass

from rths.core.errors import ParameterError
from rths.diagnose.effects.actuator import ActuatorModel
from rths.diagnose.effects.calibration import RootwiseActuator, absorbed_lag
from rths.diagnose.effects.chain import SeriesChain
from rths.diagnose.effects.compliance import ComplianceModel
from rths.diagnose.effects.model import Columns, Model, Param, Theta
from rths.diagnose.effects.specimen import RigidSpecimen

__all__ = [
    "CHANNEL_EFFECTS",
    "EFFECTS",
    "NESTS",
    "ActuatorModel",
    "ComplianceModel",
    "Columns",
    "Effect",
    "Model",
    "Param",
    "RigidSpecimen",
    "RootwiseActuator",
    "SeriesChain",
    "Theta",
    "absorbed_lag",
    "baseline_for",
    "calibration_for",
    "compatible",
    "models_for",
]


@dataclass(frozen=True)
class Effect:
    """One candidate effect.

    Attributes
    ----------
    name
        The verdict name users see.
    subsystem
        ``actuator`` or ``specimen``.
    params
        The reported parameter names (SI).
    n_params
        Parameters counted by the selection's price (the identified ones).
    """

    name: str
    subsystem: str
    params: tuple[str, ...]
    n_params: int


#: The candidate effects by verdict name.
EFFECTS: dict[str, Effect] = {
    e.name: e
    for e in (
        Effect("internal_stiffness", "specimen", ("stiffness", "series_damping", "frequency"), 2),
        Effect("backlash", "specimen", ("gap", "stiffness", "contact_damping"), 3),
        Effect("coulomb_friction", "specimen", ("friction", "presliding_stiffness"), 2),
        Effect("amplitude_damping", "specimen", ("c1", "c2"), 2),
        Effect("actuator_delay", "actuator", ("delay",), 1),
        Effect("rate_limit", "actuator", ("velocity_limit",), 1),
    )
}

_ELEMENTS = frozenset({"backlash", "internal_stiffness"})

#: Effects whose model holds another one as a limit (``{general: special}``): a backlash
#: whose clearance closes is a series spring with its own damping (``internal_stiffness``).
#: The selection takes the general one only when it beats the special one by the price of its
#: extra parameters (:func:`rths.diagnose.search.selection.select`).
NESTS: dict[str, str] = {"backlash": "internal_stiffness"}


def compatible(effects: tuple[str, ...]) -> bool:
    """Whether one model can hold all of ``effects`` (one subsystem, one series element).

    Parameters
    ----------
    effects
        Effect names (keys of :data:`EFFECTS`).
    """
    if len({EFFECTS[e].subsystem for e in effects}) > 1:
        return False
    return len(_ELEMENTS.intersection(effects)) <= 1


#: The effects each channel's models can hold.
CHANNEL_EFFECTS: dict[str, tuple[str, ...]] = {
    "measured": ("actuator_delay", "rate_limit"),
    "force": ("internal_stiffness", "backlash", "coulomb_friction", "amplitude_damping"),
    "displacement": ("internal_stiffness", "backlash"),
}


def baseline_for(channel: str) -> Model:
    """The re-calibrated nominal model of a channel.

    Parameters
    ----------
    channel
        ``"measured"`` (actuator), ``"force"`` or ``"displacement"`` (specimen).
    """
    if channel == "measured":
        return ActuatorModel()
    return ComplianceModel() if channel == "displacement" else RigidSpecimen()


def calibration_for(channel: str, effects: tuple[str, ...] = ()) -> RootwiseActuator | None:
    """The channel's finer re-calibration of NOMINAL.toml's own parameters that tells model form
    from an unexplained gap (:mod:`rths.diagnose.effects.calibration`), or None.

    Parameters
    ----------
    channel
        ``"measured"``, ``"force"`` or ``"displacement"``.
    effects
        Effects the calibrated model holds besides (default none).
    """
    return RootwiseActuator(effects) if channel == "measured" else None


def models_for(channel: str, effects: tuple[str, ...]) -> list[Model]:
    """The model structures of a channel that hold ``effects`` (module docstring); tried in
    turn.

    Parameters
    ----------
    channel
        ``"measured"``, ``"force"`` or ``"displacement"``.
    effects
        The effects the models must hold (:data:`CHANNEL_EFFECTS` of the channel).

    Raises
    ------
    ParameterError
        For an unknown or incompatible set, or one the channel's models cannot hold.
    """
    allowed = CHANNEL_EFFECTS.get(channel, ())
    if not compatible(effects) or any(e not in allowed for e in effects):
        raise ParameterError(f"no {channel} channel model holds the effects {effects!r}")
    if channel == "measured":
        if "rate_limit" in effects:  # a limiter on the motion, or on the flow inside the loop
            return [ActuatorModel(effects, "output"), ActuatorModel(effects, "loop")]
        return [ActuatorModel(effects)]
    if channel == "displacement":
        return [ComplianceModel(effects)]
    element = _ELEMENTS.intersection(effects)
    if not element:
        return _rigid(effects)
    out: list[Model] = [SeriesChain(effects)]
    if "backlash" in effects and "coulomb_friction" not in effects:
        # a friction device behind a clearance has three structures already (its contact is
        # the friction's presliding spring, no impact law)
        out.append(SeriesChain(effects, contact="hertz"))
    if "coulomb_friction" in effects:
        out.append(SeriesChain(effects, friction_at="drive"))
        if element == {"backlash"}:
            out += _rigid(effects)  # massless friction behind a clearance
    return out


def _rigid(effects: tuple[str, ...]) -> list[Model]:
    """The rigid structures of ``effects``: beside a dissipation law both the nominal's
    damping within its tolerance and a free one (priced by the selection)."""
    if {"coulomb_friction", "amplitude_damping"}.isdisjoint(effects):
        return [RigidSpecimen(effects)]
    return [RigidSpecimen(effects, damping="nominal"), RigidSpecimen(effects)]
