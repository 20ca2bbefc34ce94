"""The amplitude-dependent damping law (S0 Eq.17-18 form) and the damping beside a dissipation
law, against records made here by laws the diagnosis does not hold."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rths.diagnose.channels import specimen_channel
from rths.diagnose.channels.signals import peak_amplitude, running_amplitude
from rths.diagnose.data.nominal import ActuatorNominal, NominalModel, SpecimenNominal
from rths.diagnose.data.records import Record
from rths.diagnose.effects import RigidSpecimen, baseline_for, models_for
from rths.diagnose.effects.kernels import reversal_amplitude
from rths.diagnose.search import fit_model
from rths.diagnose.search.selection import select

FS = 1024.0
DT = 1.0 / FS
M, C0, C1, C2 = 400.0, 2000.0, 40.0, 2e-3  # kg, N s/m, N s, m


def _last_reversal(x: np.ndarray) -> np.ndarray:
    """|x| at the motion's last reversal: the current excursion's amplitude (a causal law the
    diagnosis does not hold: its readings are a mean-square envelope and a fading peak)."""
    out = np.empty_like(x)
    current = abs(x[0])
    for k in range(x.size):
        if 1 <= k < x.size - 1 and (x[k] - x[k - 1]) * (x[k + 1] - x[k]) < 0.0:
            current = abs(x[k])
        out[k] = current
    return out


def _stepped(name: str, levels: list[float], f0: float, hold: float, seed: int) -> Record:
    """A sine whose amplitude steps through ``levels`` [m] (0.5 s raised-cosine transitions,
    ``hold`` s each); force ``M a + (C0 + C1/(A + C2)) v`` with A the last reversal's."""
    n = int(hold * len(levels) * FS)
    t = DT * np.arange(n)
    env = np.full(n, levels[0])
    for i in range(1, len(levels)):
        s = np.clip((t - i * hold) / 0.5, 0.0, 1.0)
        env += (levels[i] - levels[i - 1]) * (0.5 - 0.5 * np.cos(math.pi * s))
    x = np.clip(t / 0.5, 0.0, 1.0) * env * np.sin(2 * math.pi * f0 * t)
    v = np.gradient(x, DT)
    a = np.gradient(v, DT)
    amp = np.maximum(_last_reversal(x), 2e-4)
    rng = np.random.default_rng(seed)
    force = M * a + (C0 + C1 / (amp + C2)) * v + 2.0 * rng.standard_normal(n)
    return Record(name, DT, t, x, x, force)


def _channel(nominal_damping: float):
    nominal = NominalModel(
        ActuatorNominal((1.0,), (1.0,), 0.0), SpecimenNominal(M, nominal_damping, 0.0)
    )
    ident = _stepped("steps", [1e-3, 3e-3, 9e-3], 2.0, 6.0, 0)
    held = _stepped("held", [6e-3, 2e-3], 3.0, 6.0, 1)
    return specimen_channel([ident, held], nominal, 30.0)


def test_amplitude_readings_hold_a_steady_sine_amplitude_at_any_memory():
    """About the record's mean position both readings settle on a steady sine's amplitude; a
    running mean of the same memory, subtracted instead, had followed the oscillation at a
    memory short beside the period (0.92 of the amplitude at 2 Hz, 0.1 s)."""
    t = DT * np.arange(int(20 * FS))
    x = 5e-3 + 3e-3 * np.sin(2 * math.pi * 2.0 * t)  # offset: the transducer's zero
    tail = t > 12.0  # 12 memories: the start from rest has decayed to (1 + 12) e^-12 < 1e-4
    for tau in (0.1, 0.3, 1.0):
        rms = running_amplitude(x, DT, tau)[tail]
        # d^2 = A^2 (1 - cos 2wt)/2: its 4 Hz part through two first-order stages keeps the
        # share r = 1/(1 + (2 pi 4 Hz tau)^2), so the reading lies within A sqrt(1 -/+ r)
        ripple = 1.0 / (1.0 + (2 * math.pi * 4.0 * tau) ** 2)
        assert np.max(np.abs(rms / 3e-3 - 1.0)) <= 1.0 - math.sqrt(1.0 - ripple) + 1e-3
        peak = peak_amplitude(x, DT, tau)[tail]
        # the hold fades by exp(-T/(2 tau)) between two peaks half a period apart
        assert np.max(peak) == pytest.approx(3e-3, rel=1e-3)
        assert np.min(peak) >= 3e-3 * math.exp(-0.25 / tau) * (1 - 1e-3)


def test_the_amplitude_law_is_identified_over_the_records_range_of_amplitude():
    """One identification record steps through 1, 3 and 9 mm: c2 shows only across the
    steps, which short search windows where the drive moves most (the 9 mm step) leave out --
    searched on such windows the fit came out at c1 = 28 or 56 N s (truth 40).  The force's
    amplitude is ``|x|`` at the last reversal, which the diagnosis's half-cycle reading (half
    the excursion between the last two reversals) matches except during the steps (0.5 s of
    every 6 s); without that reading the mean-square and peak-hold trackers lagged there and
    the fit came out c1 7.7 % and c2 8 % low, with it 3.5 and 3.6 % (bounds 8 and 10 %: the
    steps' difference stays)."""
    ch = _channel(0.95 * C0)
    base = fit_model(baseline_for("force"), ch)
    fit = fit_model(RigidSpecimen(("amplitude_damping",)), ch, base.baseline)
    law = fit.params["amplitude_damping"]
    assert law["c1"] == pytest.approx(C1, rel=0.08)
    assert law["c2"] == pytest.approx(C2, rel=0.1)
    assert fit.held_mse < 0.01 * base.held_mse


def test_the_damping_beside_a_law_is_freed_only_when_it_buys_itself():
    """Beside a dissipation law the damping has two structures: the nominal's within its
    tolerance, or free (a law may replace the viscous share of a nominal fitted to the same
    loops).  The free one always fits the identification data at least as well; it is taken
    only when it closes 10 % of the held-out gap the held one leaves: not on steady sines of one
    amplitude each (every reading of A exact), nor on the stepped records, whose law the
    half-cycle reading holds (before that reading a free damping absorbed the trackers' lag at
    the steps and held c1 7.7 % low).  A friction damper whose viscous nominal holds the
    friction's dissipation (0.95 of it here) frees its damping."""
    assert [m.free_damping for m in models_for("force", ("amplitude_damping",))] == [False, True]
    # steady sines, one amplitude each: every reading of A is exact once settled (the force's
    # is the last reversal's), and a free damping buys nothing
    steady = ((1.5e-3, 2.0), (4e-3, 3.0), (9e-3, 1.5), (6e-3, 2.5), (2.5e-3, 1.8), (12e-3, 1.2))
    records = [_stepped(f"s{i}", [amp], f0, 8.0, i) for i, (amp, f0) in enumerate(steady)]
    nominal = NominalModel(ActuatorNominal((1.0,), (1.0,), 0.0), SpecimenNominal(M, C0, 0.0))
    result = select(specimen_channel(records, nominal, 30.0), ("amplitude_damping",))
    assert result.effects == ("amplitude_damping",)
    assert not result.final.model.free_damping
    assert result.final.params["amplitude_damping"]["c1"] == pytest.approx(C1, rel=0.05)

    result = select(_channel(0.95 * C0), ("amplitude_damping",))
    assert result.effects == ("amplitude_damping",)
    assert not result.final.model.free_damping
    assert result.final.params["amplitude_damping"]["c1"] == pytest.approx(C1, rel=0.08)

    t = DT * np.arange(1, 8 * 1024 + 1)
    x = 0.025 * np.sin(2 * math.pi * 0.5 * t) + 0.01 * np.sin(2 * math.pi * 1.3 * t)
    force = 2200.0 * np.tanh(np.gradient(x, DT) / 1e-3)
    viscous = float(force @ np.gradient(x, DT) / (np.gradient(x, DT) @ np.gradient(x, DT)))
    nominal = NominalModel(ActuatorNominal((1.0,), (1.0,), 0.0), SpecimenNominal(0.0, viscous, 0.0))
    half = t.size // 2
    records = [
        Record("a", DT, t[:half], x[:half], x[:half], force[:half]),
        Record("b", DT, t[half:], x[half:], x[half:], force[half:]),
    ]
    result = select(specimen_channel(records, nominal, 30.0), ("coulomb_friction",))
    assert result.effects == ("coulomb_friction",)
    assert result.final.model.free_damping
    assert result.final.baseline["damping"] <= 0.05 * viscous
    assert result.final.params["coulomb_friction"]["friction"] == pytest.approx(2200.0, rel=0.05)


def test_the_half_cycle_reading_is_half_the_excursion_between_the_last_two_reversals():
    """A 1 Hz sine stepping from 2 to 5 mm (at 4 s, a rising zero crossing) about a 4 mm
    offset, with 10 um of noise: 0 until two reversals (0.25 and 0.75 s), then half the last
    excursion -- 2 mm, 3.5 mm for the half cycle across the step (-2 mm at 3.75 s to +5 mm at
    4.25 s), then 5 mm.  With the diagnosis's hysteresis (2 % of the standard deviation, 5 %
    of the amplitude) the noise's wiggles are no reversals: within 5 noise sigma."""
    from rths.diagnose.effects.specimen import REVERSAL_FLOOR, REVERSAL_SHARE

    t = DT * np.arange(int(8 * FS))
    x = np.where(t < 4.0, 2e-3, 5e-3) * np.sin(2 * math.pi * 1.0 * t) + 4e-3
    noisy = x + 10e-6 * np.random.default_rng(3).standard_normal(t.size)
    d = noisy - np.mean(noisy)
    a = reversal_amplitude(d, REVERSAL_FLOOR * float(np.std(d)), REVERSAL_SHARE)
    assert np.all(a[t < 0.75] == 0.0)
    np.testing.assert_allclose(a[(t > 0.85) & (t < 4.25)], 2e-3, atol=50e-6)
    np.testing.assert_allclose(a[(t > 4.35) & (t < 4.75)], 3.5e-3, atol=50e-6)
    np.testing.assert_allclose(a[t > 4.85], 5e-3, atol=50e-6)


def test_an_amplitude_law_on_the_half_cycle_amplitude_is_identified_under_multi_tone_motion():
    """Multi-tone drives (0.7-5 Hz) whose force follows ``C1/(A + C2)`` with A the emulated
    lab's own tracker (:class:`plants.imd.amplitude.AmplitudeTracker`: half the excursion
    between reversals, 10 % relative hysteresis on the noise-free drive; the diagnosis reads
    the measured one with 1 um noise and its own hysteresis).  Under such motion a
    mean-square envelope and a fading peak are other laws: without the half-cycle reading the
    fit closed 94.4 % of the held-out gap with c2 47 % off and the inertance 14 % low; with
    it 99.75 %, c1 0.6 % and c2 16 % off (bounds: 99 % closed, c1 5 %, c2 25 %, the two
    trackers' hysteresis differ) and the half-cycle share above one half."""
    from plants.imd.amplitude import AmplitudeTracker

    c1, c2 = 60.0, 1e-3

    def record(name: str, tones: tuple[tuple[float, float], ...], seed: int) -> Record:
        rng = np.random.default_rng(seed)
        t = DT * np.arange(int(12 * FS))
        x = np.clip(t, 0.0, 1.0) * sum(
            a * np.sin(2 * math.pi * f * t + rng.uniform(0.0, 2 * math.pi)) for f, a in tones
        )
        v = np.gradient(x, DT)
        tracker, amp = AmplitudeTracker(1e-6, 0.1), np.empty_like(x)
        for k, u in enumerate(x):
            tracker.update(float(u))
            amp[k] = tracker.amplitude
        force = M * np.gradient(v, DT) + c1 / (amp + c2) * v + 2.0 * rng.standard_normal(x.size)
        measured = x + 1e-6 * rng.standard_normal(x.size)
        return Record(name, DT, t, measured, measured, force)

    records = [
        record("a", ((0.7, 2e-3), (2.3, 1e-3), (4.1, 0.5e-3)), 0),
        record("b", ((1.1, 3e-3), (3.3, 0.8e-3)), 1),
        record("c", ((0.9, 1.5e-3), (2.9, 1.2e-3), (5.0, 0.4e-3)), 2),
        record("d", ((1.6, 2.5e-3),), 3),
    ]
    nominal = NominalModel(
        ActuatorNominal((1.0,), (1.0,), 0.0), SpecimenNominal(1.05 * M, 0.0, 0.0)
    )
    result = select(specimen_channel(records, nominal, 30.0), ("amplitude_damping",))
    assert result.effects == ("amplitude_damping",)
    law = result.final.params["amplitude_damping"]
    assert result.closed >= 0.99
    assert law["c1"] == pytest.approx(c1, rel=0.05)
    assert law["c2"] == pytest.approx(c2, rel=0.25)
    assert law["reversal"] > 0.5
