"""Candidate-effect simulations against independent computations (closed forms, plant models)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from plants.actuator import MTS_IDENTIFIED, RateLimiter, TransferFunctionActuator
from plants.linear_specimen import LinearSpecimen
from rths.diagnose.effects.kernels import series_force_per_mass, series_force_per_mass_py
from rths.diagnose.channels.signals import actuator_replay, white_noise_rms
from rths.diagnose.channels import actuator_channel, specimen_channel
from rths.diagnose.data.records import Record
from rths.diagnose.effects import (
    ActuatorDelay,
    CoulombFriction,
    RateLimit,
    SpecimenBaseline,
    flywheel_displacement,
)
from rths.diagnose.search import fit_model, noise_floor
from rths.diagnose.data.nominal import ActuatorNominal, NominalModel, SpecimenNominal

UNIT = NominalModel(ActuatorNominal((1.0,), (1.0,), 0.0), SpecimenNominal(1000.0, 0.0))


def _record(t: np.ndarray, u: np.ndarray, x: np.ndarray, f: np.ndarray) -> Record:
    return Record("r", float(t[1] - t[0]), t, u, x, f)


def test_replay_matches_the_emulated_actuator_exactly():
    dt = 1.0 / 2048.0
    u = 3e-3 * np.sin(2 * math.pi * 3.0 * dt * np.arange(4096))
    act = TransferFunctionActuator(
        MTS_IDENTIFIED.num, MTS_IDENTIFIED.den, LinearSpecimen(10.0, 0.0, 0.0), dt
    )
    y = np.array([act.step(v)[0].displacement for v in u])
    # same ZOH model, two realisations (state-space steps vs lfilter): round-off only
    assert np.max(np.abs(actuator_replay(MTS_IDENTIFIED.num, MTS_IDENTIFIED.den, dt, u) - y)) < (
        1e-11 * np.max(np.abs(y))
    )


def test_delay_candidate_is_the_exactly_shifted_sine():
    dt, f0, amp = 1e-3, 5.0, 2e-3
    t = dt * np.arange(1, 4001)
    u = amp * np.sin(2 * math.pi * f0 * t)
    nominal = NominalModel(ActuatorNominal((1.0,), (1.0,), 0.003), UNIT.specimen)
    ch = actuator_channel([_record(t, u, u, u)], nominal, 30.0)
    cols, fixed = ActuatorDelay().columns(ch, ch.segments[0], np.array([0.0047]))
    exact = amp * np.sin(2 * math.pi * f0 * (t - 0.0077))
    # linear interpolation between samples: error <= dt^2 w^2 A / 8 (DelayLine docstring)
    bound = dt**2 * (2 * math.pi * f0) ** 2 * amp / 8
    assert np.max(np.abs(cols[100:, 0] - exact[100:])) <= bound
    assert not np.any(fixed)


def test_rate_limit_candidate_bounds_the_slope_and_is_identity_below_the_limit():
    dt = 1.0 / 1024.0
    t = dt * np.arange(1, 8193)
    u = 3e-3 * np.sin(2 * math.pi * 4.0 * t)  # peak velocity 0.0754 m/s
    ch = actuator_channel([_record(t, u, u, u)], UNIT, 30.0)
    seg, model = ch.segments[0], RateLimit()
    _, limited = model.columns(ch, seg, np.array([1.0, 0.04]))
    assert np.max(np.abs(np.diff(limited))) / dt <= 0.04 * (1 + 1e-12)  # the limiter's law
    _, free = model.columns(ch, seg, np.array([1.0, 0.08]))
    assert np.array_equal(free, u)  # below the limit the output is the input, exactly
    lim = RateLimiter(0.04, dt)  # the plant's stepping object: same semantics
    assert np.allclose([lim.step(v) for v in u], limited, rtol=0, atol=1e-15)


def test_friction_candidate_dissipates_4_F_A_per_cycle():
    dt, f0, amp, friction = 1.0 / 2048.0, 1.0, 5e-3, 100.0
    t = dt * np.arange(1, 10 * 2048 + 1)
    x = amp * np.sin(2 * math.pi * f0 * t)
    ch = specimen_channel([_record(t, x, x, 0 * x)], UNIT, 30.0)
    cols, _ = CoulombFriction().columns(ch, ch.segments[0], np.empty(0))
    force = friction * cols[:, 4]  # columns: a, v, x, amplitude damping, sign, offset
    sel = slice(2 * 2048, 8 * 2048)  # six whole cycles away from the edges
    work = np.sum(force[sel] * np.gradient(x, dt)[sel]) * dt / 6
    # tanh regularisation lowers it by 0.41 (eps/(A w))^2 (IMDParameters docstring), eps is
    # 1e-3 of the velocity RMS here -> 1e-6; the 30 Hz smoother passes the fundamental exactly
    assert work == pytest.approx(4 * friction * amp, rel=1e-3)


@pytest.mark.parametrize("f0", [2.0, 10.0, 13.8, 20.0])
def test_internal_stiffness_force_is_the_closed_form_frf(f0):
    dt, m, fe, zeta = 1.0 / 2048.0, 1589.0, 13.8, 0.03
    w, we = 2 * math.pi * f0, 2 * math.pi * fe
    k = m * we**2
    t = dt * np.arange(40 * 2048)
    x = 1e-3 * np.sin(w * t)
    force = k * (x - flywheel_displacement(x, dt, we, zeta))
    tail = slice(30 * 2048, None)  # steady state (transient decays as exp(-zeta we t))
    basis = np.column_stack([np.sin(w * t[tail]), np.cos(w * t[tail])])
    a, b = np.linalg.lstsq(basis, force[tail], rcond=None)[0]
    s = 1j * w
    frf = k * (1 - we**2 / (s**2 + 2 * zeta * we * s + we**2))  # F/X = k (1 - G), S0 Eq.12
    # FOH exact for piecewise-linear drives; a sine departs by O((w dt)^2/12) < 3e-4
    assert complex(a, b) * 1j / 1e-3 == pytest.approx(1j * frf, rel=1e-3)


def test_series_kernel_numba_equals_python_and_gap_zero_equals_the_linear_filter():
    dt = 1.0 / 1024.0
    t = dt * np.arange(4096)
    ramp = np.sin(0.5 * math.pi * np.minimum(t, 1.0)) ** 2  # starts at rest: both models agree
    x = ramp * (2e-3 * np.sin(2 * math.pi * 1.5 * t) + 5e-4 * np.sin(2 * math.pi * 7.0 * t))
    v = np.gradient(x, dt)
    w = 2 * math.pi * 12.0
    jit = series_force_per_mass(x, v, dt, 3.0, w, 2e-4)
    ref = series_force_per_mass_py(x, v, dt, 3.0, w, 2e-4)
    assert np.allclose(jit, ref, rtol=0, atol=1e-9 * np.max(np.abs(ref)))  # same source
    rk4 = series_force_per_mass(x, v, dt, 3.0, w, 0.0)
    lin = w**2 * (x - flywheel_displacement(x, dt, w, 3.0 / (2 * w)))
    # RK4 on a Hermite drive vs FOH lfilter: two discretisations, O((w dt)^2) apart
    assert np.max(np.abs(rk4 - lin)[100:]) < 2e-3 * np.max(np.abs(lin))
    assert np.any(jit == 0.0)  # the force path is open while the gap is crossed


def test_white_noise_level_and_noise_floor_two_ways():
    rng = np.random.default_rng(3)
    dt = 1.0 / 2048.0
    n = 20 * 2048
    t = dt * np.arange(1, n + 1)
    band = signal.butter(4, [0.3, 5.0], "bandpass", fs=2048, output="sos")
    drive = 3e-3 * signal.sosfiltfilt(band, rng.standard_normal(n))
    drive /= np.std(drive) / 3e-3
    noise = 4e-6 * rng.standard_normal(n)
    # median of ~80-segment Welch averages over ~150 bins: a few per cent
    assert white_noise_rms(drive + noise, dt) == pytest.approx(4e-6, rel=0.05)
    m = 1500.0
    force = m * np.gradient(np.gradient(drive, dt), dt) + 0.5 * rng.standard_normal(n)
    ch = specimen_channel([_record(t, drive, drive + noise, force)], UNIT, 30.0)
    fit = fit_model(SpecimenBaseline(), ch)
    analytic = ch.floor_variance((m, 0.0, 0.0))
    injected = noise_floor(fit, ch, seed=1, repeats=4)
    # kernel formula vs Monte Carlo re-drive: the MC variance estimate over ~7 s of held-out
    # data with noise concentrated near the 30 Hz cutoff scatters by ~5 % per copy
    assert injected == pytest.approx(analytic, rel=0.1)
    assert fit.held_mse == pytest.approx(analytic, rel=0.2)  # residual of the true model
