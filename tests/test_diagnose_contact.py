"""Backlash with a Hertz / Hunt-Crossley contact and impacts in the noise estimate."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, interpolate, optimize, signal

from rths.diagnose.channels import displacement_channel
from rths.diagnose.channels.signals import white_noise_rms
from rths.diagnose.data.nominal import ActuatorNominal, NominalModel, SpecimenNominal
from rths.diagnose.data.records import Record
from rths.diagnose.effects.kernels import series_chain

UNIT = NominalModel(ActuatorNominal((1.0,), (1.0,), 0.0), SpecimenNominal(1000.0, 0.0))


def _record(t: np.ndarray, u: np.ndarray, x: np.ndarray, f: np.ndarray) -> Record:
    return Record("r", float(t[1] - t[0]), t, u, x, f)


def test_hertz_contact_of_the_chain_is_the_quasi_static_closed_form():
    """A slow ramp into a Hertz contact (n = 3/2) held by an overdamped body: once the start's
    transient has decayed the body creeps with the drive, and the spring and damper force
    ``k_b y + c x'`` equals the contact force ``w^2 p_r^(1-n) (x - y - g/2)^n`` -- solved per
    sample by a root finder independent of the kernel's Newton iteration."""
    dt, n_exp, p_r, gap = 1e-3, 1.5, 50e-6, 200e-6
    w2, kb = (2 * math.pi * 300.0) ** 2, (2 * math.pi * 3.0) ** 2  # contact >> body spring
    t = np.arange(0, 4.0, dt)
    x = 300e-6 * np.clip(t - 0.5, 0, None)  # reaches the clearance's edge at ~0.83 s
    v = np.gradient(x, dt)
    c = 100.0  # per unit mass [1/s]: damping ratio 2.6, slow mode c/k_b = 0.28 s
    out = series_chain(
        x, v, dt, omega=math.sqrt(w2), zeta=0.0, gap=gap, damping=c, stiffness=kb,
        exponent=n_exp, reference=p_r,
    )  # fmt: skip
    for i in range(2500, t.size, 250):

        def balance(y, xi=x[i], vi=v[i]):
            p = max(xi - y - gap / 2, 0.0)
            return kb * y + c * vi - w2 * p_r ** (1 - n_exp) * p**n_exp

        y = optimize.brentq(balance, -1e-3, x[i])
        # the transient's residue exp(-(t - 0.83 s)/0.28 s) < 0.3 %, the penetration's creep
        # rate (p grows as F^(2/3)) ~ 1 % of the drive's
        assert out[i] == pytest.approx(kb * y + c * v[i], rel=0.01)
    assert np.all(out[t < 0.8] == 0.0)  # no force inside the clearance


def _hertz_record(
    seed: int = 5, k: float = 2e10, alpha: float = 25.0, c: float = 2000.0
) -> list[Record]:
    """Drive -> clearance (300 um total) -> Hertz contact with Hunt-Crossley damping
    ``F = k p^1.5 (1 + alpha p')`` (default k = 2e10 N/m^1.5, alpha = 25 s/m), never pulling ->
    body of 1000 kg with 2 kN s/m and a 2 Hz spring: integrated by scipy's LSODA (1e-6 relative tolerance)
    at 8 x 1024 Hz, both channels through a 4-pole Bessel anti-alias filter at 256 Hz (an
    impact is shorter than a sample: the filter keeps its impulse), sampled at 1024 Hz with
    1 um / 0.5 N of white noise."""
    rng = np.random.default_rng(seed)
    fs, up, dur = 1024.0, 8, 6.0
    tf = np.arange(1, int(fs * dur * up) + 1) / (fs * up)
    band = signal.butter(4, [0.3, 1.5], "bandpass", fs=fs * up, output="sos")
    drive = signal.sosfiltfilt(band, rng.standard_normal(tf.size))
    drive *= 2e-3 / np.std(drive)
    spl = interpolate.CubicSpline(tf, drive)
    dspl = spl.derivative()
    m, kb, hg = 1000.0, 1000.0 * (2 * math.pi * 2.0) ** 2, 150e-6

    def contact(xd, vd, y, vy):
        r = xd - y
        if abs(r) <= hg:
            return 0.0
        s = math.copysign(1.0, r)
        f = s * k * (abs(r) - hg) ** 1.5 * (1.0 + alpha * s * (vd - vy))
        return f if f * s > 0.0 else 0.0

    def rhs(ti, z):
        f = contact(float(spl(ti)), float(dspl(ti)), z[0], z[1])
        return [z[1], (f - c * z[1] - kb * z[0]) / m]

    sol = integrate.solve_ivp(
        rhs, (tf[0], tf[-1]), [0.0, 0.0], method="LSODA", t_eval=tf, rtol=1e-6,
        atol=[1e-11, 1e-9], max_step=1e-4,
    )  # fmt: skip
    vd = dspl(tf)
    force = np.array([contact(drive[i], vd[i], *sol.y[:, i]) for i in range(tf.size)])
    b, a = signal.bessel(4, 0.25 * fs, fs=fs * up, norm="mag")
    aa = [
        signal.lfilter(b, a, q, zi=signal.lfilter_zi(b, a) * q[0])[0][::up] for q in (drive, force)
    ]
    t = tf[::up]
    x = aa[0] + 1e-6 * rng.standard_normal(t.size)
    return [_record(t, drive[::up], x, aa[1] + 0.5 * rng.standard_normal(t.size))]


def test_a_hertz_contact_is_backlash_with_its_clearance_and_exponent():
    from rths.diagnose.search.selection import select

    channel = displacement_channel(_hertz_record(), UNIT, None)
    res = select(channel, ("internal_stiffness", "backlash"))
    # the force-driven view: scored only where the contact carries force, linear in the
    # clearance -- no replay of the impacts (which the force channel cannot reproduce)
    assert res.effects == ("backlash",)
    p = res.final.params["backlash"]
    # the clearance within 10 % (the target; measured 0.6 %): the contact law's
    # exponent is searched, the deflection at the peak force (~100 um) is not taken for play
    assert p["gap"] == pytest.approx(300e-6, rel=0.1)
    assert res.closed > 0.9


@pytest.mark.parametrize("k", [2e13, 2e12])
def test_a_contact_stiffer_than_the_noise_resolves_never_takes_a_negative_compliance(k):
    """k = 2e13 and 2e12 N/m^1.5: the contact deflects 0.14 and 0.63 um at 1 kN, below the
    displacement noise.  Its compliance is bounded at zero (a contact that gives way against
    the force would be a source); unbounded, the fit took a negative one (-22 mm at the peak
    force for 2e12, seed 5, and the record came out `unexplained`).

    Which verdict such a record gets is not asserted: the contact rattles, the force-driven
    view scores only where it carries force (200-460 held-out samples in runs of 1-5), and
    the bouncing trajectory -- hence the verdict -- turns on the integrator's rounding
    (measured over seeds 5, 6, 8, 9 here: `backlash` on three of four at 2e12 with clearances
    of 160-580 um against 300, `none` or `unexplained` at 2e13; this test had asserted
    `backlash` on seed 5 at 2e13, which held on one machine and not on another).  What holds
    on every seed: no candidate's compliance is negative and none is a series spring (a
    300 um clearance is no spring)."""
    from rths.diagnose.search.selection import select

    for seed in (5, 6, 8, 9):
        channel = displacement_channel(_hertz_record(seed=seed, k=k), UNIT, None)
        res = select(channel, ("internal_stiffness", "backlash"))
        assert res.verdict != "internal_stiffness"
        for cand in res.candidates:
            contact = cand.fit.params.get("backlash", {})
            assert contact.get("peak_deflection", 0.0) >= 0.0
            assert contact.get("gap", 0.0) >= 0.0
            assert cand.fit.params.get("internal_stiffness", {}).get("stiffness", 1.0) > 0.0


def test_noise_level_ignores_sparse_impacts():
    """White noise of 1 N plus a decaying 300 Hz ring of 200 N every 0.5 s (impacts): the top
    of the band is dominated by the rings, the median third difference is not."""
    rng = np.random.default_rng(2)
    dt = 1.0 / 2048.0
    t = np.arange(16 * 2048) * dt
    rings = np.zeros_like(t)
    for t0 in np.arange(0.2, t[-1], 0.5):
        on = t >= t0
        rings[on] += 200.0 * np.exp(-(t[on] - t0) / 0.004) * np.sin(2 * np.pi * 300 * (t[on] - t0))
    slow = 500.0 * np.sin(2 * np.pi * 1.5 * t)
    x = slow + rings + rng.standard_normal(t.size)
    # the median absolute deviation of ~3e4 samples: a few per cent; the rings occupy ~4 %
    assert white_noise_rms(x, dt) == pytest.approx(1.0, rel=0.1)
    assert white_noise_rms(slow + rng.standard_normal(t.size), dt) == pytest.approx(1.0, rel=0.05)


def test_a_series_spring_stiffer_than_the_data_resolve_is_no_element():
    """Band-limited drive of 2 mm RMS into 1000 kg (force RMS ~ 1 kN), 2 um displacement noise,
    the force channel smoothed at 30 Hz (tested up to 45 Hz): a resonance inside the band is an
    element, one far above it only if its static deflection F_rms/k exceeds 2 x 2 um."""
    from rths.diagnose.channels import specimen_channel
    from rths.diagnose.effects.chain import element_resolved

    rng = np.random.default_rng(7)
    dt = 1.0 / 1024.0
    t = dt * np.arange(1, 6 * 1024 + 1)
    band = signal.butter(4, [0.5, 8.0], "bandpass", fs=1024, output="sos")
    drive = signal.sosfiltfilt(band, rng.standard_normal(t.size))
    drive *= 2e-3 / np.std(drive)
    force = 1000.0 * np.gradient(np.gradient(drive, dt), dt)
    x = drive + 2e-6 * rng.standard_normal(t.size)
    ch = specimen_channel([_record(t, drive, x, force)], UNIT, 30.0)
    f_rms = float(np.sqrt(np.mean(ch.stack("observed") ** 2)))
    assert element_resolved(ch, {"stiffness": 5e6, "frequency": 11.3})  # in the band
    stiff = f_rms / (0.5 * 4e-6)  # deflects 2 um: inside the noise band
    assert not element_resolved(ch, {"stiffness": stiff, "frequency": 450.0})
    soft = f_rms / (4.0 * 4e-6)  # deflects 16 um: resolved although its resonance is not
    assert element_resolved(ch, {"stiffness": soft, "frequency": 450.0})


def test_a_friction_inside_the_force_noise_is_no_friction():
    from rths.diagnose.effects.specimen import RESOLVED_CLEARANCE, friction_resolved

    rng = np.random.default_rng(8)
    dt = 1.0 / 1024.0
    t = dt * np.arange(1, 4 * 1024 + 1)
    drive = 2e-3 * np.sin(2 * np.pi * 1.5 * t)
    force = 1000.0 * np.gradient(np.gradient(drive, dt), dt) + 3.0 * rng.standard_normal(t.size)
    from rths.diagnose.channels import specimen_channel

    ch = specimen_channel([_record(t, drive, drive, force)], UNIT, 30.0)
    assert ch.noise["force"] == pytest.approx(3.0, rel=0.1)  # the estimator sees the 3 N
    assert not friction_resolved(ch, 0.5 * RESOLVED_CLEARANCE * 3.0)
    assert friction_resolved(ch, 2.0 * RESOLVED_CLEARANCE * 3.0)


def _rattle(rng: np.random.Generator, t: np.ndarray) -> np.ndarray:
    """Impacts of a lightly damped contact (180 Hz, zeta 0.03) at Poisson times, 20 per second,
    random signs and levels: a rattle whose timing no replay reproduces."""
    dt = t[1] - t[0]
    wd, zeta = 2 * math.pi * 180.0, 0.03
    kernel_t = np.arange(0, 0.2, dt)
    kernel = np.exp(-zeta * wd * kernel_t) * np.sin(wd * kernel_t)
    pulses = np.zeros(t.size)
    hits = rng.random(t.size) < 20.0 * dt
    pulses[hits] = rng.choice([-1.0, 1.0], hits.sum()) * rng.uniform(0.5, 1.5, hits.sum())
    return 300.0 * np.convolve(pulses, kernel)[: t.size]


def test_a_replay_out_of_step_with_a_rattle_has_its_spectrum():
    """The spectral distance of :mod:`rths.diagnose.search.spectral`: a model whose impacts
    fall at other instants than the record's (another realisation of the same rattle) has
    the record's band powers -- ``D`` is the chi-square spread of two Welch estimates, about
    ``2/(n_seg n_bins)`` per band: well under 0.05 here -- although its time-domain residual
    is larger than the impacts themselves; the drive's rigid force alone, which puts no power
    into the contact's band, is far off (``D`` > 10).  White force noise of the floor's level is
    in the record and in neither model."""
    from rths.diagnose.search.spectral import band_distance

    rng = np.random.default_rng(3)
    dt = 1 / 2048
    t = np.arange(0, 30.0, dt)
    rigid = 2000.0 * np.sin(2 * math.pi * 2.0 * t)
    noise_rms = 5.0
    observed = rigid + _rattle(rng, t) + noise_rms * rng.standard_normal(t.size)
    out_of_step = rigid + _rattle(rng, t)
    floor = (np.array([0.0, 1024.0]), np.full(2, 2 * dt * noise_rms**2))
    d_step = band_distance([observed], [out_of_step], dt, floor, 400.0)
    d_rigid = band_distance([observed], [rigid], dt, floor, 400.0)
    residual = np.mean((observed - out_of_step) ** 2) / np.mean((observed - rigid) ** 2)
    assert residual > 1.5  # the replay is worse than no contact at all, sample by sample
    assert d_step < 0.05 and d_rigid > 10.0
