"""Parameters of the inertial mass damper (IMD) models and the seed-paper presets.

Everything here is plain data plus the closed-form relations of S0 §4 (Eq.3–5, Eq.17–18); the
models that use it live in :mod:`plants.imd.models`.  Units are SI except where the paper fits a law
in millimetres (S0 Eq.17), which is converted at the boundary and says so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from rths.core.errors import (
    ParameterError,
    check_nonnegative,
    check_positive,
    format_choices,
)

__all__ = [
    "CONTACT_FREQUENCY_HZ",
    "AmplitudeDamping",
    "IMDParameters",
    "ball_screw_stiffness",
    "damping_from_ratio",
    "screw_series_stiffness",
]

#: Natural frequency [Hz] of the default contact spring (flywheel on a stiff contact) used for a
#: backlash gap when no internal stiffness is configured: ``k_c = m_e (2 pi f_c)^2``.  100 Hz is
#: well above the band the IMD tests and the cable RTHS use (<= 15 Hz, S0 Table 2) yet soft enough
#: to be resolved with a few sub-steps at 1-8 kHz loop rates.
CONTACT_FREQUENCY_HZ: float = 100.0


def screw_series_stiffness(axial: float, torsional: float, lead: float) -> float:
    """Equivalent axial stiffness of a ball screw, S0 Eq.3.

    .. math:: 1/\\bar k_e = 1/k_s + 1/\\left(k_T (2\\pi/l_d)^2\\right)

    Parameters
    ----------
    axial
        Axial stiffness ``k_s`` of the screw [N/m].
    torsional
        Torsional stiffness ``k_T`` of the screw [N m/rad].
    lead
        Lead ``l_d`` of the screw [m per revolution].

    Returns
    -------
    float
        Equivalent stiffness ``k_e`` [N/m] felt at the damper ends.
    """
    k_s = check_positive(axial, "axial stiffness k_s")
    k_t = check_positive(torsional, "torsional stiffness k_T")
    l_d = check_positive(lead, "screw lead l_d")
    return 1.0 / (1.0 / k_s + 1.0 / (k_t * (2.0 * math.pi / l_d) ** 2))


def ball_screw_stiffness(
    area: float,
    youngs_modulus: float,
    shear_modulus: float,
    torsion_constant: float,
    lead: float,
    free_length: float,
    compensation: float = 1.0,
) -> float:
    """Stiffness ``k0`` of the ball screw at the neutral position, S0 Eq.5.

    .. math:: k_0 = \\frac{\\gamma_b A E}{l_f\\left[1 + \\gamma_b \\frac{AE}{GJ_s}
              \\left(\\frac{l_d}{2\\pi}\\right)^2\\right]}

    This is Eq.3 with ``k_s = gamma_b A E / l_f`` and ``k_T = G J_s / l_f``.

    Parameters
    ----------
    area
        Section area ``A`` of the screw [m^2].
    youngs_modulus, shear_modulus
        ``E`` and ``G`` of the screw material [Pa].
    torsion_constant
        Polar moment ``J_s`` of the screw section [m^4].
    lead
        Lead ``l_d`` [m per revolution].
    free_length
        ``l_f`` [m]: distance between the rotary mass and the ball nut at ``u_d = 0``.
    compensation
        ``gamma_b`` [-], the bearing/housing compliance factor (S0 sets it to 1).

    Returns
    -------
    float
        ``k0`` [N/m].
    """
    ae = check_positive(area, "screw area A") * check_positive(youngs_modulus, "Young's modulus E")
    gj = check_positive(shear_modulus, "shear modulus G") * check_positive(
        torsion_constant, "torsion constant J_s"
    )
    l_d = check_positive(lead, "screw lead l_d")
    l_f = check_positive(free_length, "free length l_f")
    g_b = check_positive(compensation, "compensation factor gamma_b")
    return g_b * ae / (l_f * (1.0 + g_b * ae / gj * (l_d / (2.0 * math.pi)) ** 2))


def damping_from_ratio(ratio: float, stiffness: float, inertance: float) -> float:
    """Equivalent damping coefficient ``c_d = 2 xi_e sqrt(k0 m_e)`` [N s/m] (S0 §4.1).

    Parameters
    ----------
    ratio
        Equivalent damping ratio ``xi_e`` [-].
    stiffness
        ``k0`` [N/m].
    inertance
        ``m_e`` [kg].
    """
    xi = check_nonnegative(ratio, "damping ratio xi_e")
    k0 = check_positive(stiffness, "stiffness k0")
    m_e = check_positive(inertance, "inertance m_e")
    return 2.0 * xi * math.sqrt(k0 * m_e)


@dataclass(frozen=True, slots=True)
class AmplitudeDamping:
    """Amplitude-dependent equivalent damping ratio, S0 Eq.17-18.

    .. math:: \\xi_e(A_1) = c_1/(A_1 + c_2) \\text{ for } A_1 > 0.1, \\quad 0.3 \\text{ otherwise}

    with the load amplitude ``A_1`` in **millimetres** (the paper's fit).  The models convert
    their amplitude estimate [m] before calling :meth:`ratio_mm`; :meth:`ratio` takes metres.

    Attributes
    ----------
    c1
        Fit coefficient ``c_1`` [mm].
    c2
        Fit coefficient ``c_2`` [mm].
    small_amplitude_mm
        Amplitude [mm] at or below which the constant ratio applies (S0: 0.1 mm).
    small_amplitude_ratio
        ``xi_e`` [-] for small amplitudes (S0: 0.3).
    reversal_tolerance
        Hysteresis [m] of the online reversal detector (see ``plants.imd.amplitude``): the
        drive must retreat this far from its running extremum for a reversal to count.
    reversal_fraction
        Relative hysteresis: the retreat must also exceed this fraction of the current
        amplitude estimate (wiggles small against the motion are not load reversals).
    """

    c1: float
    c2: float
    small_amplitude_mm: float = 0.1
    small_amplitude_ratio: float = 0.3
    reversal_tolerance: float = 1e-6
    reversal_fraction: float = 0.1

    def __post_init__(self) -> None:
        check_positive(self.c1, "damping law coefficient c1")
        check_positive(self.c2, "damping law coefficient c2")
        check_nonnegative(self.small_amplitude_mm, "small amplitude threshold [mm]")
        check_positive(self.small_amplitude_ratio, "small-amplitude damping ratio")
        check_positive(self.reversal_tolerance, "reversal tolerance")
        check_nonnegative(self.reversal_fraction, "reversal fraction")

    def ratio_mm(self, amplitude_mm: float) -> float:
        """``xi_e`` [-] for a load amplitude in millimetres (S0 Eq.18)."""
        if amplitude_mm <= self.small_amplitude_mm:
            return self.small_amplitude_ratio
        return self.c1 / (amplitude_mm + self.c2)

    def ratio(self, amplitude: float) -> float:
        """``xi_e`` [-] for a load amplitude in metres (converted to mm for S0 Eq.18)."""
        return self.ratio_mm(1e3 * amplitude)


#: Largest inertance [kg], damping [N s/m], stiffness [N/m] or friction [N] of an IMD: beyond
#: it the model's sub-steps (stiffness over inertance) no longer fit in an integer.
MAX_VALUE = 1e12


@dataclass(frozen=True, slots=True)
class IMDParameters:
    """One parameter set for every IMD model; each effect is switched on or off here.

    The effects and their switches:

    ========================  ===========================================  =====================
    effect                    parameters                                   off when
    ========================  ===========================================  =====================
    inertance (S0 Eq.1)       ``inertance``                                never
    viscous damping           ``damping`` (fixed) or ``damping_law``       both zero/None
    internal stiffness        ``stiffness`` and ``internal_stiffness``     flag False or no k0
    variant stiffness Eq.4    ``free_length``                              None (constant k0)
    backlash (in series)      ``clearance`` (total ``h_d``)                0
    Coulomb friction Eq.1     ``friction``, ``friction_velocity``          ``friction == 0``
    ========================  ===========================================  =====================

    Attributes
    ----------
    inertance
        Equivalent inertial mass ``m_e`` [kg] (S0 Eq.1, Eq.13).
    damping
        Fixed equivalent damping coefficient ``c_d`` [N s/m]; must be 0 when ``damping_law``
        is given.
    damping_law
        Amplitude-dependent damping ratio ``xi_e(A)`` (S0 Eq.18); ``c_d = 2 xi_e sqrt(k0 m_e)``,
        so it needs ``stiffness``.  None: fixed ``damping``.
    stiffness
        ``k0`` [N/m], the internal stiffness at the neutral position (S0 Eq.4-5).  Also used to
        convert damping ratios to coefficients even when the series spring is switched off.
    internal_stiffness
        Whether the series spring ``k0`` is part of the force path (S0 Eq.12).  Has an effect
        only when ``stiffness`` is given.
    free_length
        ``l_f`` [m] of S0 Eq.4, giving ``k_e = k0 l_f/(l_f + u_d)``.  The paper does not report
        it, so every preset leaves it None (constant ``k0``).  It cannot be backed out of ``k0``
        either: Eq.5 with ``gamma_b = 1`` and a 12-20 mm steel screw would need ``l_f`` of
        2-5 m to give Type II's 1.2e7 N/m, longer than the device, so the identified ``k0``
        also holds nut/bearing compliance.  Pick it explicitly to study the effect (e.g. 0.5 m
        gives +-11 % stiffness over the +-50 mm stroke).
    clearance
        Total backlash ``h_d`` [m] (S0 Table 6), a dead zone of half-width ``h_d/2`` in series
        with the internal spring; the force path is open while it is crossed.
    contact_stiffness
        Stiffness [N/m] of the series contact used when ``clearance > 0`` but no internal
        stiffness is active.  None: ``m_e (2 pi CONTACT_FREQUENCY_HZ)^2``.  The contact has no
        damping of its own (as S0's backlash block before ``k0``): after each closure the
        flywheel rings at the contact frequency, damped only by ``c_d``.
    friction
        Coulomb friction ``F_r`` [N] at the driven end (S0 Eq.1, Fig.17).
    friction_velocity
        Regularisation velocity ``v_eps`` [m/s] of ``F_r tanh(v/v_eps)``.  The default 1 mm/s
        is about 5 % of the slowest peak drive velocity in S0 Table 2 (0.1 Hz x 30 mm, 19 mm/s);
        it lowers the friction work per cycle by about ``0.41 (v_eps/(A w))^2`` of ``4 F_r A``
        (1e-3 in that worst case).  Near zero velocity the friction acts as a viscous damper of
        ``F_r/v_eps`` [N s/m], which an explicitly coupled actuator must resolve.
    """

    inertance: float
    damping: float = 0.0
    damping_law: AmplitudeDamping | None = None
    stiffness: float | None = None
    internal_stiffness: bool = True
    free_length: float | None = None
    clearance: float = 0.0
    contact_stiffness: float | None = None
    friction: float = 0.0
    friction_velocity: float = 1e-3

    def __post_init__(self) -> None:
        for name in ("inertance", "damping", "stiffness", "contact_stiffness", "friction"):
            value = getattr(self, name)
            if value is not None and abs(value) > MAX_VALUE:
                raise ParameterError(
                    f"IMD {name} {value!r} is beyond any damper's (at most {MAX_VALUE:g} SI)"
                )
        check_positive(self.inertance, "inertance m_e")
        check_nonnegative(self.damping, "damping c_d")
        if self.stiffness is not None:
            check_positive(self.stiffness, "stiffness k0")
        if self.free_length is not None:
            check_positive(self.free_length, "free length l_f")
        check_nonnegative(self.clearance, "backlash clearance h_d")
        if self.contact_stiffness is not None:
            check_positive(self.contact_stiffness, "contact stiffness")
        check_nonnegative(self.friction, "friction F_r")
        check_positive(self.friction_velocity, "friction regularisation velocity v_eps")
        if self.damping_law is not None:
            if self.stiffness is None:
                raise ParameterError(
                    "damping_law (xi_e(A), S0 Eq.18) needs stiffness k0 to give c_d; got None"
                )
            if self.damping != 0.0:
                raise ParameterError(
                    "give either a fixed damping c_d or a damping_law, not both; "
                    f"got damping={self.damping!r}"
                )
        if self.free_length is not None and not self.has_internal_stiffness:
            raise ParameterError(
                "free_length l_f (variant stiffness, S0 Eq.4) needs an active internal stiffness; "
                f"got stiffness={self.stiffness!r}, internal_stiffness={self.internal_stiffness!r}"
            )

    # --- derived quantities -------------------------------------------------------------

    @property
    def has_internal_stiffness(self) -> bool:
        """True when the series spring ``k0`` is in the force path."""
        return self.internal_stiffness and self.stiffness is not None

    @property
    def has_series_element(self) -> bool:
        """True when the flywheel is not rigidly attached (internal stiffness or backlash)."""
        return self.has_internal_stiffness or self.clearance > 0.0

    @property
    def series_stiffness(self) -> float:
        """Stiffness [N/m] in series with the flywheel: ``k0``, else the contact stiffness."""
        if self.has_internal_stiffness:
            return float(self.stiffness)  # type: ignore[arg-type]
        if self.contact_stiffness is not None:
            return self.contact_stiffness
        return self.inertance * (2.0 * math.pi * CONTACT_FREQUENCY_HZ) ** 2

    @property
    def natural_frequency(self) -> float:
        """Equivalent natural frequency ``omega_e = sqrt(k0/m_e)`` [rad/s] (S0 §4.1)."""
        if self.stiffness is None:
            raise ParameterError("natural frequency needs stiffness k0; got None")
        return math.sqrt(self.stiffness / self.inertance)

    def damping_coefficient(self, amplitude: float = 0.0) -> float:
        """``c_d`` [N s/m] at a load amplitude [m] (the amplitude matters only with a law)."""
        if self.damping_law is None:
            return self.damping
        k0 = float(self.stiffness)  # type: ignore[arg-type]  # checked in __post_init__
        return 2.0 * self.damping_law.ratio(amplitude) * math.sqrt(k0 * self.inertance)

    def with_damping_ratio(self, ratio: float) -> IMDParameters:
        """A copy with a fixed ``c_d = 2 xi_e sqrt(k0 m_e)`` instead of any damping law."""
        if self.stiffness is None:
            raise ParameterError("a damping ratio needs stiffness k0 to give c_d; got None")
        c_d = damping_from_ratio(ratio, self.stiffness, self.inertance)
        return replace(self, damping=c_d, damping_law=None)

    @classmethod
    def preset(cls, name: str, **overrides: object) -> IMDParameters:
        """A named seed-paper parameter set, optionally with some fields replaced.

        Presets (``free_length`` is None in all of them; the paper does not report ``l_f``):

        * ``"type_i"``, ``"type_ii"`` -- SMS-B snubbers, S0 Table 4: ``m_e``, ``k0`` and the
          amplitude law ``xi_e(A)`` (Eq.18) with ``c1``, ``c2``; no backlash, no friction.
        * ``"eimd_small"``, ``"eimd_full"`` -- electromagnetic IMDs of Nakamura et al. (2014)
          identified in S0 Table 6: ``m_e``, fixed ``c_d``, ``k0`` and backlash ``h_d``.

        Parameters
        ----------
        name
            One of the names above.
        **overrides
            Fields to replace, e.g. ``friction=50.0`` or ``internal_stiffness=False``.
        """
        try:
            values = dict(_PRESETS[name])
        except KeyError:
            raise ParameterError(
                f"unknown IMD preset {name!r}; choose one of {format_choices(sorted(_PRESETS))}"
            ) from None
        values.update(overrides)
        try:
            return cls(**values)  # type: ignore[arg-type]
        except TypeError as exc:
            raise ParameterError(f"bad override for IMD preset {name!r}: {exc}") from None

    @staticmethod
    def preset_names() -> tuple[str, ...]:
        """Names accepted by :meth:`preset`."""
        return tuple(sorted(_PRESETS))

    #: Scenario-file presets (:mod:`rths.config.options`): the names of :meth:`preset`.
    presets = preset_names

    @classmethod
    def from_preset(cls, name: str, **overrides: object) -> IMDParameters:
        """Scenario-file presets (:mod:`rths.config.options`): :meth:`preset`."""
        return cls.preset(name, **overrides)


_PRESETS: dict[str, dict[str, object]] = {
    # S0 Table 4 (SMS-B snubbers, tested at UIUC)
    "type_i": {
        "inertance": 1509.0,
        "stiffness": 0.9e7,
        "damping_law": AmplitudeDamping(c1=0.100, c2=0.236),
    },
    "type_ii": {
        "inertance": 1589.0,
        "stiffness": 1.2e7,
        "damping_law": AmplitudeDamping(c1=0.079, c2=0.153),
    },
    # S0 Table 6 (EIMDs of Nakamura et al. 2014)
    "eimd_small": {
        "inertance": 6.00e3,
        "damping": 1.61e3,
        "stiffness": 1.03e8,
        "clearance": 0.01e-3,
    },
    "eimd_full": {
        "inertance": 2.20e6,
        "damping": 2.72e6,
        "stiffness": 1.37e8,
        "clearance": 0.40e-3,
    },
}
