"""Parameters of the taut cable model (private; re-exported by :mod:`plants.cable.model`).

Cable properties, the S0 Eq.23 damper normalisation, the S0 Eq.22 load, Rayleigh intrinsic
damping and the optional nominal interface device inside the FE model.  SI units throughout.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rths.core.errors import (
    ParameterError,
    check_finite,
    check_nonnegative,
    check_positive,
    check_positive_int,
)

__all__ = [
    "CableProperties",
    "DistributedLoad",
    "InterfaceDevice",
    "PointDamper",
    "RayleighDamping",
    "normalised_damper",
    "normalised_stiffness",
    "physical_damper",
    "physical_stiffness",
]


def _store(instance: object, name: str, value: object) -> None:
    """Replace a frozen dataclass field by its validated (coerced) value."""
    object.__setattr__(instance, name, value)


@dataclass(frozen=True, slots=True)
class CableProperties:
    """A taut cable: ``length`` [m], ``tension`` [N] and ``mass_per_length`` [kg/m].

    The cable is a taut string (no bending stiffness, no sag), the numerical substructure of
    S0 §5.1; the symbols are those of S0 Eq.23.

    Attributes
    ----------
    length : float
        Cable length ``L`` [m], > 0 (S0 Eq.23).
    tension : float
        Cable tension ``T`` [N], > 0 (S0 Eq.23).
    mass_per_length : float
        Mass per unit length ``m`` [kg/m], > 0.
    """

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
    """Physical ``(inertance [kg], damping [N s/m])`` from normalised ``(m_e, c_d)`` (S0 Eq.23).

    The inverse of :func:`normalised_damper`:
    ``mbar_e = m_e pi^2 T/(L omega0^2)``, ``cbar_d = c_d pi^2 T/(L omega0)``.

    Parameters
    ----------
    properties : CableProperties
        The cable (``L`` [m], ``T`` [N] and, through ``omega0``, ``m`` [kg/m]).
    m_e : float
        Normalised inertance ``m_e`` [-], >= 0 (S0 Eq.23; the S0 optimum is 0.53).
    c_d : float
        Normalised damping coefficient ``c_d`` [-], >= 0 (S0 Eq.23; note S0 quotes the product
        ``c_d x_d``, e.g. 0.015 at ``x_d = 0.02``).
    """
    m_e = check_nonnegative(m_e, "normalised inertance m_e")
    c_d = check_nonnegative(c_d, "normalised damping c_d")
    p, w0 = properties, properties.omega0
    scale = math.pi**2 * p.tension / p.length
    return m_e * scale / w0**2, c_d * scale / w0


def normalised_stiffness(properties: CableProperties, stiffness: float) -> float:
    """Normalised stiffness ``k_e = kbar L/(pi^2 T)`` [-] of a spring ``kbar`` [N/m] at the damper.

    The S0 Eq.23 scaling of a dynamic stiffness (``m_e`` is ``mbar_e omega0^2`` scaled the same
    way), so a device with inertance ``m_e`` behind a spring ``k_e`` has its own frequency
    ``sqrt(k_e/m_e) omega0``, i.e. the normalised wavenumber ``pi sqrt(k_e/m_e)``.

    Parameters
    ----------
    properties : CableProperties
        The cable (``L`` [m], ``T`` [N]).
    stiffness : float
        Physical stiffness ``kbar`` [N/m], > 0 (e.g. the IMD's ``k0`` of S0 Eq.5).
    """
    k_bar = check_positive(stiffness, "series stiffness")
    return k_bar * properties.length / (math.pi**2 * properties.tension)


def physical_stiffness(properties: CableProperties, k_e: float) -> float:
    """Physical stiffness ``kbar = pi^2 T k_e/L`` [N/m] from the normalised ``k_e`` (inverse of
    :func:`normalised_stiffness`).

    Parameters
    ----------
    properties : CableProperties
        The cable (``L`` [m], ``T`` [N]).
    k_e : float
        Normalised stiffness ``k_e = kbar L/(pi^2 T)`` [-], > 0.
    """
    k_e = check_positive(k_e, "normalised series stiffness k_e")
    return math.pi**2 * properties.tension * k_e / properties.length


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
    duration
        Time [s] after which the load is zero (free vibration); ``None``: it never stops.
    """

    amplitude: float = 0.0
    mode: int = 1
    frequency: float | None = None
    duration: float | None = None

    def __post_init__(self) -> None:
        _store(self, "amplitude", check_finite(self.amplitude, "load amplitude p0"))
        check_positive_int(self.mode, "load mode n")
        if self.frequency is not None:
            _store(self, "frequency", check_nonnegative(self.frequency, "load frequency Omega"))
        if self.duration is not None:
            _store(self, "duration", check_positive(self.duration, "load duration"))


@dataclass(frozen=True, slots=True)
class RayleighDamping:
    """Intrinsic damping ``ratio`` [-] at the string modes ``modes`` (Rayleigh, ``a0 M + a1 K``).

    The cable's own damping (S0 §5.1, "cable element with distributed mass and intrinsic
    damping"), applied to the string alone; the coefficients follow from
    :func:`plants.cable.fe.rayleigh_coefficients` at the two anchors ``n omega0``.  Between the
    anchors the ratio is below ``ratio``, outside them above it.

    Attributes
    ----------
    ratio : float, default 0.001
        Damping ratio ``zeta`` [-] at both anchor modes, in [0, 1); 0 gives no intrinsic
        damping.  The default 0.1 % is the order S0 §1 quotes for stay cables.
    modes : tuple of (int, int), default (1, 3)
        The two distinct anchor mode numbers ``(i, j)`` >= 1 of the taut string (the default
        brackets mode 3, the mode S0 §5.3 excites).
    """

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
class InterfaceDevice:
    """Nominal interface device inside the FE model, integrated implicitly with the cable.

    A *rigid part* acts directly on the damper node (simplified S0 Eq.1, plus an optional
    grounded spring, ``F_r = inertance * a_d + damping * v_d + stiffness * u_d``); an optional
    *series branch* is a spring
    ``series_stiffness`` from the node to a flywheel of inertance ``series_inertance`` with a
    viscous ``series_damping`` to ground (S0 Eq.12 with ``x_i`` the flywheel displacement)::

        m_s x'' + c_s x' + k_s (x - u_d) = 0,     F_s = k_s (u_d - x).

    The restoring force of the device is ``F = F_r + F_s`` and the cable receives ``-F``
    (sign convention of :mod:`plants.base`).  The S0 Type II IMD is the series branch alone
    (``k_s = k0``, ``m_s = mbar_e``, ``c_s = cbar_d``, S0 Table 4).

    Attributes
    ----------
    inertance
        Rigid inertance ``m_r`` [kg], >= 0.
    damping
        Rigid viscous coefficient ``c_r`` [N s/m], >= 0.
    series_stiffness
        ``k_s`` [N/m], > 0; ``None`` for no series branch.
    series_inertance
        Flywheel inertance ``m_s`` [kg], >= 0 (0 gives a Maxwell element, spring + dashpot).
    series_damping
        Flywheel viscous coefficient ``c_s`` [N s/m], >= 0; ``m_s`` and ``c_s`` are not both 0.
    stiffness
        Rigid grounded stiffness ``k_r`` [N/m], >= 0 (the linear nominal model of the diagnosis,
        design.md §7).  The mesh rule of :func:`plants.cable.model.max_element_size` applies to it
        too.

    Notes
    -----
    :data:`PointDamper` is this class (its first two fields are the old point damper's).
    """

    inertance: float = 0.0
    damping: float = 0.0
    series_stiffness: float | None = None
    series_inertance: float = 0.0
    series_damping: float = 0.0
    stiffness: float = 0.0

    def __post_init__(self) -> None:
        _store(self, "inertance", check_nonnegative(self.inertance, "damper inertance"))
        _store(self, "damping", check_nonnegative(self.damping, "damper damping coefficient"))
        _store(self, "stiffness", check_nonnegative(self.stiffness, "damper stiffness"))
        m_s = check_nonnegative(self.series_inertance, "series inertance")
        c_s = check_nonnegative(self.series_damping, "series damping coefficient")
        _store(self, "series_inertance", m_s)
        _store(self, "series_damping", c_s)
        if self.series_stiffness is None:
            if m_s > 0.0 or c_s > 0.0:
                raise ParameterError(
                    "series inertance/damping need a series stiffness; got series_stiffness=None "
                    f"with series_inertance={m_s!r}, series_damping={c_s!r}"
                )
            return
        _store(self, "series_stiffness", check_positive(self.series_stiffness, "series stiffness"))
        if m_s == 0.0 and c_s == 0.0:
            raise ParameterError(
                "a series branch needs series_inertance or series_damping > 0; got both 0.0 "
                f"behind series_stiffness={self.series_stiffness!r}"
            )

    @property
    def has_series(self) -> bool:
        """Whether the device has a series branch (a flywheel DOF)."""
        return self.series_stiffness is not None

    @property
    def series_frequency(self) -> float:
        """The series branch's own frequency ``sqrt(k_s/m_s)`` [rad/s] with the node held
        (S0 §4.1, ``omega_e``); ``inf`` without flywheel inertance, ``nan`` without a branch."""
        if self.series_stiffness is None:
            return math.nan
        if self.series_inertance == 0.0:
            return math.inf
        return math.sqrt(self.series_stiffness / self.series_inertance)

    def dynamic_stiffness(self, omega: ArrayLike) -> NDArray[np.complex128]:
        """Complex dynamic stiffness ``K(omega) = F/u_d`` [N/m] at circular frequency ``omega``.

        .. math:: K = k_r - m_r\\omega^2 + i c_r\\omega
                  + \\frac{k_s(-m_s\\omega^2 + i c_s\\omega)}{k_s - m_s\\omega^2 + i c_s\\omega}

        ``omega`` [rad/s] may be complex (any shape); the series term has a pole at the
        branch's own (damped) frequency.
        """
        w = np.asarray(omega, dtype=complex)
        k = self.stiffness - self.inertance * w**2 + 1j * self.damping * w
        if self.series_stiffness is None:
            return k
        k_s = self.series_stiffness
        flywheel = -self.series_inertance * w**2 + 1j * self.series_damping * w
        return k + k_s * flywheel / (k_s + flywheel)


#: The grounded point damper of earlier versions: an :class:`InterfaceDevice` (same first two
#: fields, ``PointDamper(inertance, damping)``), kept as an alias.
PointDamper = InterfaceDevice
