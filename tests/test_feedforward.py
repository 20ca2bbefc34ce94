"""Model-based feedforward: inverse series, low-order fit, tracking on exact low-order plants."""

from __future__ import annotations

import math

import control
import numpy as np
import pytest
from _vrths import benchmark_plant, closed_loop, discretize, heavy_plant, j2, multisine

from controllers._lti import inverse_taylor, siso_polynomials
from controllers.model_based.feedforward import (
    FeedforwardCompensator,
    LowOrderModel,
    fit_low_order,
    low_order_from_nominal,
)
from rths.core.errors import ParameterError
from rths.core.kinematics import Kinematics

DT = 1.0 / 4096.0
FREQS = (1.0, 2.0, 3.0, 4.0, 5.0)


@pytest.fixture(scope="module")
def benchmark_fit():
    return fit_low_order(benchmark_plant(), order=3, band_hz=(0.0, 20.0))


# ---------------------------------------------------------------- inverse power series


def test_inverse_series_of_all_pole_model_is_its_denominator():
    den = np.array([1.0, 274.0, 6.8e4, 2.7e6])
    c = inverse_taylor(np.array([2.7e6]), den, 3)
    # exact polynomial identity; only round-off
    np.testing.assert_allclose(c, den[::-1] / 2.7e6, rtol=1e-14)


def test_inverse_series_of_pure_delay_is_exponential_series():
    tau = 0.02
    c = inverse_taylor(np.array([1.0]), np.array([1.0]), 4, delay=tau)
    # e^{s tau} = sum tau^i s^i / i!  exactly
    np.testing.assert_allclose(c, [tau**i / math.factorial(i) for i in range(5)], rtol=1e-14)


def test_inverse_series_matches_inverse_frf_at_low_frequency():
    sys = control.tf([3.0, 40.0], [1.0, 9.0, 50.0, 80.0])  # has a zero: series is infinite
    num, den = siso_polynomials(sys)
    c = inverse_taylor(num, den, 4)
    s = 1j * 0.05
    series = sum(ci * s**i for i, ci in enumerate(c))
    # truncation error ~ |s|^5 * O(1) coefficients = 3e-7
    assert abs(series - 1.0 / complex(sys(s))) < 1e-6


def test_inverse_series_rejects_negative_order():
    with pytest.raises(ParameterError, match="series order must be non-negative; got -1"):
        inverse_taylor(np.array([1.0]), np.array([1.0, 1.0]), -1)


# ---------------------------------------------------------------- low-order fit


def test_fit_of_benchmark_plant_reports_small_error_and_right_delay(benchmark_fit):
    fit = benchmark_fit
    m = fit.model
    assert fit.model.order == 3 and fit.band_hz == (0.0, 20.0)
    # measured 2.03 % / 0.73 %: a 3-pole model cannot follow the 67 Hz servo-valve pair exactly
    assert fit.max_relative_error < 0.025
    assert fit.rms_relative_error < 0.008
    # DC gain of the benchmark, closed form gain*a1b0/(b2*a3*k + a1b0) = 1.00751, kept exactly
    a1b0, b2, a3, k = 2.1283e13, 9.9976e4, 3.3, 1.19e6
    assert m.b0 / m.den[-1] == pytest.approx(1.0261 * a1b0 / (b2 * a3 * k + a1b0), rel=1e-9)
    # low-frequency delay a1/a0 vs the benchmark's phase delay 24.96 ms at 1 Hz
    assert m.den[-2] / m.den[-1] == pytest.approx(0.02496, abs=5e-4)


def test_higher_order_fit_is_more_accurate():
    fit4 = fit_low_order(benchmark_plant(), order=4, band_hz=(0.0, 20.0))
    # measured 0.28 %: the 4th pole absorbs most of the servo-valve dynamics
    assert fit4.max_relative_error < 0.004


def test_fit_recovers_an_exact_low_order_model():
    true = LowOrderModel(b0=2.0e6, den=(1.0, 250.0, 6.0e4, 1.9e6))
    sys = control.tf([true.b0], list(true.den))
    fit = fit_low_order(sys, order=3, band_hz=(0.0, 30.0))
    # noise-free data inside the model class: LM converges to round-off
    np.testing.assert_allclose(fit.model.den, true.den, rtol=1e-6)
    assert fit.model.b0 == pytest.approx(true.b0, rel=1e-6)
    assert fit.max_relative_error < 1e-8


def test_fit_carries_the_delay_and_frequency_response():
    fit = fit_low_order(benchmark_plant(), order=3, delay=0.004)
    assert fit.model.delay == 0.004
    h = fit.model.frequency_response(np.array([2.0]))[0]
    # the delay adds 2*pi*2*0.004 rad of lag to the delay-free fit
    h0 = LowOrderModel(fit.model.b0, fit.model.den).frequency_response(np.array([2.0]))[0]
    assert np.angle(h / h0) == pytest.approx(-2 * np.pi * 2.0 * 0.004, abs=1e-12)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"order": 0}, r"fit order must be an integer in \[1, 5\]; got 0"),
        ({"order": 2.5}, r"fit order must be an integer in \[1, 5\]; got 2.5"),
        ({"band_hz": (10.0, 5.0)}, r"fit band must satisfy 0 <= lo < hi \[Hz\]; got \(10.0, 5.0\)"),
        ({"delay": -0.1}, "nominal delay must be non-negative; got -0.1"),
    ],
)
def test_fit_validation(kwargs, match):
    with pytest.raises(ParameterError, match=match):
        fit_low_order(benchmark_plant(), **kwargs)


@pytest.mark.parametrize(
    ("nominal", "match"),
    [
        ("1/(s+1)", "nominal model must be a python-control TransferFunction or StateSpace"),
        (control.tf([1.0], [1.0, 0.5], 0.01), "nominal model must be continuous-time; got dt=0.01"),
        (
            control.ss(-np.eye(2), np.eye(2), np.eye(2), 0),
            "nominal model must be SISO; got 2 inputs",
        ),
        (control.tf([1.0, 0.0, 1.0], [1.0, 1.0]), "nominal model must be proper"),
        (control.tf([1.0], [1.0, -2.0]), "nominal model must be stable; got a pole at 2"),
        (control.tf([1.0, 0.0], [1.0, 2.0, 1.0]), "nominal model must have a non-zero DC gain"),
    ],
)
def test_nominal_model_validation(nominal, match):
    with pytest.raises(ParameterError, match=match):
        siso_polynomials(nominal)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"b0": -1.0, "den": (1.0, 2.0)}, "low-order model gain b0 must be positive; got -1.0"),
        (
            {"b0": 1.0, "den": (1.0, 2.0), "delay": -1.0},
            "low-order model delay must be non-negative",
        ),
        ({"b0": 1.0, "den": (1.0,)}, r"low-order model order must lie in \[1, 5\]; got 0"),
        ({"b0": 1.0, "den": (2.0, 2.0)}, "low-order model denominator must be monic"),
        ({"b0": 1.0, "den": (1.0, float("nan"))}, "denominator coefficient 1 must be finite"),
        ({"b0": 1.0, "den": (1.0, -2.0)}, "low-order model must be stable"),
    ],
)
def test_low_order_model_validation(kwargs, match):
    with pytest.raises(ParameterError, match=match):
        LowOrderModel(**kwargs)


def test_all_pole_nominal_is_taken_exactly_and_others_are_not():
    exact = low_order_from_nominal(control.tf([8.0], [1.0, 6.0, 12.0, 8.0]), delay=0.01)
    assert exact == LowOrderModel(8.0, (1.0, 6.0, 12.0, 8.0), 0.01)
    assert low_order_from_nominal(control.tf([1.0, 1.0], [1.0, 3.0, 2.0])) is None


# ---------------------------------------------------------------- tracking


def _rms_zoh_error(freqs, dt):
    """J2 of a ZOH half-sample lead on an equal-amplitude multi-sine: RMS_i(w_i dt/2)."""
    return math.sqrt(np.mean([(2 * np.pi * f * dt / 2) ** 2 for f in freqs]))


@pytest.mark.parametrize("dt", [1.0 / 4096.0, 1.0 / 2048.0])
def test_feedforward_on_exact_low_order_plant_tracks_to_zoh_error(benchmark_fit, dt):
    model = benchmark_fit.model
    plant = discretize(control.tf([model.b0], list(model.den)), dt)
    target = multisine(dt, 2.0, FREQS)
    skip = int(1.0 / dt)
    y, _ = closed_loop(FeedforwardCompensator(dt, model), plant, target)
    y_plain, _ = closed_loop(
        FeedforwardCompensator(dt, model, hold_correction=False), plant, target
    )
    # mid-step evaluation leaves the O(dt^2) error of averaging the ends, (w dt)^2/8 = 3e-5 at
    # 5 Hz and 2048 Hz; measured 5.5e-6 (4096 Hz) and 2.2e-5 (2048 Hz)
    assert j2(y, target.r, skip) < 1.5 * (2 * np.pi * 5.0 * dt) ** 2 / 8
    # without it, the ZOH leads by dt/2: J2 = RMS(w dt/2) (0.26 % at 4096 Hz) to within 5 %
    assert j2(y_plain, target.r, skip) == pytest.approx(_rms_zoh_error(FREQS, dt), rel=0.05)


def test_feedforward_on_exact_fourth_order_heavy_plant():
    plant_tf = heavy_plant()
    model = low_order_from_nominal(plant_tf)
    assert model is not None and model.order == 4
    target = multisine(DT, 2.0, (0.5, 1.0, 2.0, 3.0))
    y, _ = closed_loop(FeedforwardCompensator(DT, model), discretize(plant_tf, DT), target)
    # the 4th derivative (second difference of acceleration) is centred half a step late:
    # error ~ c4 w^4 |r| * w dt/2 = 1.2e-7 * 1.2e5 * 0.0038 = 6e-5 at 3 Hz; measured below that
    assert j2(y, target.r, int(1.0 / DT)) < 1e-4
    y_none = closed_loop(
        FeedforwardCompensator(DT, LowOrderModel(1.0, (1.0, 1.0))), discretize(plant_tf, DT), target
    )[0]
    assert j2(y_none, target.r, int(1.0 / DT)) > 0.1  # sanity: the 50 ms plant needs compensation


def test_feedforward_command_leads_target_by_model_delay(benchmark_fit):
    ff = FeedforwardCompensator(DT, benchmark_fit.model)
    f, amp = 1.0, 1e-3
    n = int(2.0 / DT)
    u = np.empty(n)
    t = (np.arange(n) + 1) * DT
    w = 2 * np.pi * f
    for k in range(n):
        u[k] = ff.step(
            Kinematics(
                amp * np.sin(w * t[k]), amp * w * np.cos(w * t[k]), -amp * w * w * np.sin(w * t[k])
            ),
            0.0,
        )
    # phase of u vs r at 1 Hz = the fitted model's phase (~25 ms lead), from a DFT over 1 s
    seg = slice(n // 2, n)
    ph_u = np.angle(np.sum(u[seg] * np.exp(-1j * w * (t[seg] - DT / 2))))
    ph_r = np.angle(np.sum(amp * np.sin(w * t[seg]) * np.exp(-1j * w * t[seg])))
    lead = (ph_u - ph_r) / w
    model_lead = -np.angle(benchmark_fit.model.frequency_response(np.array([f]))[0]) / w
    # DFT over whole periods is exact; remaining error is the O(dt^2) mid-step averaging
    assert lead == pytest.approx(model_lead, abs=2e-6)
    assert ff.state() == {"feedforward": u[-1]}


def test_feedforward_validation_and_reset(benchmark_fit):
    with pytest.raises(ParameterError, match="model must be a LowOrderModel; got 3"):
        FeedforwardCompensator(DT, 3)  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match="time step dt must be positive; got 0.0"):
        FeedforwardCompensator(0.0, benchmark_fit.model)
    ff = FeedforwardCompensator(DT, benchmark_fit.model)
    first = ff.step(Kinematics(1e-3, 0.0, 0.0), 0.0)
    ff.step(Kinematics(2e-3, 0.1, 1.0), 0.0)
    ff.reset()
    assert ff.step(Kinematics(1e-3, 0.0, 0.0), 0.0) == first
