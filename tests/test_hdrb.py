"""Oracles for the HDRB isolator of S1 Eq.8 (plants.tmdi.hdrb)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from plants.tmdi.hdrb import (
    AMPLITUDE_EXPONENT,
    AMPLITUDE_RANGE,
    HDRB,
    IDENTIFICATION_AMPLITUDE,
    S1_PRIMARY,
    S1_PRIMARY_AMPLITUDE,
    S1_PRIMARY_IDEAL_INERTER,
    S1_PRIMARY_IDEAL_INERTER_AMPLITUDE,
    S1_PRIMARY_UNCONTROLLED,
    S1_SECONDARY,
    S1_SECONDARY_AMPLITUDE,
    S1_SECONDARY_IDEAL_INERTER,
    S1_SECONDARY_IDEAL_INERTER_AMPLITUDE,
    UNCONTROLLED_STIFFNESS_SCALE,
    AmplitudeDamping,
)
from rths.core.errors import ParameterError

PRESETS = [S1_PRIMARY, S1_SECONDARY]


def test_presets_are_the_s1_identification() -> None:
    # S1 §4.2 numbers, exactly as printed
    assert (S1_PRIMARY.k1, S1_PRIMARY.k2, S1_PRIMARY.k3, S1_PRIMARY.c) == (
        3.94e4,
        -6.46e5,
        4.52e6,
        538.13,
    )
    assert (S1_SECONDARY.k1, S1_SECONDARY.k2, S1_SECONDARY.k3, S1_SECONDARY.c) == (
        5.55e4,
        -1.15e6,
        8.48e6,
        409.15,
    )
    assert S1_PRIMARY_IDEAL_INERTER == HDRB(3.94e4, -6.46e5, 4.52e6, 743.3)
    assert S1_SECONDARY_IDEAL_INERTER == HDRB(5.55e4, -1.15e6, 8.48e6, 324.7)


@pytest.mark.parametrize("iso", PRESETS)
def test_softening_in_the_tested_range(iso: HDRB) -> None:
    # S1 §3.1: softening up to the largest measured deformation (38 mm); the identified
    # cubic keeps softening to -k2/(2 k3) ≈ 68-71 mm.
    amplitudes = np.linspace(0.0, 0.04, 81)
    secant = iso.secant_stiffness(amplitudes)
    assert np.all(np.diff(secant) < 0.0)
    assert np.all(np.diff(iso.equivalent_stiffness(amplitudes)) < 0.0)
    assert iso.softening_limit() > 0.06
    # the secant stiffness is smallest at the softening limit
    a_min = iso.softening_limit()
    assert iso.secant_stiffness(a_min) < iso.secant_stiffness(0.99 * a_min)
    assert iso.secant_stiffness(a_min) < iso.secant_stiffness(1.01 * a_min)
    # and the spring stays monotonic everywhere (k2² < 3 k1 k3)
    assert iso.monotonic_limit() == math.inf


@pytest.mark.parametrize("iso", PRESETS)
def test_tangent_and_energy_are_derivatives(iso: HDRB) -> None:
    u = np.linspace(-0.05, 0.05, 40)  # even count: skips u = 0, where F_E'' jumps
    h = 1e-6
    # central differences: truncation O(h² F''') ~ 1e-12 relative, round-off ~1e-16/h ~ 1e-10
    fd_tangent = (iso.elastic_force(u + h) - iso.elastic_force(u - h)) / (2 * h)
    np.testing.assert_allclose(iso.tangent_stiffness(u), fd_tangent, rtol=1e-7)
    fd_force = (iso.elastic_energy(u + h) - iso.elastic_energy(u - h)) / (2 * h)
    np.testing.assert_allclose(iso.elastic_force(u), fd_force, rtol=1e-7, atol=1e-9)


@pytest.mark.parametrize("iso", PRESETS)
def test_spring_is_odd_and_secant_is_peak_to_peak(iso: HDRB) -> None:
    a = np.array([0.005, 0.02, 0.038])
    np.testing.assert_allclose(iso.elastic_force(-a), -iso.elastic_force(a), rtol=1e-15)
    peak_to_peak = (iso.elastic_force(a) - iso.elastic_force(-a)) / (2 * a)
    np.testing.assert_allclose(iso.secant_stiffness(a), peak_to_peak, rtol=1e-14)


@pytest.mark.parametrize("iso", PRESETS)
@pytest.mark.parametrize("amplitude", [0.005, 0.03])
def test_equivalent_stiffness_is_the_first_harmonic(iso: HDRB, amplitude: float) -> None:
    # Fourier sine coefficient of F_E(A sin φ) divided by A, by adaptive quadrature (1e-10)
    b1, _ = quad(
        lambda phi: iso.elastic_force(amplitude * math.sin(phi)) * math.sin(phi),
        0.0,
        2.0 * math.pi,
        epsabs=0.0,
        epsrel=1e-12,
        limit=200,
    )
    assert iso.equivalent_stiffness(amplitude) == pytest.approx(b1 / math.pi / amplitude, rel=1e-10)


@pytest.mark.parametrize("iso", PRESETS)
def test_dashpot_dissipates_pi_c_omega_a2_per_cycle(iso: HDRB) -> None:
    amplitude, omega = 0.02, 2.0 * math.pi * 2.25
    t = np.linspace(0.0, 2.0 * math.pi / omega, 4001)
    u = amplitude * np.sin(omega * t)
    v = amplitude * omega * np.cos(omega * t)
    # ∮ F du = ∫ F v dt; trapezoidal rule on a periodic integrand is spectrally accurate
    dissipated = np.trapezoid(iso.force(u, v) * v, t)
    assert dissipated == pytest.approx(math.pi * iso.c * omega * amplitude**2, rel=1e-10)
    # the nonlinear spring alone is conservative: zero loop area (to round-off, ~1e-12 J)
    assert abs(np.trapezoid(iso.elastic_force(u) * v, t)) < 1e-9


def test_force_is_spring_plus_dashpot_and_scalar_in_scalar_out() -> None:
    iso = S1_PRIMARY
    f = iso.force(0.01, 0.2)
    assert isinstance(f, float)
    assert f == pytest.approx(iso.elastic_force(0.01) + iso.damping_force(0.2), rel=1e-15)
    assert iso.elastic_force(0.01) == pytest.approx(394.0 - 64.6 + 4.52, rel=1e-14)


def test_linear_limit_and_monotonic_limit() -> None:
    lin = S1_PRIMARY.linear()
    assert (lin.k2, lin.k3, lin.c) == (0.0, 0.0, S1_PRIMARY.c)
    # the linear limit is viscous: the damping law goes with the nonlinearity
    assert S1_PRIMARY_UNCONTROLLED.linear().damping_law is None
    assert lin.softening_limit() == 0.0
    assert HDRB(1.0, -1.0, 0.0).softening_limit() == math.inf
    # a strongly softening spring: tangent k1 + 2 k2 x + 3 k3 x² vanishes at the limit
    soft = HDRB(k1=1e4, k2=-1e6, k3=1e7)
    x = soft.monotonic_limit()
    assert math.isfinite(x)
    assert soft.tangent_stiffness(x) == pytest.approx(0.0, abs=1e-6)
    assert HDRB(k1=1e4, k2=-1e5).monotonic_limit() == pytest.approx(0.05, rel=1e-15)


# --- amplitude-dependent damping ----------------------------------------------------------------
LAW = AmplitudeDamping(0.36, 0.010, (0.005, 0.038))


def test_damping_law_is_a_clamped_power_law() -> None:
    iso = HDRB(3.94e4, c=600.0, damping_law=LAW)
    assert iso.damping_coefficient(0.010) == pytest.approx(600.0, rel=1e-15)  # c = c(A_ref)
    assert iso.damping_coefficient(None) == 600.0  # no amplitude: the reference dashpot
    # held constant outside the calibrated range, on both sides
    assert iso.damping_coefficient(0.0) == iso.damping_coefficient(0.005)
    assert iso.damping_coefficient(0.1) == iso.damping_coefficient(0.038)
    assert iso.damping_coefficient(0.005) == pytest.approx(600.0 * 0.5**-0.36, rel=1e-14)
    # the law applies to |A| and to arrays
    np.testing.assert_allclose(
        iso.damping_coefficient([-0.02, 0.02]), 600.0 * 2.0**-0.36, rtol=1e-14
    )
    # anchoring moves the reference, not the exponent or the range
    moved = LAW.anchored(0.02)
    assert (moved.exponent, moved.amplitude_range) == (LAW.exponent, LAW.amplitude_range)
    assert moved.factor(0.02) == pytest.approx(1.0, rel=1e-15)
    # without a law every amplitude gives c
    assert S1_PRIMARY.damping_coefficient(0.03) == S1_PRIMARY.c


@pytest.mark.parametrize("amplitude", [0.006, 0.02])
def test_energy_per_cycle_grows_as_a_power_2_minus_n(amplitude: float) -> None:
    """W(A) = ∮ F du over a cycle of u = A sin ωt with the dashpot c(A): W ∝ A^(2-n)."""
    iso = HDRB(3.94e4, -6.46e5, 4.52e6, 600.0, LAW)
    omega = 2.0 * math.pi * 2.25
    t = np.linspace(0.0, 2.0 * math.pi / omega, 4001)

    def work(a: float) -> float:
        u, v = a * np.sin(omega * t), a * omega * np.cos(omega * t)
        return float(np.trapezoid(iso.force(u, v, amplitude=a) * v, t))

    # doubling A inside the range (6-12 mm, 20-40 mm clamps at 38 mm: check the clamp too);
    # periodic trapezoidal quadrature is spectrally accurate
    ratio = work(2.0 * amplitude) / work(amplitude)
    exponent = 2.0 - LAW.exponent if 2.0 * amplitude <= 0.038 else None
    if exponent is not None:
        assert ratio == pytest.approx(2.0**exponent, rel=1e-10)
    else:
        expected = 4.0 * (0.038 / amplitude) ** -LAW.exponent
        assert ratio == pytest.approx(expected, rel=1e-10)
    assert work(amplitude) == pytest.approx(
        math.pi * float(iso.damping_coefficient(amplitude)) * omega * amplitude**2, rel=1e-10
    )


def test_variants_keep_what_they_do_not_change() -> None:
    iso = HDRB(3.94e4, -6.46e5, 4.52e6, 600.0, LAW)
    assert iso.with_damping(500.0).damping_law == LAW
    assert iso.with_damping_law(None).damping_law is None
    scaled = iso.with_stiffness_scale(0.5)
    assert (scaled.k1, scaled.k2, scaled.k3) == (0.5 * 3.94e4, 0.5 * -6.46e5, 0.5 * 4.52e6)
    assert (scaled.c, scaled.damping_law) == (600.0, LAW)
    assert scaled.equivalent_stiffness(0.02) == pytest.approx(
        0.5 * iso.equivalent_stiffness(0.02), rel=1e-15
    )
    assert iso.force(0.01, 0.2) == pytest.approx(iso.elastic_force(0.01) + 600.0 * 0.2, rel=1e-15)
    assert iso.damping_force(0.2, 0.005) == pytest.approx(
        float(iso.damping_coefficient(0.005)) * 0.2, rel=1e-15
    )


def test_amplitude_presets() -> None:
    law = S1_PRIMARY_UNCONTROLLED.damping_law
    assert law is not None and law.amplitude_range == AMPLITUDE_RANGE == (0.005, 0.038)
    assert law.exponent == AMPLITUDE_EXPONENT
    # the uncontrolled PS: S1 §4.2 springs scaled, c = 623.0 N s/m at 10 mm
    scaled = S1_PRIMARY.with_stiffness_scale(UNCONTROLLED_STIFFNESS_SCALE)
    assert (S1_PRIMARY_UNCONTROLLED.k1, S1_PRIMARY_UNCONTROLLED.k2, S1_PRIMARY_UNCONTROLLED.k3) == (
        scaled.k1,
        scaled.k2,
        scaled.k3,
    )
    assert S1_PRIMARY_UNCONTROLLED.damping_coefficient(0.010) == pytest.approx(623.0, rel=1e-15)
    # the TMDI bearings give S1's identified dashpots where S1 identified them (0.10 g)
    for iso, viscous, amplitude in (
        (S1_PRIMARY_AMPLITUDE, S1_PRIMARY, IDENTIFICATION_AMPLITUDE["rack_pinion"]),
        (
            S1_PRIMARY_IDEAL_INERTER_AMPLITUDE,
            S1_PRIMARY_IDEAL_INERTER,
            IDENTIFICATION_AMPLITUDE["ideal"],
        ),
        (S1_SECONDARY_AMPLITUDE, S1_SECONDARY, 0.003),
        (S1_SECONDARY_IDEAL_INERTER_AMPLITUDE, S1_SECONDARY_IDEAL_INERTER, 0.003),
    ):
        assert (iso.k1, iso.k2, iso.k3, iso.c) == (viscous.k1, viscous.k2, viscous.k3, viscous.c)
        assert iso.damping_coefficient(amplitude) == pytest.approx(viscous.c, rel=1e-14)
    # secondary: c_T up to A_lo = 5 mm, less for the 0.15 g strokes
    assert S1_SECONDARY_AMPLITUDE.damping_coefficient(0.005) == pytest.approx(409.15, rel=1e-14)
    assert S1_SECONDARY_AMPLITUDE.damping_coefficient(0.006) < 409.15


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"exponent": -0.1}, r"damping law exponent n must lie in \[0.0, 1.0\]; got -0.1"),
        ({"exponent": 1.5}, r"damping law exponent n must lie in \[0.0, 1.0\]; got 1.5"),
        ({"reference_amplitude": 0.0}, "reference amplitude A_ref must be positive; got 0.0"),
        (
            {"amplitude_range": (0.01, 0.005)},
            r"amplitude range must satisfy 0 < A_lo < A_hi; got \(0.01, 0.005\)",
        ),
        ({"amplitude_range": (0.0, 0.005)}, "amplitude range must satisfy 0 < A_lo < A_hi"),
        ({"amplitude_range": 0.005}, r"amplitude range must be \(A_lo, A_hi\) in m; got 0.005"),
        ({"reversal_tolerance": -1e-6}, "reversal tolerance must be positive; got -1e-06"),
    ],
)
def test_bad_damping_laws_are_rejected(kwargs: dict, match: str) -> None:
    args = {"exponent": 0.3, "reference_amplitude": 0.01, "amplitude_range": (0.005, 0.038)}
    with pytest.raises(ParameterError, match=match):
        AmplitudeDamping(**(args | kwargs))


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"k1": 0.0}, "k1 must be positive; got 0.0"),
        ({"k1": -3.0}, "k1 must be positive; got -3.0"),
        ({"k1": 1.0, "k2": math.nan}, "k2 must be finite"),
        ({"k1": 1.0, "k3": math.inf}, "k3 must be finite"),
        ({"k1": 1.0, "c": -1.0}, "damping c must be non-negative; got -1.0"),
        ({"k1": "stiff"}, "k1 must be a number; got 'stiff'"),
        (
            {"k1": 1.0, "damping_law": 0.3},
            "damping law must be an AmplitudeDamping or None; got 0.3",
        ),
    ],
)
def test_bad_parameters_are_rejected(kwargs: dict, match: str) -> None:
    with pytest.raises(ParameterError, match=match):
        HDRB(**kwargs)


def test_bad_stiffness_scale_is_rejected() -> None:
    with pytest.raises(ParameterError, match="HDRB stiffness scale must be positive; got -0.5"):
        S1_PRIMARY.with_stiffness_scale(-0.5)
