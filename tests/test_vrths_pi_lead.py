"""The benchmark's sample controller (controllers.baselines.pi_lead): discretisation, wiring, converters."""

from __future__ import annotations

import math
from typing import Any

import control
import numpy as np
import pytest
from scipy import signal

from controllers.baselines.pi_lead import (
    LEAD_DEN,
    LEAD_NUM,
    PILeadCompensator,
    round_half_away,
    tustin_section,
)
from rths.core.errors import ParameterError
from rths.core.kinematics import Kinematics

DT = 1.0 / 4096.0


def _coefficients(num: list[float], den: list[float]) -> tuple[np.ndarray, np.ndarray]:
    tf = control.c2d(control.tf(num, den), DT, method="tustin")
    b, a = np.asarray(tf.num[0][0], float), np.asarray(tf.den[0][0], float)
    return np.concatenate([np.zeros(2 - b.size), b]) / a[0], a / a[0]


def _bilinear(num: list[float], den: list[float]) -> tuple[np.ndarray, np.ndarray]:
    """Tustin by hand: s = (2/T)(z-1)/(z+1) for n1 s + n0 over d1 s + d0."""
    k = 2.0 / DT
    (n1, n0), (d1, d0) = num, den
    b = np.array([n1 * k + n0, n0 - n1 * k])
    a = np.array([d1 * k + d0, d0 - d1 * k])
    return b / a[0], a / a[0]


@pytest.mark.parametrize("num, den", [(list(LEAD_NUM), list(LEAD_DEN)), ([2.0, 95.0], [1.0, 0.0])])
def test_tustin_sections_equal_control_c2d_and_the_bilinear_map(num, den) -> None:
    sec = tustin_section(num, den, DT)
    for b, a in (_coefficients(num, den), _bilinear(num, den)):
        np.testing.assert_allclose([sec.b0, sec.b1, sec.a1], [b[0], b[1], a[1]], rtol=1e-12)


def test_lead_has_unit_dc_gain_and_its_zero_and_pole() -> None:
    lead = tustin_section(LEAD_NUM, LEAD_DEN, DT)
    assert lead.dc_gain() == pytest.approx(1.0, rel=1e-12)
    # 50.8 (s + 168.6)/(s + 8570) as the paper rounds it
    assert LEAD_NUM[1] / LEAD_NUM[0] == pytest.approx(168.6, abs=0.01)
    assert LEAD_DEN[1] == pytest.approx(8570, abs=0.5) and LEAD_NUM[0] == pytest.approx(
        50.8, abs=0.05
    )
    pi = tustin_section([2.0, 95.0], [1.0, 0.0], DT)
    assert pi.a1 == -1.0 and math.isinf(pi.dc_gain())  # integrator


def test_command_equals_the_two_discrete_filters_in_series() -> None:
    # Without converters and with r_k = target one step late: u = G_C(z)[G_T(z) r - y].
    comp = PILeadCompensator(DT, quantization=0.0, saturation=math.inf)
    rng = np.random.default_rng(1)
    n = 600
    r = np.cumsum(rng.standard_normal(n + 1)) * 1e-5
    r[0] = 0.0  # the compensator starts from rest: r_0 = 0
    y = 0.8 * r + 1e-6 * rng.standard_normal(n + 1)
    u = np.array([comp.step(Kinematics(r[k + 1], 0.0, 0.0), y[k]) for k in range(n)])
    bt, at = _bilinear(list(LEAD_NUM), list(LEAD_DEN))
    bc, ac = _bilinear([2.0, 95.0], [1.0, 0.0])
    y_p = signal.lfilter(bt, at, r[:n])  # the benchmark's G_T acts on r_k at step k
    expected = signal.lfilter(bc, ac, y_p - y[:n])
    np.testing.assert_allclose(u, expected, rtol=1e-9, atol=1e-15)


def test_lookahead_feeds_the_end_of_step_target() -> None:
    late = PILeadCompensator(DT, quantization=0.0)
    ahead = PILeadCompensator(DT, quantization=0.0, lookahead=True)
    target = Kinematics(1e-3, 0.0, 0.0)
    assert late.step(target, 0.0) == 0.0  # first command uses r_0 = 0 (rest)
    lead = tustin_section(LEAD_NUM, LEAD_DEN, DT)
    pi = tustin_section([2.0, 95.0], [1.0, 0.0], DT)
    assert ahead.step(target, 0.0) == pytest.approx(pi.b0 * lead.b0 * 1e-3, rel=1e-12)


def test_converters_quantise_by_2_to_the_minus_18_and_saturate_at_3_8() -> None:
    comp = PILeadCompensator(DT)
    q = 2.0**-18
    assert comp._adc(2.4 * q) == 2 * q and comp._adc(2.5 * q) == 3 * q
    assert comp._adc(-2.5 * q) == -3 * q and comp._adc(10.0) == pytest.approx(3.8, abs=q)
    assert comp._dac(-9.0) == -3.8
    u = comp.step(Kinematics(0.0, 0.0, 0.0), 1e-3)  # negative error -> quantised command
    assert u / q == pytest.approx(round(u / q), abs=1e-9) and u < 0
    assert set(comp.state()) == {"reference", "error", "command"}


@pytest.mark.parametrize(
    "options",
    [{}, {"lookahead": True}, {"quantization": 0.0, "saturation": math.inf}, {"saturation": 2e-3}],
    ids=["benchmark", "lookahead", "no-converters", "saturating"],
)
def test_compiled_step_is_the_python_path_bit_for_bit(options: dict[str, Any]) -> None:
    # Same scalar operations in the same order (no sums to reorder): equal bit for bit, with
    # halves on the quantiser's grid, saturation and both wirings exercised.
    rng = np.random.default_rng(7)
    n = 3000
    q = 2.0**-18
    r = np.cumsum(rng.standard_normal(n)) * 2e-4
    r[::50] = np.round(r[::50] / q) * q + 0.5 * q  # exact halves between codes
    y = 0.9 * np.concatenate([[0.0], r[:-1]]) + 1e-5 * rng.standard_normal(n)
    runs = []
    for use_jit in (True, False):
        comp = PILeadCompensator(DT, use_jit=use_jit, **options)
        out = np.zeros(3)
        rows = []
        for k in range(n):
            u = comp.step(Kinematics(r[k], 0.0, 0.0), y[k])
            comp.write_channels(out)
            rows.append([u, *comp.state().values(), *out])
        runs.append(np.array(rows))
    np.testing.assert_array_equal(runs[0], runs[1])
    if "saturation" in options and options["saturation"] == 2e-3:
        assert np.count_nonzero(np.abs(runs[1][:, 0]) == 2e-3) > 10


def test_round_half_away() -> None:
    assert [round_half_away(v) for v in (0.5, -0.5, 1.5, 2.5, -2.49)] == [1, -1, 2, 3, -2]


def test_reset_restores_rest() -> None:
    comp = PILeadCompensator(DT)
    first = [comp.step(Kinematics(1e-3 * k, 0, 0), 0.0) for k in range(20)]
    comp.reset()
    assert [comp.step(Kinematics(1e-3 * k, 0, 0), 0.0) for k in range(20)] == first


def test_bad_parameters_name_the_value() -> None:
    with pytest.raises(ParameterError, match="non-zero gain"):
        PILeadCompensator(DT, proportional=0.0, integral=0.0)
    with pytest.raises(ParameterError, match="saturation must be positive; got -1"):
        PILeadCompensator(DT, saturation=-1)
    with pytest.raises(ParameterError, match="quantization must be non-negative; got -0.1"):
        PILeadCompensator(DT, quantization=-0.1)
    with pytest.raises(ParameterError, match="den of degree 1"):
        tustin_section([1.0], [1.0, 2.0, 3.0], DT)
    with pytest.raises(ParameterError, match="lookahead must be true or false"):
        PILeadCompensator(DT, lookahead="yes")  # type: ignore[arg-type]
