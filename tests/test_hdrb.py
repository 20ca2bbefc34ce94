"""Oracles for the HDRB isolator of S1 Eq.8 (plants.hdrb)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from plants.hdrb import (
    HDRB,
    S1_PRIMARY,
    S1_PRIMARY_IDEAL_INERTER,
    S1_SECONDARY,
    S1_SECONDARY_IDEAL_INERTER,
)
from rths.errors import ParameterError

PRESETS = [S1_PRIMARY, S1_SECONDARY]


def test_presets_are_the_s1_identification() -> None:
    # S1 §4.2 numbers, exactly as printed
    assert (S1_PRIMARY.k1, S1_PRIMARY.k2, S1_PRIMARY.k3, S1_PRIMARY.c) == (
        3.94e4, -6.46e5, 4.52e6, 538.13
    )
    assert (S1_SECONDARY.k1, S1_SECONDARY.k2, S1_SECONDARY.k3, S1_SECONDARY.c) == (
        5.55e4, -1.15e6, 8.48e6, 409.15
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
    b1, _ = quad(lambda phi: iso.elastic_force(amplitude * math.sin(phi)) * math.sin(phi),
                 0.0, 2.0 * math.pi, epsabs=0.0, epsrel=1e-12, limit=200)
    assert iso.equivalent_stiffness(amplitude) == pytest.approx(b1 / math.pi / amplitude,
                                                                 rel=1e-10)


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
    assert lin.softening_limit() == 0.0
    assert HDRB(1.0, -1.0, 0.0).softening_limit() == math.inf
    # a strongly softening spring: tangent k1 + 2 k2 x + 3 k3 x² vanishes at the limit
    soft = HDRB(k1=1e4, k2=-1e6, k3=1e7)
    x = soft.monotonic_limit()
    assert math.isfinite(x)
    assert soft.tangent_stiffness(x) == pytest.approx(0.0, abs=1e-6)
    assert HDRB(k1=1e4, k2=-1e5).monotonic_limit() == pytest.approx(0.05, rel=1e-15)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"k1": 0.0}, "k1 must be positive; got 0.0"),
        ({"k1": -3.0}, "k1 must be positive; got -3.0"),
        ({"k1": 1.0, "k2": math.nan}, "k2 must be finite"),
        ({"k1": 1.0, "k3": math.inf}, "k3 must be finite"),
        ({"k1": 1.0, "c": -1.0}, "damping c must be non-negative; got -1.0"),
        ({"k1": "stiff"}, "k1 must be a number; got 'stiff'"),
    ],
)
def test_bad_parameters_are_rejected(kwargs: dict, match: str) -> None:
    with pytest.raises(ParameterError, match=match):
        HDRB(**kwargs)
