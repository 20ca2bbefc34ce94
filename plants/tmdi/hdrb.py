"""High-damping rubber bearing (HDRB) isolator: cubic elastic spring in parallel with a dashpot.

The rheological model of S1 Eq.8 (Fig.15): the shear force of a bearing with deformation ``u``
[m] and deformation rate ``v`` [m/s] is

.. math::

    F = F_E(u) + F_D(v), \\qquad
    F_E = k_1 u + k_2 u^2 \\operatorname{sign}(u) + k_3 u^3, \\qquad F_D = c\\,v .

With ``k_2 < 0 < k_3`` (the identified bearings of S1 §4.2) the spring softens with amplitude up
to ``|u| = -k_2 / (2 k_3)`` (about 70 mm, beyond the strains of the S1 tests) and stiffens after.

Amplitude-dependent damping.  S1 calls its dashpot "simplified but adequate" for the strains of
its tests (S1 §4.1).  HDRB dissipation is largely rate-independent and grows more slowly than the
square of the shear-strain amplitude, so one equivalent dashpot holds at one amplitude only: S1
identifies ``c_I`` at PGA 0.10 g, and its uncontrolled PS peaks (5 mm at 0.05 g, 38 mm at 0.15 g,
S1 §3.1) need ``c`` ≈ 800 N s/m at 5 mm and ≈ 390 N s/m at 38 mm.  An optional
:class:`AmplitudeDamping` law replaces ``c`` by

.. math::

    c(A) = c \\left( \\frac{\\min(\\max(A, A_{lo}), A_{hi})}{A_{ref}} \\right)^{-n},
    \\qquad W(A, ω) = π\\, c(A)\\, ω A^2 \\propto A^{2-n}

(``W`` is the energy dissipated per harmonic cycle: ``n = 0`` viscous, ``n = 1`` Coulomb-like),
held constant outside the range ``[A_lo, A_hi]`` it was calibrated on, and ``c`` is its value at
the reference amplitude ``A_ref``.  The amplitude ``A`` is estimated online from the bearing
deformation by the rule :mod:`plants.imd.amplitude` applies to the IMD's ``ξ_e(A)`` of S0
Eq.17-18 (same functional role, ``c1/(A + c2)`` there): half the
peak-to-peak excursion between the last two reversals, a reversal being a retreat of more than
``reversal_tolerance`` from the running extremum; ``A = 0`` (hence ``c(A_lo)``) until two reversals
have been seen.  ``c(A)`` is therefore piecewise constant, changing at reversals, where the
deformation rate and the dashpot force are near zero.  The kernel of :mod:`plants.tmdi.structure`
runs the same rule per loop step (:func:`plants.tmdi.integration.laws.track_amplitude`).

Presets (the numbers of S1, and of the calibration in
:mod:`rths.experiments.s1_shake_table.calibration`):

* :data:`S1_PRIMARY` / :data:`S1_SECONDARY`: S1 §4.2 with the rack-and-pinion inerter model;
  :data:`S1_PRIMARY_IDEAL_INERTER` / :data:`S1_SECONDARY_IDEAL_INERTER`: same springs,
  re-identified dashpots, ideal inerter.
* :data:`S1_PRIMARY_UNCONTROLLED`: the primary bearing of the *uncontrolled* PS, calibrated on the
  numbers S1 reports for the uncontrolled tests (S1 §3.1 peaks, S1 Fig.12 ``f0``): the S1 §4.2
  springs scaled by :data:`UNCONTROLLED_STIFFNESS_SCALE` and a damping law of exponent
  :data:`AMPLITUDE_EXPONENT`.
* ``S1_*_AMPLITUDE``: the S1 §4.2 bearings of the TMDI (same rubber) with the same exponent,
  anchored where S1 identified them, at PGA 0.10 g: the primary at the peak PS displacement of
  the S1 §4.2 model there (:data:`IDENTIFICATION_AMPLITUDE`), so ``c(13.7 mm) = c_I``; the
  secondary at ``A_lo``, because the S1 §4.2 model's strokes at 0.10 g (3.0 mm rack-and-pinion,
  3.2 mm ideal) lie below the calibrated range, where the law is constant: ``c_T`` holds up to
  5 mm and decreases only for the larger strokes at 0.15 g.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rths.core.errors import (
    ParameterError,
    check_finite,
    check_in_range,
    check_nonnegative,
    check_positive,
)

__all__ = [
    "AMPLITUDE_EXPONENT",
    "AMPLITUDE_RANGE",
    "HDRB",
    "IDENTIFICATION_AMPLITUDE",
    "S1_PRIMARY",
    "S1_PRIMARY_AMPLITUDE",
    "S1_PRIMARY_IDEAL_INERTER",
    "S1_PRIMARY_IDEAL_INERTER_AMPLITUDE",
    "S1_PRIMARY_UNCONTROLLED",
    "S1_SECONDARY",
    "S1_SECONDARY_AMPLITUDE",
    "S1_SECONDARY_IDEAL_INERTER",
    "S1_SECONDARY_IDEAL_INERTER_AMPLITUDE",
    "UNCONTROLLED_STIFFNESS_SCALE",
    "AmplitudeDamping",
]

FloatOrArray = float | NDArray[np.float64]


def _as_float_or_array(x: ArrayLike) -> FloatOrArray:
    a = np.asarray(x, dtype=float)
    return float(a) if a.ndim == 0 else a


@dataclass(frozen=True, slots=True)
class AmplitudeDamping:
    """Power law of the equivalent dashpot of an HDRB in its deformation amplitude.

    ``c(A) = c (clip(A, A_lo, A_hi) / A_ref)**(-n)`` with ``c`` the bearing's dashpot (module
    docstring); the amplitude ``A`` is estimated online from the reversals of the deformation.

    Parameters
    ----------
    exponent
        ``n`` [-], in ``[0, 1]``: the energy dissipated per cycle grows as ``A**(2 - n)``,
        between viscous (``n = 0``) and Coulomb friction (``n = 1``).
    reference_amplitude
        ``A_ref`` [m] > 0, where ``c(A_ref)`` equals the bearing's ``c``.
    amplitude_range
        ``(A_lo, A_hi)`` [m], ``0 < A_lo < A_hi``: the law is held constant outside.
    reversal_tolerance
        Hysteresis [m] > 0 of the online reversal detector (round-off guard; the emulation has
        no sensor noise).
    """

    exponent: float
    reference_amplitude: float
    amplitude_range: tuple[float, float]
    reversal_tolerance: float = 1e-6

    def __post_init__(self) -> None:
        check_in_range(self.exponent, "damping law exponent n", 0.0, 1.0)
        check_positive(self.reference_amplitude, "damping law reference amplitude A_ref")
        check_positive(self.reversal_tolerance, "damping law reversal tolerance")
        try:
            lo, hi = (float(x) for x in self.amplitude_range)
        except (TypeError, ValueError):
            raise ParameterError(
                f"damping law amplitude range must be (A_lo, A_hi) in m; got "
                f"{self.amplitude_range!r}"
            ) from None
        if not (0.0 < lo < hi and math.isfinite(hi)):
            raise ParameterError(
                f"damping law amplitude range must satisfy 0 < A_lo < A_hi; got "
                f"{self.amplitude_range!r}"
            )
        object.__setattr__(self, "amplitude_range", (lo, hi))

    def factor(self, amplitude: ArrayLike) -> FloatOrArray:
        """``c(A) / c = (clip(A, A_lo, A_hi) / A_ref)**(-n)`` [-] at amplitudes ``A`` [m]."""
        lo, hi = self.amplitude_range
        a = np.clip(np.abs(np.asarray(amplitude, dtype=float)), lo, hi)
        return _as_float_or_array((a / self.reference_amplitude) ** (-self.exponent))

    def anchored(self, amplitude: float) -> AmplitudeDamping:
        """The same law with the reference amplitude ``amplitude`` [m] (same ``n`` and range)."""
        return AmplitudeDamping(
            self.exponent, amplitude, self.amplitude_range, self.reversal_tolerance
        )


@dataclass(frozen=True, slots=True)
class HDRB:
    """Nonlinear-elastic + viscous HDRB isolator, S1 Eq.8.

    Parameters
    ----------
    k1
        Linear stiffness coefficient [N/m]; must be positive.
    k2
        Quadratic coefficient of ``u**2 * sign(u)`` [N/m^2]; negative softens.
    k3
        Cubic coefficient [N/m^3]; positive stiffens.
    c
        Dashpot coefficient [N s/m]; non-negative.  With a ``damping_law`` it is the value at
        the law's reference amplitude.
    damping_law
        Optional :class:`AmplitudeDamping`: the dashpot becomes ``c(A)`` (module docstring).

    Notes
    -----
    The tangent stiffness ``k1 + 2 k2 |u| + 3 k3 u**2`` must stay positive for the bearing to be
    a monotonic spring; it is positive for every ``u`` when ``k2**2 < 3 k1 k3`` (true for all
    S1 presets) and is otherwise only positive in a band around ``u = 0`` (see
    :meth:`monotonic_limit`).
    """

    k1: float
    k2: float = 0.0
    k3: float = 0.0
    c: float = 0.0
    damping_law: AmplitudeDamping | None = None

    def __post_init__(self) -> None:
        check_positive(self.k1, "HDRB linear stiffness k1")
        check_finite(self.k2, "HDRB quadratic coefficient k2")
        check_finite(self.k3, "HDRB cubic coefficient k3")
        check_nonnegative(self.c, "HDRB damping c")
        if self.damping_law is not None and not isinstance(self.damping_law, AmplitudeDamping):
            raise ParameterError(
                f"HDRB damping law must be an AmplitudeDamping or None; got {self.damping_law!r}"
            )

    # --- forces -------------------------------------------------------------------------------
    def elastic_force(self, u: ArrayLike) -> FloatOrArray:
        """Spring force ``F_E(u)`` [N] for the deformation ``u`` [m] (S1 Eq.8)."""
        x = np.asarray(u, dtype=float)
        return _as_float_or_array(self.k1 * x + self.k2 * x * np.abs(x) + self.k3 * x**3)

    def damping_coefficient(self, amplitude: ArrayLike | None = None) -> FloatOrArray:
        """Dashpot coefficient [N s/m] at the deformation amplitude [m].

        ``c`` without a damping law or when ``amplitude`` is None; ``c(A)`` otherwise.
        """
        if self.damping_law is None or amplitude is None:
            return self.c
        return _as_float_or_array(self.c * np.asarray(self.damping_law.factor(amplitude)))

    def damping_force(self, v: ArrayLike, amplitude: ArrayLike | None = None) -> FloatOrArray:
        """Dashpot force ``F_D = c(A) v`` [N] for the deformation rate ``v`` [m/s] (S1 Eq.8).

        ``amplitude`` [m] matters only with a damping law (:meth:`damping_coefficient`).
        """
        c = np.asarray(self.damping_coefficient(amplitude))
        return _as_float_or_array(c * np.asarray(v, dtype=float))

    def force(self, u: ArrayLike, v: ArrayLike, amplitude: ArrayLike | None = None) -> FloatOrArray:
        """Total bearing force ``F_E(u) + c(A) v`` [N] (``amplitude`` [m] as in
        :meth:`damping_force`)."""
        x = np.asarray(u, dtype=float)
        c = np.asarray(self.damping_coefficient(amplitude))
        return _as_float_or_array(
            self.k1 * x + self.k2 * x * np.abs(x) + self.k3 * x**3 + c * np.asarray(v, dtype=float)
        )

    def elastic_energy(self, u: ArrayLike) -> FloatOrArray:
        """Strain energy ``∫_0^u F_E`` [J] = ``k1 u²/2 + k2 |u|³/3 + k3 u⁴/4``."""
        x = np.asarray(u, dtype=float)
        return _as_float_or_array(
            0.5 * self.k1 * x**2 + self.k2 * np.abs(x) ** 3 / 3.0 + 0.25 * self.k3 * x**4
        )

    # --- stiffness measures -------------------------------------------------------------------
    def tangent_stiffness(self, u: ArrayLike) -> FloatOrArray:
        """``dF_E/du = k1 + 2 k2 |u| + 3 k3 u²`` [N/m]."""
        x = np.asarray(u, dtype=float)
        return _as_float_or_array(self.k1 + 2.0 * self.k2 * np.abs(x) + 3.0 * self.k3 * x**2)

    def secant_stiffness(self, amplitude: ArrayLike) -> FloatOrArray:
        """``F_E(A)/A = k1 + k2 A + k3 A²`` [N/m] at the amplitude ``A`` [m] (``k1`` at 0).

        Because ``F_E`` is odd this is also the peak-to-peak effective stiffness
        ``(F_E(A) - F_E(-A)) / (2 A)`` of a symmetric cycle.
        """
        a = np.abs(np.asarray(amplitude, dtype=float))
        return _as_float_or_array(self.k1 + self.k2 * a + self.k3 * a**2)

    def equivalent_stiffness(self, amplitude: ArrayLike) -> FloatOrArray:
        """First-harmonic (describing-function) stiffness [N/m] for ``u = A sin(ωt)``.

        .. math:: k_{eq}(A) = k_1 + \\frac{8}{3\\pi} k_2 A + \\frac{3}{4} k_3 A^2

        the linear spring with the same fundamental force component; it sets the resonance of
        the harmonic-balance approximation used to linearise S1 Eq.12 around an amplitude.
        """
        a = np.abs(np.asarray(amplitude, dtype=float))
        return _as_float_or_array(
            self.k1 + 8.0 / (3.0 * math.pi) * self.k2 * a + 0.75 * self.k3 * a**2
        )

    def softening_limit(self) -> float:
        """Amplitude [m] up to which the secant stiffness decreases: ``-k2/(2 k3)``.

        ``inf`` when the spring never stiffens again (``k3 <= 0``), ``0`` when it does not soften
        (``k2 >= 0``).
        """
        if self.k2 >= 0.0:
            return 0.0
        if self.k3 <= 0.0:
            return math.inf
        return -self.k2 / (2.0 * self.k3)

    def monotonic_limit(self) -> float:
        """Largest ``|u|`` [m] below which the tangent stiffness stays positive (``inf`` if
        always)."""
        # roots of 3 k3 x^2 + 2 k2 x + k1 = 0 for x = |u| >= 0
        if self.k3 == 0.0:
            return math.inf if self.k2 >= 0.0 else -self.k1 / (2.0 * self.k2)
        disc = self.k2**2 - 3.0 * self.k1 * self.k3
        if disc < 0.0:
            return math.inf
        roots = [(-self.k2 - s * math.sqrt(disc)) / (3.0 * self.k3) for s in (1.0, -1.0)]
        positive = [x for x in roots if x > 0.0]
        return min(positive) if positive else math.inf

    # --- variants -----------------------------------------------------------------------------
    def with_damping(self, c: float) -> HDRB:
        """The same springs and damping law with another dashpot coefficient ``c`` [N s/m]."""
        return HDRB(self.k1, self.k2, self.k3, c, self.damping_law)

    def with_damping_law(self, law: AmplitudeDamping | None) -> HDRB:
        """The same springs and ``c`` with the damping law ``law`` (None: viscous)."""
        return HDRB(self.k1, self.k2, self.k3, self.c, law)

    def with_stiffness_scale(self, scale: float) -> HDRB:
        """The same bearing with ``k1``, ``k2``, ``k3`` multiplied by ``scale`` > 0 [-]."""
        s = check_positive(scale, "HDRB stiffness scale")
        return HDRB(s * self.k1, s * self.k2, s * self.k3, self.c, self.damping_law)

    def linear(self) -> HDRB:
        """The linear limit: ``k2 = k3 = 0``, the same ``k1`` and the constant dashpot ``c``."""
        return HDRB(self.k1, 0.0, 0.0, self.c)


#: Primary (PS) isolator identified with the rack-and-pinion inerter model, S1 §4.2.
S1_PRIMARY: Final[HDRB] = HDRB(k1=3.94e4, k2=-6.46e5, k3=4.52e6, c=538.13)
#: Secondary (TMDI) isolator identified with the rack-and-pinion inerter model, S1 §4.2.
S1_SECONDARY: Final[HDRB] = HDRB(k1=5.55e4, k2=-1.15e6, k3=8.48e6, c=409.15)
#: Primary isolator of the ideal-inerter variant (same springs, c_I = 743.3 N s/m), S1 §4.2.
S1_PRIMARY_IDEAL_INERTER: Final[HDRB] = S1_PRIMARY.with_damping(743.3)
#: Secondary isolator of the ideal-inerter variant (same springs, c_T = 324.7 N s/m), S1 §4.2.
S1_SECONDARY_IDEAL_INERTER: Final[HDRB] = S1_SECONDARY.with_damping(324.7)

# --- amplitude-dependent damping (the S1 experiment's calibration.py reproduces these numbers)
#: Range [m] of the PS peak amplitudes S1 reports for the uncontrolled tests (S1 §3.1: 5 mm at
#: 0.05 g, 38 mm at 0.15 g): the damping law is held constant outside it.
AMPLITUDE_RANGE: Final[tuple[float, float]] = (0.005, 0.038)
#: Exponent ``n`` of the HDRB damping law fitted on the uncontrolled PS [-].
AMPLITUDE_EXPONENT: Final[float] = 0.3596
#: Spring scale of the uncontrolled PS's bearing relative to S1 §4.2 [-] (fitted with ``n``).
UNCONTROLLED_STIFFNESS_SCALE: Final[float] = 0.8319
#: Peak PS displacement [m] of the S1 §4.2 models at the identification test (IM-IF, PGA 0.10 g,
#: down sweep, MTS table; rack-and-pinion / ideal inerter): where S1's viscous c_I applies.
IDENTIFICATION_AMPLITUDE: Final[Mapping[str, float]] = MappingProxyType(
    {"rack_pinion": 0.0137, "ideal": 0.0139}
)

#: Primary bearing of the uncontrolled PS calibrated on S1 §3.1 / Fig.12: S1 §4.2 springs
#: scaled by :data:`UNCONTROLLED_STIFFNESS_SCALE`, ``c = 623.0 N s/m`` at ``A_ref = 10 mm``.
S1_PRIMARY_UNCONTROLLED: Final[HDRB] = (
    S1_PRIMARY.with_damping(623.0)
    .with_damping_law(AmplitudeDamping(AMPLITUDE_EXPONENT, 0.010, AMPLITUDE_RANGE))
    .with_stiffness_scale(UNCONTROLLED_STIFFNESS_SCALE)
)
#: S1 §4.2 primary bearing (rack-and-pinion model) with the amplitude law anchored at c_I.
S1_PRIMARY_AMPLITUDE: Final[HDRB] = S1_PRIMARY.with_damping_law(
    AmplitudeDamping(AMPLITUDE_EXPONENT, IDENTIFICATION_AMPLITUDE["rack_pinion"], AMPLITUDE_RANGE)
)
#: S1 §4.2 primary bearing of the ideal-inerter variant with the amplitude law anchored at c_I.
S1_PRIMARY_IDEAL_INERTER_AMPLITUDE: Final[HDRB] = S1_PRIMARY_IDEAL_INERTER.with_damping_law(
    AmplitudeDamping(AMPLITUDE_EXPONENT, IDENTIFICATION_AMPLITUDE["ideal"], AMPLITUDE_RANGE)
)
#: S1 §4.2 secondary bearing (rack-and-pinion model) with the amplitude law, ``c_T`` up to 5 mm.
S1_SECONDARY_AMPLITUDE: Final[HDRB] = S1_SECONDARY.with_damping_law(
    AmplitudeDamping(AMPLITUDE_EXPONENT, AMPLITUDE_RANGE[0], AMPLITUDE_RANGE)
)
#: S1 §4.2 secondary bearing of the ideal-inerter variant with the amplitude law.
S1_SECONDARY_IDEAL_INERTER_AMPLITUDE: Final[HDRB] = S1_SECONDARY_IDEAL_INERTER.with_damping_law(
    AmplitudeDamping(AMPLITUDE_EXPONENT, AMPLITUDE_RANGE[0], AMPLITUDE_RANGE)
)
