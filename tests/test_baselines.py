"""Baselines: no compensation, polynomial extrapolation (Horiuchi 1999), ATS (Chae et al. 2013)."""

from __future__ import annotations

import numpy as np
import pytest
from _vrths import Target, benchmark_plant, closed_loop, discretize, j2, multisine
from scipy.signal import butter, sosfreqz

from controllers.base import Compensator
from controllers.baselines.ats import AdaptiveTimeSeries, ATSSettings
from controllers.baselines.extrapolation import (
    NoCompensation,
    PolynomialExtrapolation,
    extrapolation_weights,
)
from rths.core.errors import ParameterError
from rths.core.kinematics import Kinematics

DT = 1.0 / 4096.0


def pure_delay_loop(comp: Compensator, target: Target, gain: float, delay_steps: int) -> np.ndarray:
    """y(t) = gain * u_zoh(t - D dt): y_{k+1} = gain * u_{k-D}; returns y."""
    n = target.r.size - 1
    u = np.zeros(n + 1)
    y = np.zeros(n + 1)
    comp.reset()
    for k in range(n):
        u[k] = comp.step(Kinematics(target.r[k + 1], target.v[k + 1], target.a[k + 1]), y[k])
        y[k + 1] = gain * u[k - delay_steps] if k >= delay_steps else 0.0
    return y


def sine(freq: float, duration: float, dt: float = DT, amp: float = 1e-2) -> Target:
    t = np.arange(int(round(duration / dt)) + 1) * dt
    w = 2 * np.pi * freq
    return Target(dt, amp * np.sin(w * t), amp * w * np.cos(w * t), -amp * w * w * np.sin(w * t))


# ---------------------------------------------------------------- none / polynomial


def test_no_compensation_commands_the_target():
    comp = NoCompensation(DT)
    assert comp.step(Kinematics(1.5e-3, 0.2, 3.0), 7.0) == 1.5e-3
    assert comp.state() == {}
    comp.reset()


@pytest.mark.parametrize("order", [1, 2, 3, 4])
def test_extrapolation_weights_are_exact_for_polynomials(order):
    w = extrapolation_weights(order, 7.5)
    x = -np.arange(order + 1.0)
    coeffs = np.arange(1.0, order + 2.0)  # a polynomial of degree `order`
    # Lagrange extrapolation reproduces degree-`order` polynomials up to round-off
    assert w @ np.polyval(coeffs, x) == pytest.approx(np.polyval(coeffs, 7.5), rel=1e-12)
    assert w.sum() == pytest.approx(1.0, rel=1e-12)


@pytest.mark.parametrize("order", [1, 2, 3])
def test_polynomial_extrapolation_on_pure_delay_plant_has_closed_form_error(order):
    steps = 41  # 10 ms at 4096 Hz
    comp = PolynomialExtrapolation(DT, steps * DT, order)
    results = {}
    for f in (2.0, 4.0):
        target = sine(f, 2.0)
        y = pure_delay_loop(comp, target, 1.0, steps)
        wdt = 2 * np.pi * f * DT
        # steady state: y/r = e^{-i w D dt} sum_j w_j e^{-i w j dt}
        exact = abs(
            np.sum(comp.weights * np.exp(-1j * wdt * np.arange(order + 1)))
            - np.exp(1j * wdt * steps)
        )
        # J2 over whole periods (samples 4096..8191) of a sine equals the amplitude ratio of the
        # error; the FIR extrapolator has no transient past its 4 samples.  Round-off only: the
        # cubic's weights reach 3.9e4 and cancel: 1e-16 * 4e4 / 1.2e-5 ~ 3e-7 relative
        results[f] = j2(y[:-1], target.r[:-1], int(1.0 / DT))
        assert results[f] == pytest.approx(exact, rel=1e-5)
    # halving the frequency divides the error by 2^(order+1) (leading term (w dt)^(order+1))
    assert results[4.0] / results[2.0] == pytest.approx(2.0 ** (order + 1), rel=0.05)
    # and it beats no compensation, whose error is 2 sin(w tau/2)
    none = j2(
        pure_delay_loop(NoCompensation(DT), sine(4.0, 2.0), 1.0, steps)[:-1],
        sine(4.0, 2.0).r[:-1],
        4096,
    )
    assert none == pytest.approx(2 * np.sin(2 * np.pi * 4.0 * steps * DT / 2), rel=1e-9)
    assert results[4.0] < 0.2 * none  # linear 0.13x, quadratic 0.011x, cubic 7.7e-4x


def test_polynomial_validation_and_state():
    with pytest.raises(
        ParameterError, match="polynomial extrapolation order must be at most 4; got 5"
    ):
        PolynomialExtrapolation(DT, 0.01, 5)
    with pytest.raises(
        ParameterError, match="polynomial extrapolation order must be a positive integer; got 0"
    ):
        PolynomialExtrapolation(DT, 0.01, 0)
    with pytest.raises(
        ParameterError, match="polynomial extrapolation delay must be non-negative; got -0.01"
    ):
        PolynomialExtrapolation(DT, -0.01)
    with pytest.raises(
        ParameterError, match="extrapolation steps ahead must be non-negative; got -1"
    ):
        extrapolation_weights(2, -1)
    comp = PolynomialExtrapolation(DT, 0.01)
    assert comp.state() == {"delay": 0.01}
    first = comp.step(Kinematics(1e-3, 0, 0), 0.0)
    comp.step(Kinematics(2e-3, 0, 0), 0.0)
    comp.reset()
    assert comp.step(Kinematics(1e-3, 0, 0), 0.0) == first


# ---------------------------------------------------------------- ATS


def _expected_ats(freqs, amps, gain, tau, settings, coeffs):
    """Least-squares coefficients the ATS regression converges to (frequency-domain closed form).

    Over whole periods the sinusoids are orthogonal: the regression minimises
    sum_i Y_i^2 |e^{i w_i tau}/A - (a0 + a1 D1_i + a2 D2_i)|^2 with the central-difference
    operators D1 = i sin(w dt)/dt, D2 = -(2 - 2 cos(w dt))/dt^2 and Y_i the filtered measured
    amplitudes.
    """
    w = 2 * np.pi * np.asarray(freqs)
    sos = butter(settings.filter_order, settings.cutoff_hz, fs=1 / DT, output="sos")
    _, f_resp = sosfreqz(sos, worN=w * DT)
    a0, a1, a2 = coeffs
    cmd_amp = np.abs(a0 - a2 * w**2 + 1j * a1 * w) * np.asarray(amps)
    y = np.abs(f_resp) * gain * cmd_amp
    s1 = np.sin(w * DT) / DT
    s2 = -(2 - 2 * np.cos(w * DT)) / DT**2
    a1_ls = np.sum(y**2 * s1 * np.sin(w * tau)) / np.sum(y**2 * s1**2) / gain
    m = np.column_stack([y, y * s2])
    a0_ls, a2_ls = np.linalg.lstsq(m, y * np.cos(w * tau) / gain, rcond=None)[0]
    return np.array([a0_ls, a1_ls, a2_ls])


def test_ats_converges_to_inverse_of_gain_and_delay():
    gain, steps = 0.9, 82  # tau = 20.0 ms
    tau = steps * DT
    freqs, amps = (1.0, 2.0, 3.0), (2e-3,) * 3
    comp = AdaptiveTimeSeries(DT)
    pure_delay_loop(comp, multisine(DT, 8.0, freqs, amps[0]), gain, steps)
    a = comp.coefficients
    expected = _expected_ats(freqs, amps, gain, tau, comp.settings, a)
    # the exact least-squares solution; windows of 4094 samples are whole periods to 2/4096
    np.testing.assert_allclose(a, expected, rtol=2e-3)
    # the second-order Taylor inverse a0 = 1/A, a1 = tau/A, a2 = tau^2/(2A); truncation bias of
    # a1, a2 is (w tau)^2/6 <= 2.4 % at 3 Hz and 20 ms, of a0 (w tau)^4/24 ~ 1e-4 rel
    assert a[0] == pytest.approx(1 / gain, rel=2e-3)
    assert a[1] == pytest.approx(tau / gain, rel=0.025)
    assert a[2] == pytest.approx(tau**2 / (2 * gain), rel=0.025)
    assert comp.state()["delay"] == pytest.approx(tau, rel=0.025)
    assert comp.state()["updates"] > 1000


def test_ats_safeguards_threshold_bounds_and_rate():
    steps = 82
    # below the threshold (0.254 mm) nothing is identified
    quiet = AdaptiveTimeSeries(DT)
    pure_delay_loop(quiet, multisine(DT, 3.0, (1.0, 2.0, 3.0), 5e-5), 1.0, steps)
    assert quiet.state()["updates"] == 0.0 and tuple(quiet.coefficients) == (1.0, 0.0, 0.0)
    # a single steady sine cannot separate a0 from a2 (y'' = -w^2 y exactly for central
    # differences): the ill-conditioned update is skipped (unfiltered, so no start transient)
    single = AdaptiveTimeSeries(DT, ATSSettings(cutoff_hz=None))
    probe = sine(2.0, 3.0)
    for k in range(probe.r.size - 1):
        single.step(Kinematics(probe.r[k + 1], probe.v[k + 1], probe.a[k + 1]), probe.r[k])
    assert single.state()["updates"] == 0.0
    # gain 0.5 asks for a0 = 2: clipped at the upper bound 1.3
    clipped = AdaptiveTimeSeries(DT)
    pure_delay_loop(clipped, multisine(DT, 6.0, (1.0, 2.0, 3.0)), 0.5, steps)
    assert clipped.coefficients[0] == 1.3
    # each update moves a_i by at most max_rate_i * update_every * dt
    settings = ATSSettings(max_rate=(0.2, 0.005, 1e-4))
    slow = AdaptiveTimeSeries(DT, settings)
    target = multisine(DT, 3.0, (1.0, 2.0, 3.0))
    history = []
    n = target.r.size - 1
    u, y = np.zeros(n + 1), np.zeros(n + 1)
    for k in range(n):
        u[k] = slow.step(Kinematics(target.r[k + 1], target.v[k + 1], target.a[k + 1]), y[k])
        y[k + 1] = u[k - steps] if k >= steps else 0.0
        history.append(slow.coefficients.copy())
    steps_taken = np.abs(np.diff(np.array(history), axis=0)).max(axis=0)
    limit = np.array(settings.max_rate) * settings.update_every * DT
    assert np.all(steps_taken <= limit * (1 + 1e-12))
    assert steps_taken[1] == pytest.approx(limit[1], rel=1e-9)  # a1 (0 -> 20 ms) was rate-bound


def test_ats_tracks_the_benchmark_plant():
    target = multisine(DT, 6.0)
    plant = discretize(benchmark_plant(), DT)
    skip = int(4.0 / DT)
    comp = AdaptiveTimeSeries(DT, ATSSettings(initial=(1.0, 0.02, 2e-4)))
    y, _ = closed_loop(comp, plant, target, noise_rms=2e-5)
    y_none, _ = closed_loop(NoCompensation(DT), plant, target)
    # measured 0.26 % vs 46 % without compensation after 4 s of adaptation
    assert j2(y, target.r, skip) < 0.01 < 0.4 < j2(y_none, target.r, skip)
    # delay estimate a1/a0 near the plant's low-frequency delay (24.6-25.0 ms at 1-2 Hz);
    # the fit over 1-5 Hz sees the phase delay fall to 22.7 ms at 5 Hz
    assert comp.state()["delay"] == pytest.approx(0.024, abs=0.0015)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"initial": (1.0, 0.0)}, "ATS initial, bounds and max_rate must each have 3 entries"),
        (
            {"bounds": ((1.0, 0.5), (0.0, 0.08), (0.0, 0.0032))},
            r"ATS bounds of a0 must satisfy lo < hi; got \(1.0, 0.5\)",
        ),
        (
            {"initial": (2.0, 0.0, 0.0)},
            r"ATS initial a0 must lie within its bounds \(0.7, 1.3\); got 2.0",
        ),
        ({"max_rate": (2.0, 0.0, 0.001)}, "ATS max_rate of a1 must be positive; got 0.0"),
        ({"window": -1.0}, "ATS window must be positive; got -1.0"),
        ({"threshold": -1.0}, "ATS threshold must be non-negative; got -1.0"),
        ({"update_every": 0}, "ATS update_every must be a positive integer; got 0"),
        ({"cutoff_hz": 0.0}, "ATS cutoff_hz must be positive; got 0.0"),
        ({"filter_order": 5}, "ATS filter_order must be 2, 4, 6 or 8; got 5"),
    ],
)
def test_ats_settings_validation(kwargs, match):
    with pytest.raises(ParameterError, match=match):
        ATSSettings(**kwargs)


def test_ats_compensator_validation():
    with pytest.raises(ParameterError, match="settings must be an ATSSettings; got 1"):
        AdaptiveTimeSeries(DT, 1)  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match="ATS window must span at least 16 steps; got 0.001 s"):
        AdaptiveTimeSeries(DT, ATSSettings(window=0.001))
    with pytest.raises(
        ParameterError, match="ATS cutoff_hz must be below the Nyquist frequency 2048.0; got 3000.0"
    ):
        AdaptiveTimeSeries(DT, ATSSettings(cutoff_hz=3000.0))
    comp = AdaptiveTimeSeries(DT, ATSSettings(cutoff_hz=None, initial=(1.0, 0.02, 2e-4)))
    assert comp.step(Kinematics(1.0, 2.0, 3.0), 0.0) == pytest.approx(1.0 + 0.04 + 6e-4)
