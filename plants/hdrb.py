"""High-damping rubber bearing (HDRB) isolator: cubic elastic spring in parallel with a dashpot.

The rheological model of S1 Eq.8 (Fig.15): the shear force of a bearing with deformation ``u``
[m] and deformation rate ``v`` [m/s] is

.. math::

    F = F_E(u) + F_D(v), \\qquad
    F_E = k_1 u + k_2 u^2 \\operatorname{sign}(u) + k_3 u^3, \\qquad F_D = c\\,v .

With ``k_2 < 0 < k_3`` (the identified bearings of S1 §4.2) the spring softens with amplitude up
to ``|u| = -k_2 / (2 k_3)`` (about 70 mm, beyond the strains of the S1 tests) and stiffens after.

The presets are the S1 §4.2 identifications: :data:`S1_PRIMARY` / :data:`S1_SECONDARY` with the
rack-and-pinion inerter model, and :data:`S1_PRIMARY_IDEAL_INERTER` /
:data:`S1_SECONDARY_IDEAL_INERTER` (same springs, re-identified dampers) with the ideal inerter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rths.errors import check_finite, check_nonnegative, check_positive

__all__ = [
    "HDRB",
    "S1_PRIMARY",
    "S1_PRIMARY_IDEAL_INERTER",
    "S1_SECONDARY",
    "S1_SECONDARY_IDEAL_INERTER",
]

FloatOrArray = float | NDArray[np.float64]


def _as_float_or_array(x: ArrayLike) -> FloatOrArray:
    a = np.asarray(x, dtype=float)
    return float(a) if a.ndim == 0 else a


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
        Dashpot coefficient [N s/m]; non-negative.

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

    def __post_init__(self) -> None:
        check_positive(self.k1, "HDRB linear stiffness k1")
        check_finite(self.k2, "HDRB quadratic coefficient k2")
        check_finite(self.k3, "HDRB cubic coefficient k3")
        check_nonnegative(self.c, "HDRB damping c")

    # --- forces -------------------------------------------------------------------------------
    def elastic_force(self, u: ArrayLike) -> FloatOrArray:
        """Spring force ``F_E(u)`` [N] for the deformation ``u`` [m] (S1 Eq.8)."""
        x = np.asarray(u, dtype=float)
        return _as_float_or_array(
            self.k1 * x + self.k2 * x * np.abs(x) + self.k3 * x**3
        )

    def damping_force(self, v: ArrayLike) -> FloatOrArray:
        """Dashpot force ``F_D = c v`` [N] for the deformation rate ``v`` [m/s] (S1 Eq.8)."""
        return _as_float_or_array(self.c * np.asarray(v, dtype=float))

    def force(self, u: ArrayLike, v: ArrayLike) -> FloatOrArray:
        """Total bearing force ``F_E(u) + c v`` [N]."""
        x = np.asarray(u, dtype=float)
        return _as_float_or_array(
            self.k1 * x + self.k2 * x * np.abs(x) + self.k3 * x**3
            + self.c * np.asarray(v, dtype=float)
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
        """Largest ``|u|`` [m] below which the tangent stiffness stays positive (``inf`` if always)."""
        # roots of 3 k3 x^2 + 2 k2 x + k1 = 0 for x = |u| >= 0
        if self.k3 == 0.0:
            return math.inf if self.k2 >= 0.0 else -self.k1 / (2.0 * self.k2)
        disc = self.k2**2 - 3.0 * self.k1 * self.k3
        if disc < 0.0:
            return math.inf
        roots = [(-self.k2 - s * math.sqrt(disc)) / (3.0 * self.k3) for s in (1.0, -1.0)]
        positive = [x for x in roots if x > 0.0]
        return min(positive) if positive else math.inf

    def with_damping(self, c: float) -> HDRB:
        """The same springs with another dashpot coefficient ``c`` [N s/m]."""
        return HDRB(self.k1, self.k2, self.k3, c)

    def linear(self) -> HDRB:
        """The linear limit (``k2 = k3 = 0``) with the same ``k1`` and ``c``."""
        return HDRB(self.k1, 0.0, 0.0, self.c)


#: Primary (PS) isolator identified with the rack-and-pinion inerter model, S1 §4.2.
S1_PRIMARY = HDRB(k1=3.94e4, k2=-6.46e5, k3=4.52e6, c=538.13)
#: Secondary (TMDI) isolator identified with the rack-and-pinion inerter model, S1 §4.2.
S1_SECONDARY = HDRB(k1=5.55e4, k2=-1.15e6, k3=8.48e6, c=409.15)
#: Primary isolator of the ideal-inerter variant (same springs, c_I = 743.3 N s/m), S1 §4.2.
S1_PRIMARY_IDEAL_INERTER = S1_PRIMARY.with_damping(743.3)
#: Secondary isolator of the ideal-inerter variant (same springs, c_T = 324.7 N s/m), S1 §4.2.
S1_SECONDARY_IDEAL_INERTER = S1_SECONDARY.with_damping(324.7)
