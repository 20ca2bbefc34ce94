"""Oracles for plants.linear_specimen: the vRTHS benchmark's mass-spring-dashpot specimen."""

from __future__ import annotations

import math

import numpy as np
import pytest

from plants.base import drive
from plants.linear_specimen import (
    BenchmarkSpecimenParameters,
    LinearSpecimen,
    benchmark_specimen,
)
from rths.core.errors import ParameterError


def test_force_is_the_algebraic_sum_and_all_of_mass_and_dashpot_is_rigid() -> None:
    s = LinearSpecimen(2.0, 3.0, 5.0)
    expected = 2.0 * 0.3 + 3.0 * -0.2 + 5.0 * 0.1
    assert s.step(0.1, -0.2, 0.3, 1e-3) == pytest.approx(expected, rel=1e-15)
    assert (s.rigid_inertance, s.rigid_damping) == (2.0, 3.0)
    assert s.state() == {"spring_force": pytest.approx(0.5)}
    s.reset()
    assert s.state() == {"spring_force": 0.0}
    assert s.kind == "linear" and "stiffness=5.0" in repr(s)


def test_drive_with_exact_derivatives_reproduces_the_harmonic_force() -> None:
    # F = (k - m w^2) A sin(wt) + c w A cos(wt) for u = A sin(wt): closed form
    m, c, k, amplitude, w = 29.13, 114.0, 1.19e6, 0.002, 2 * math.pi * 5
    t = np.arange(0, 1, 1e-3)
    u = amplitude * np.sin(w * t)
    force = drive(LinearSpecimen(m, c, k), u, 1e-3, amplitude * w * np.cos(w * t), -w * w * u)
    expected = (k - m * w * w) * u + c * w * amplitude * np.cos(w * t)
    np.testing.assert_allclose(force, expected, rtol=1e-12, atol=1e-9)


def test_benchmark_values() -> None:
    p = BenchmarkSpecimenParameters()
    s = benchmark_specimen()
    assert (s.mass, s.stiffness) == (29.13, 1.19e6)
    # c = 2 zeta sqrt(k m) = 2 * 0.0097 * sqrt(1.19e6 * 29.13) = 114.22 N s/m
    assert s.damping == pytest.approx(114.22, abs=0.01)
    assert p.damping == s.damping
    assert LinearSpecimen.from_damping_ratio(29.13, 1.19e6, 0.0097).damping == s.damping


def test_monte_carlo_stiffness_is_reproducible_with_documented_spread() -> None:
    a = [benchmark_specimen(np.random.default_rng(9)).stiffness for _ in range(2)]
    assert a[0] == a[1] != 1.19e6
    rng = np.random.default_rng(12)
    n = 4000
    draws = [benchmark_specimen(rng) for _ in range(n)]
    k = np.array([d.stiffness for d in draws])
    # 5-sigma bands: se(mean) = std/sqrt(n), se(std)/std ~ 1/sqrt(2(n-1))
    assert abs(k.mean() - 1.19e6) < 5 * 5e4 / math.sqrt(n)
    assert abs(k.std(ddof=1) / 5e4 - 1) < 5 / math.sqrt(2 * (n - 1))
    assert {d.mass for d in draws} == {29.13}
    # the damping ratio is kept: c / (2 sqrt(k m)) stays 0.0097
    ratios = [d.damping / (2 * math.sqrt(d.stiffness * d.mass)) for d in draws[:20]]
    np.testing.assert_allclose(ratios, 0.0097, rtol=1e-12)


@pytest.mark.parametrize(
    ("args", "match"),
    [
        ((-1.0, 0.0, 0.0), "specimen mass must be non-negative; got -1.0"),
        ((1.0, -2.0, 0.0), "specimen damping must be non-negative; got -2.0"),
        ((1.0, 0.0, math.nan), "specimen stiffness must be finite; got nan"),
    ],
)
def test_validation(args: tuple[float, float, float], match: str) -> None:
    with pytest.raises(ParameterError, match=match):
        LinearSpecimen(*args)


@pytest.mark.parametrize(
    ("args", "match"),
    [
        ((0.0, 1e6, 0.01), "specimen mass must be positive; got 0.0"),
        ((1.0, -1e6, 0.01), "specimen stiffness must be positive; got -1000000.0"),
        ((1.0, 1e6, -0.01), "specimen damping ratio must be non-negative; got -0.01"),
    ],
)
def test_from_damping_ratio_validation(args: tuple[float, float, float], match: str) -> None:
    with pytest.raises(ParameterError, match=match):
        LinearSpecimen.from_damping_ratio(*args)


@pytest.mark.parametrize(
    ("field", "value", "match"),
    [
        ("mass", 0.0, "specimen mass must be positive"),
        ("stiffness", 0.0, "specimen stiffness must be positive"),
        ("damping_ratio", -0.1, "specimen damping ratio must be non-negative"),
        ("stiffness_std", -1.0, "specimen stiffness_std must be non-negative; got -1.0"),
    ],
)
def test_benchmark_parameter_validation(field: str, value: float, match: str) -> None:
    with pytest.raises(ParameterError, match=match):
        BenchmarkSpecimenParameters(**{field: value})
