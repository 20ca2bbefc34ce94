"""Oracles for rths.metrics: closed forms for sines, exact discrete identities, noise bounds."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from rths import metrics
from rths.core.errors import DataError, ParameterError

FS = 1024.0  # sampling rate [Hz]
DT = 1.0 / FS  # sampling step [s]
F0 = 2.0  # sine frequency [Hz]: 512 samples per period
OMEGA = 2.0 * math.pi * F0  # [rad/s]
AMP = 0.01  # displacement amplitude [m]
N = 4096  # 8 whole periods
H = OMEGA * DT  # phase advance per sample [rad]
T = np.arange(N) * DT


def sine(delay: float = 0.0, amplitude: float = AMP, n: int = N) -> np.ndarray:
    """``amplitude * sin(omega (t - delay))`` sampled at FS [m]."""
    return amplitude * np.sin(OMEGA * (np.arange(n) * DT - delay))


def band_limited(n: int, cutoff: float, delay: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A periodic random signal below ``cutoff`` [Hz] and its exact delay by ``delay`` [s]."""
    rng = np.random.default_rng(seed)
    spec = np.fft.rfft(rng.standard_normal(n))
    freqs = np.fft.rfftfreq(n, DT)
    spec[freqs > cutoff] = 0.0
    spec[0] = 0.0
    target = np.fft.irfft(spec, n)
    measured = np.fft.irfft(spec * np.exp(-2j * np.pi * freqs * delay), n)
    return AMP * target / np.std(target), AMP * measured / np.std(target)


# --- J1 ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("delay_samples", [0.3, 3.3, 7.81, 17.77, -2.7, -11.45])
def test_j1_recovers_fractional_delay_of_sine(delay_samples: float) -> None:
    tau = delay_samples * DT
    j1 = metrics.tracking_delay(sine(), sine(tau), DT)
    # Parabolic-peak bias for 512 samples/period is below (2 pi/512)^2/12 ~ 1.3e-5 of a sample;
    # the finite window adds a similar amount: 1e-3 sample is a generous "small fraction".
    assert j1 == pytest.approx(tau, abs=1e-3 * DT)


@pytest.mark.parametrize("delay_samples", [2.37, 9.6])
@pytest.mark.parametrize("cutoff", [5.0, 40.0])
def test_j1_recovers_fractional_delay_of_broadband_record(
    delay_samples: float, cutoff: float
) -> None:
    target, measured = band_limited(8192, cutoff, delay_samples * DT, seed=3)
    j1 = metrics.tracking_delay(target, measured, DT, max_delay=20 * DT)
    # Content below 40 Hz has >= 25 samples per period: parabolic bias < 5e-3 of a sample.
    assert j1 == pytest.approx(delay_samples * DT, abs=5e-3 * DT)


def test_j1_ignores_offset_and_amplitude_error() -> None:
    tau = 4.6 * DT
    measured = 0.8 * sine(tau) + 0.3 * AMP
    # Pearson correlation removes mean and scale: same accuracy as the clean case.
    assert metrics.tracking_delay(sine(), measured, DT) == pytest.approx(tau, abs=1e-3 * DT)


def test_j1_noise_stays_near_cramer_rao_bound() -> None:
    tau, sigma, max_delay = 3.3 * DT, 0.01 * AMP, 20 * DT
    overlap = N - 2 * 20
    # Cramer-Rao bound for a delay with white noise sigma on the measurement only:
    # std(tau) >= sigma / sqrt(sum xdot^2) = sigma / (A omega sqrt(overlap / 2)).
    crlb = sigma / (AMP * OMEGA * math.sqrt(overlap / 2.0))
    errors = []
    for seed in range(40):
        noise = sigma * np.random.default_rng(seed).standard_normal(N)
        errors.append(metrics.tracking_delay(sine(), sine(tau) + noise, DT, max_delay) - tau)
    rms = math.sqrt(float(np.mean(np.square(errors))))
    # 40 draws estimate the RMS to ~11 % (1 sigma); 1.5x the bound leaves >4 sigma of margin
    # and still fails an estimator that is not efficient (measured: 1.08x).
    assert rms < 1.5 * crlb
    assert crlb < 0.02 * DT  # the bound itself is a small fraction of a sample here


# --- amplitude error: J1, J2, J3, FEI, TI ---------------------------------------------------


@pytest.mark.parametrize("eps", [0.05, -0.03])
def test_pure_amplitude_error(eps: float) -> None:
    target = sine()
    measured = (1.0 + eps) * target
    # error = eps * target exactly, so both ratios are |eps| up to rounding.
    assert metrics.normalised_rms_error(target, measured) == pytest.approx(abs(eps), rel=1e-12)
    assert metrics.normalised_peak_error(target, measured) == pytest.approx(abs(eps), rel=1e-12)
    fei = metrics.frequency_evaluation_index(target, measured, DT)
    # X_m = (1+eps) X_t up to FFT rounding (~1e-16 relative).
    assert fei.amplitude == pytest.approx(1.0 + eps, rel=1e-12)
    assert fei.delay == pytest.approx(0.0, abs=1e-12)
    # Correlation peak at lag 0; the fixed measured window against a sliding target window makes
    # it asymmetric by a few 1e-6 of a sample (measured 3e-6), well inside 1e-4 sample.
    assert metrics.tracking_delay(target, measured, DT) == pytest.approx(0.0, abs=1e-4 * DT)
    # Each TI step is 0.5 (1+eps)(a b - b a) = 0 but for the rounding of (1+eps) x: |TI| stays
    # below N * 1e-16 * A^2, against 0.04 A^2 per cycle for a delay of a single sample.
    assert metrics.tracking_indicator(target, measured) == pytest.approx(0.0, abs=1e-12 * AMP**2)


# --- delayed sine over whole periods: J2, J3 ---------------------------------------------------


@pytest.mark.parametrize("delay_samples", [1.5, 6.25, 40.0])
def test_j2_j3_closed_form_for_delayed_sine(delay_samples: float) -> None:
    tau = delay_samples * DT
    target, measured = sine(), sine(tau)
    # x_m - x_t = -2A sin(omega tau/2) cos(omega t - omega tau/2): RMS ratio 2|sin(omega tau/2)|.
    closed = 2.0 * abs(math.sin(OMEGA * tau / 2.0))
    # Whole periods with 512 samples each: discrete mean of cos^2 is exactly 1/2.
    assert metrics.normalised_rms_error(target, measured) == pytest.approx(closed, rel=1e-10)
    assert metrics.sync_subspace_rmse(target, measured) == metrics.normalised_rms_error(
        target, measured
    )
    # Sampled crests lie within half a sample of the true ones, so each maximum is within a
    # factor cos(H/2) of its continuous value.
    crest = 1.0 - math.cos(H / 2.0)
    assert metrics.normalised_peak_error(target, measured) == pytest.approx(closed, rel=crest)


# --- tracking indicator ----------------------------------------------------------------------


@pytest.mark.parametrize("delay_samples", [2.5, 13.0, -8.2])
def test_tracking_indicator_growth_for_delayed_sine(delay_samples: float) -> None:
    phi = OMEGA * delay_samples * DT
    ti = metrics.tracking_indicator(sine(), sine(delay_samples * DT))
    # Derivation.  Each step adds 0.5 (x_t[i-1] x_m[i] - x_t[i] x_m[i-1]) and with
    # x_t = A sin(theta), x_m = A sin(theta - phi):
    #   sin(a) sin(b - phi) - sin(b) sin(a - phi) = sin(phi) sin(b - a),
    # so every step adds exactly 0.5 A^2 sin(phi) sin(H), whatever the starting phase.
    # Per cycle (2 pi / H steps) that is (pi A^2 sin phi) * sin(H)/H -> pi A^2 sin(phi): the
    # area of the ellipse x_t = A sin(theta), x_m = A sin(theta - phi): A and TA change by
    # +/- pi A^2 sin(phi) per cycle, so TI = (A - TA)/2 is the whole enclosed area, not half of
    # it (pi A^2 sin(phi)/2 would be (A - TA)/4).
    exact = 0.5 * np.arange(N) * AMP**2 * math.sin(phi) * math.sin(H)
    assert ti == pytest.approx(exact, rel=1e-9, abs=1e-12 * AMP**2)  # rounding of a cumsum
    per_cycle = ti[512] - ti[0]
    # sin(H)/H = 1 - H^2/6 + ...: relative discretisation error below H^2/6 ~ 2.5e-5.
    assert per_cycle == pytest.approx(math.pi * AMP**2 * math.sin(phi), rel=H**2 / 6.0)
    assert np.sign(per_cycle) == np.sign(delay_samples)  # grows for a lag, falls for a lead


def test_tracking_indicator_and_energy_error_identity_on_random_records() -> None:
    rng = np.random.default_rng(7)
    target = np.cumsum(rng.standard_normal(500)) * 1e-3
    measured = target + 1e-4 * rng.standard_normal(500)
    # With F = x_t the two trapezoidal sums differ only by boundary terms (summation by parts):
    # E_err - TI = 0.5 [x_t (x_m - x_t)]_first^last, exactly for any record.
    e_err = metrics.energy_error(target, measured, target)
    ti = metrics.tracking_indicator(target, measured)
    boundary = 0.5 * (target * (measured - target) - target[0] * (measured[0] - target[0]))
    assert e_err - ti == pytest.approx(boundary, abs=1e-15)  # rounding of O(1e-9) sums


# --- frequency evaluation index ---------------------------------------------------------------


@pytest.mark.parametrize("weight_exponent", [2.0, 1.0])
@pytest.mark.parametrize(("gain", "delay_samples"), [(0.93, 7.3), (1.1, -3.6), (1.0, 60.2)])
def test_fei_recovers_amplitude_and_delay_of_sine(
    weight_exponent: float, gain: float, delay_samples: float
) -> None:
    tau = delay_samples * DT
    fei = metrics.frequency_evaluation_index(
        sine(), gain * sine(tau), DT, weight_exponent=weight_exponent
    )
    # Whole periods: both sines sit on DFT bin 8 exactly, so X_m = gain e^{-i omega tau} X_t
    # there and no other bin has content; only FFT rounding remains.
    assert fei.amplitude == pytest.approx(gain, rel=1e-9)
    assert fei.frequency == pytest.approx(F0, rel=1e-9)
    assert fei.phase == pytest.approx(-OMEGA * tau, rel=1e-9)
    assert fei.delay == pytest.approx(tau, rel=1e-9)


def test_fei_two_tone_closed_form() -> None:
    amps, freqs, tau, gain = (AMP, 0.4 * AMP), (2.0, 6.0), 5.5 * DT, 0.95
    target = sum(a * np.sin(2 * np.pi * f * T) for a, f in zip(amps, freqs, strict=True))
    measured = gain * sum(
        a * np.sin(2 * np.pi * f * (T - tau)) for a, f in zip(amps, freqs, strict=True)
    )
    # Both tones on exact bins; weights |X_t|^2 are proportional to the squared amplitudes.
    weights = np.square(amps)
    index = np.sum(weights * gain * np.exp(-2j * np.pi * np.array(freqs) * tau)) / weights.sum()
    f_eq = float(np.sum(weights * np.array(freqs)) / weights.sum())
    fei = metrics.frequency_evaluation_index(target, measured, DT)
    assert fei.amplitude == pytest.approx(abs(index), rel=1e-9)  # FFT rounding only
    assert fei.frequency == pytest.approx(f_eq, rel=1e-9)
    assert fei.delay == pytest.approx(-np.angle(index) / (2 * np.pi * f_eq), rel=1e-9)
    # ... and that equivalent delay is tau to second order in omega tau (~0.1 rad here).
    assert fei.delay == pytest.approx(tau, rel=1e-2)


# --- energy error -----------------------------------------------------------------------------


@pytest.mark.parametrize("psi", [0.0, 0.7, -1.9])
@pytest.mark.parametrize("delay_samples", [4.4, -9.0])
def test_energy_error_closed_form_for_sine_force(psi: float, delay_samples: float) -> None:
    force_amp, phi = 2.5e4, OMEGA * delay_samples * DT
    n = N + 1  # samples 0..N span exactly 8 whole periods
    force = force_amp * np.sin(OMEGA * np.arange(n) * DT + psi)
    cycles = N // 512
    e_err = metrics.energy_error(sine(n=n), sine(delay_samples * DT, n=n), force)
    # Continuous: per cycle int F0 sin(wt+psi) A w cos(wt-phi) dt = pi F0 A sin(psi + phi), so
    # E_err = cycles * pi F0 A [sin(psi + phi) - sin(psi)].
    continuous = cycles * math.pi * force_amp * AMP * (math.sin(psi + phi) - math.sin(psi))
    # Discrete: each trapezoid adds 0.5 F0 A sin(psi+phi) sin(H) plus a telescoping term that
    # vanishes over whole periods, so the exact sum is continuous * sin(H)/H.
    discrete = continuous * math.sin(H) / H
    assert e_err[-1] == pytest.approx(discrete, rel=1e-9, abs=1e-12 * force_amp * AMP)
    assert e_err[-1] == pytest.approx(continuous, rel=H**2 / 6.0, abs=1e-12 * force_amp * AMP)
    assert e_err[0] == 0.0


def test_energy_error_ratio_closed_form() -> None:
    tau = 6.0 * DT
    force = 3.0e3 * np.sin(OMEGA * T)  # in phase with the target (a spring)
    ratio = metrics.energy_error_ratio(sine(), sine(tau), force)
    # int |F x_t'| dt = F0 A int |sin(th) cos(th)| dth = 2 F0 A per cycle, against
    # pi F0 A sin(omega tau) of energy error: ratio (pi/2) sin(omega tau).  The absolute value
    # kinks at 4 points per cycle: midpoint-rule error O(H^2) relative, below 1e-4 here.
    assert ratio == pytest.approx(0.5 * math.pi * math.sin(OMEGA * tau), rel=1e-4)
    assert ratio > 0.0  # a lagging actuator on a spring injects energy (negative damping)


def test_perfect_tracking_has_no_error() -> None:
    target = sine()
    assert np.all(metrics.energy_error(target, target, 1e3 * target) == 0.0)
    assert metrics.normalised_rms_error(target, target) == 0.0
    assert np.all(metrics.tracking_indicator(target, target) == 0.0)


# --- summary ----------------------------------------------------------------------------------


def test_summary_matches_functions_and_is_json_serialisable() -> None:
    target, measured, force = sine(), 0.97 * sine(5.2 * DT), 1.2e4 * sine()
    summary = metrics.summarize(target, measured, force, DT, max_delay=0.02)
    data = json.loads(json.dumps(summary.to_dict()))
    assert data["j2"] == data["sync_rmse"] == metrics.normalised_rms_error(target, measured)
    assert data["j1_delay"] == metrics.tracking_delay(target, measured, DT, 0.02)
    assert data["j3"] == metrics.normalised_peak_error(target, measured)
    assert data["tracking_indicator"] == metrics.tracking_indicator(target, measured)[-1]
    fei = metrics.frequency_evaluation_index(target, measured, DT)
    assert data["fei_delay"] == fei.delay and data["fei_amplitude"] == fei.amplitude
    assert data["energy_error"] == metrics.energy_error(target, measured, force)[-1]
    assert data["energy_error_ratio"] == metrics.energy_error_ratio(target, measured, force)
    assert data["n_samples"] == N and data["dt"] == DT
    with pytest.raises(dataclasses.FrozenInstanceError):
        summary.j2 = 0.0  # type: ignore[misc]


def test_summary_without_force() -> None:
    summary = metrics.summarize(sine(), sine(2.0 * DT), None, DT)
    assert summary.energy_error is None and summary.energy_error_ratio is None
    assert json.loads(json.dumps(summary.to_dict()))["energy_error"] is None


# --- validation -------------------------------------------------------------------------------


def test_record_validation() -> None:
    good = sine(n=64)
    with pytest.raises(DataError, match=r"measured must have the target's length 64; got 63"):
        metrics.normalised_rms_error(good, good[:-1])
    bad = good.copy()
    bad[5] = np.nan
    with pytest.raises(DataError, match=r"measured must be finite; got nan at index 5"):
        metrics.normalised_peak_error(good, bad)
    bad[5] = np.inf
    with pytest.raises(DataError, match=r"target must be finite; got inf at index 5"):
        metrics.tracking_indicator(bad, good)
    with pytest.raises(DataError, match=r"target must have at least 16 samples; got 15"):
        metrics.sync_subspace_rmse(good[:15], good[:15])
    with pytest.raises(DataError, match=r"measured must be a 1-D array; got shape \(2, 32\)"):
        metrics.normalised_rms_error(good, good.reshape(2, 32))
    with pytest.raises(DataError, match=r"target must be a numeric 1-D array; got 'abc'"):
        metrics.normalised_rms_error("abc", good)
    with pytest.raises(DataError, match=r"target must not be identically zero"):
        metrics.normalised_rms_error(np.zeros(64), good)
    with pytest.raises(DataError, match=r"force must have the target's length 64; got 60"):
        metrics.energy_error(good, good, good[:60])
    with pytest.raises(DataError, match=r"force must be finite; got nan at index 5"):
        metrics.energy_error_ratio(good, good, np.where(np.arange(64) == 5, np.nan, good))


def test_j1_validation() -> None:
    target = sine()
    with pytest.raises(ParameterError, match=r"sampling step dt must be positive; got -0.001"):
        metrics.tracking_delay(target, target, -0.001)
    with pytest.raises(ParameterError, match=r"max_delay must be positive; got 0.0"):
        metrics.tracking_delay(target, target, DT, max_delay=0.0)
    with pytest.raises(ParameterError, match=r"max_delay must leave at least 16 overlapping"):
        metrics.tracking_delay(target[:64], target[:64], DT, max_delay=25 * DT)
    with pytest.raises(DataError, match=r"search limit .* exceeds max_delay=0.005"):
        metrics.tracking_delay(target, sine(30 * DT), DT, max_delay=0.005)
    with pytest.raises(DataError, match=r"one is constant"):
        metrics.tracking_delay(np.ones(N), target, DT)


def test_fei_and_energy_validation() -> None:
    target = sine()
    with pytest.raises(ParameterError, match=r"weight_exponent must be positive; got -1.0"):
        metrics.frequency_evaluation_index(target, target, DT, weight_exponent=-1.0)
    with pytest.raises(ParameterError, match=r"sampling step dt must be positive; got 0"):
        metrics.frequency_evaluation_index(target, target, 0)
    with pytest.raises(DataError, match=r"target has no content above 0 Hz"):
        metrics.frequency_evaluation_index(np.full(N, AMP), target, DT)
    with pytest.raises(DataError, match=r"force does no work along the target"):
        metrics.energy_error_ratio(target, target, np.zeros(N))
    with pytest.raises(ParameterError, match=r"sampling step dt must be finite; got nan"):
        metrics.summarize(target, target, None, float("nan"))
