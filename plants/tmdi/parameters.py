"""Parameters of the S1 system: the S1 Eq.12 structure without the inerter (documented in
:mod:`plants.tmdi.structure`) and the rack-and-pinion inerter of S1 Eq.9-11 with its presets
(documented in :mod:`plants.tmdi.inerter`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Final

from plants.tmdi.hdrb import HDRB, S1_PRIMARY
from rths.core.errors import (
    ParameterError,
    check_nonnegative,
    check_positive,
    format_choices,
)

__all__ = [
    "FLYWHEELS",
    "PRIMARY_MASS",
    "S1_IDEAL_INERTANCE",
    "S1_RACK_PINION",
    "SECONDARY_MASSES",
    "RackPinionParameters",
    "TMDIParameters",
    "ideal_inerter_preset",
    "rack_pinion_preset",
]

#: Primary mass m_I [kg], S1 §2.2.
PRIMARY_MASS: Final[float] = 125.0
#: Secondary masses m_T [kg] of S1 Table 1 (μ = m_T / m_I = 0.048, 0.080, 0.160).
SECONDARY_MASSES: Final[dict[str, float]] = {"SM": 6.0, "IM": 10.0, "LM": 20.0}


@dataclass(frozen=True, slots=True)
class TMDIParameters:
    """The structure of S1 Eq.12 without the inerter.

    Parameters
    ----------
    primary_mass
        ``m_I`` [kg].
    primary_isolator
        Primary HDRB (S1 Eq.8).
    secondary_mass
        ``m_T`` [kg]; 0 for the uncontrolled primary structure (PS).
    secondary_isolator
        Secondary HDRB; required when ``secondary_mass > 0``, ignored otherwise.
    """

    primary_mass: float = PRIMARY_MASS
    primary_isolator: HDRB = S1_PRIMARY
    secondary_mass: float = 0.0
    secondary_isolator: HDRB | None = None

    def __post_init__(self) -> None:
        check_positive(self.primary_mass, "primary mass m_I")
        check_nonnegative(self.secondary_mass, "secondary mass m_T")
        if not isinstance(self.primary_isolator, HDRB):
            raise ParameterError(
                f"primary isolator must be an HDRB; got {type(self.primary_isolator).__name__}"
            )
        if self.secondary_mass > 0.0 and not isinstance(self.secondary_isolator, HDRB):
            raise ParameterError(
                "secondary isolator must be an HDRB when the secondary mass is "
                f"{self.secondary_mass!r} kg; got {self.secondary_isolator!r}"
            )

    @property
    def has_tmd(self) -> bool:
        """True when a secondary mass (TMD/TMDI) is attached."""
        return self.secondary_mass > 0.0

    @property
    def mass_ratio(self) -> float:
        """``μ = m_T / m_I`` [-]."""
        return self.secondary_mass / self.primary_mass

    def linear(self) -> TMDIParameters:
        """The same structure with linear isolators (``k2 = k3 = 0``, constant dashpots ``c``)."""
        iso = self.secondary_isolator.linear() if self.secondary_isolator is not None else None
        return TMDIParameters(
            self.primary_mass, self.primary_isolator.linear(), self.secondary_mass, iso
        )


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

    @staticmethod
    def presets() -> tuple[str, ...]:
        """Scenario-file presets: the S1 Table 1 flywheels (:func:`rack_pinion_preset`)."""
        return tuple(FLYWHEELS)

    @classmethod
    def from_preset(cls, name: str, **overrides: object) -> RackPinionParameters:
        """The device of :func:`rack_pinion_preset` with some fields replaced."""
        return replace(rack_pinion_preset(name), **overrides)  # type: ignore[arg-type]

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

    Parameters
    ----------
    flywheel : {"IF", "NF", "LF"}, default "IF"
        The flywheel variant of S1 Table 1: none (NF, nominal ``b = 0.1 kg``), intermediate
        (IF, 47.9 kg) or large (LF, 95.6 kg).

    Raises
    ------
    ParameterError
        If ``flywheel`` is not one of the three.
    """
    return replace(
        S1_RACK_PINION, flywheel_inertia=S1_RACK_PINION.flywheel_inertia * _check_flywheel(flywheel)
    )


def ideal_inerter_preset(flywheel: str = "IF") -> float:
    """Inertance [kg] of the ideal-inerter model for an S1 flywheel variant.

    48.7 kg for IF (S1 §4.2), scaled by the nominal ratio of S1 Table 1 for NF and LF.

    Parameters
    ----------
    flywheel : {"IF", "NF", "LF"}, default "IF"
        The flywheel variant of S1 Table 1: none (NF, nominal ``b = 0.1 kg``), intermediate
        (IF, 47.9 kg) or large (LF, 95.6 kg).

    Raises
    ------
    ParameterError
        If ``flywheel`` is not one of the three.
    """
    return S1_IDEAL_INERTANCE * _check_flywheel(flywheel)
