"""Parameters of the taut cable model (private; re-exported by :mod:`plants.cable`).

Cable properties, the S0 Eq.23 damper normalisation, the S0 Eq.22 load, Rayleigh intrinsic
damping and the optional point damper inside the FE model.  SI units throughout.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from rths.errors import (
    ParameterError,
    check_finite,
    check_nonnegative,
    check_positive,
    check_positive_int,
)

__all__ = [
    "CableProperties",
    "DistributedLoad",
    "PointDamper",
    "RayleighDamping",
    "normalised_damper",
    "physical_damper",
]


def _store(instance: object, name: str, value: object) -> None:
    """Replace a frozen dataclass field by its validated (coerced) value."""
    object.__setattr__(instance, name, value)


@dataclass(frozen=True, slots=True)
class CableProperties:
    """A taut cable: ``length`` [m], ``tension`` [N] and ``mass_per_length`` [kg/m]."""

    length: float
    tension: float
    mass_per_length: float

    def __post_init__(self) -> None:
        _store(self, "length", check_positive(self.length, "cable length L"))
        _store(self, "tension", check_positive(self.tension, "cable tension T"))
        mass = check_positive(self.mass_per_length, "cable mass per length m")
        _store(self, "mass_per_length", mass)

    @property
    def wave_speed(self) -> float:
        """Transverse wave speed ``c = sqrt(T/m)`` [m/s]."""
        return math.sqrt(self.tension / self.mass_per_length)

    @property
    def fundamental_frequency(self) -> float:
        """First natural frequency ``f1 = c/(2L)`` [Hz]."""
        return self.wave_speed / (2.0 * self.length)

    @property
    def omega0(self) -> float:
        """First natural circular frequency ``omega0 = pi c/L`` [rad/s]."""
        return math.pi * self.wave_speed / self.length

    @property
    def mass(self) -> float:
        """Total mass ``m L`` [kg]."""
        return self.mass_per_length * self.length


def normalised_damper(
    properties: CableProperties, inertance: float, damping: float
) -> tuple[float, float]:
    """Normalised damper parameters ``(m_e, c_d)`` of S0 Eq.23 from physical ones.

    .. math:: m_e = \\frac{\\bar m_e L \\omega_0^2}{\\pi^2 T}, \\qquad
              c_d = \\frac{\\bar c_d L \\omega_0}{\\pi^2 T}

    which for a taut string equal ``mbar_e/(m L)`` and ``cbar_d/(pi sqrt(T m))``.

    Parameters
    ----------
    properties
        The cable.
    inertance
        Inertance ``mbar_e`` [kg], >= 0.
    damping
        Viscous coefficient ``cbar_d`` [N s/m], >= 0.
    """
    m_bar = check_nonnegative(inertance, "damper inertance")
    c_bar = check_nonnegative(damping, "damper damping coefficient")
    p, w0 = properties, properties.omega0
    scale = p.length / (math.pi**2 * p.tension)
    return m_bar * scale * w0**2, c_bar * scale * w0


def physical_damper(properties: CableProperties, m_e: float, c_d: float) -> tuple[float, float]:
    """Physical ``(inertance [kg], damping [N s/m])`` from normalised ``(m_e, c_d)`` (S0 Eq.23)."""
    m_e = check_nonnegative(m_e, "normalised inertance m_e")
    c_d = check_nonnegative(c_d, "normalised damping c_d")
    p, w0 = properties, properties.omega0
    scale = math.pi**2 * p.tension / p.length
    return m_e * scale / w0**2, c_d * scale / w0


@dataclass(frozen=True, slots=True)
class DistributedLoad:
    """Distributed load ``p(x,t) = amplitude sin(n pi x/L) sin(frequency t)`` (S0 Eq.22).

    Attributes
    ----------
    amplitude
        ``p0`` [N/m]; zero gives an unloaded cable.
    mode
        ``n``, the mode whose shape the load has.
    frequency
        ``Omega`` [rad/s]; ``None`` means resonance with the string, ``n omega0``.
    """

    amplitude: float = 0.0
    mode: int = 1
    frequency: float | None = None

    def __post_init__(self) -> None:
        _store(self, "amplitude", check_finite(self.amplitude, "load amplitude p0"))
        check_positive_int(self.mode, "load mode n")
        if self.frequency is not None:
            _store(self, "frequency", check_nonnegative(self.frequency, "load frequency Omega"))


@dataclass(frozen=True, slots=True)
class RayleighDamping:
    """Intrinsic damping ``ratio`` [-] at the string modes ``modes`` (Rayleigh, ``a0 M + a1 K``)."""

    ratio: float = 0.001
    modes: tuple[int, int] = (1, 3)

    def __post_init__(self) -> None:
        ratio = check_finite(self.ratio, "intrinsic damping ratio")
        if not 0.0 <= ratio < 1.0:
            raise ParameterError(f"intrinsic damping ratio must lie in [0, 1); got {self.ratio!r}")
        _store(self, "ratio", ratio)
        modes = tuple(self.modes) if isinstance(self.modes, (tuple, list)) else ()
        if len(modes) != 2 or modes[0] == modes[1]:
            raise ParameterError(
                f"Rayleigh anchor modes must be two distinct modes; got {self.modes!r}"
            )
        for n in modes:
            check_positive_int(n, "Rayleigh anchor mode")
        _store(self, "modes", modes)


@dataclass(frozen=True, slots=True)
class PointDamper:
    """Grounded damper inside the FE model: inertance [kg] and viscous coefficient [N s/m]."""

    inertance: float = 0.0
    damping: float = 0.0

    def __post_init__(self) -> None:
        _store(self, "inertance", check_nonnegative(self.inertance, "damper inertance"))
        _store(self, "damping", check_nonnegative(self.damping, "damper damping coefficient"))
