"""Oracles for rths.experiments.s1_shake_table.frf: steady-state amplitudes and S1 Eq.7 FRFs from stepped-sine records."""

from __future__ import annotations

import math

import numpy as np
import pytest

from plants.tmdi import EQ7_QUANTITIES, linear_frf, s1_configuration
from rths.core.errors import ParameterError
from rths.experiments.s1_shake_table.frf import (
    FRF,
    Resonance,
    estimate_frf,
    frf_nrmse,
    resonance,
    second_resonance,
    steady_state_amplitude,
    steady_state_windows,
)
from rths.experiments.s1_shake_table.sweep import (
    IdealTable,
    SteppedSine,
    command_amplitudes,
    sweep_structure,
)

DT = 1e-3


def test_harmonic_amplitude_is_exact_for_a_sinusoid_with_offset() -> None:
    f, n = 2.37, 5000
    t = np.arange(n) * DT
    x = 0.3 + 1.7 * np.sin(2 * math.pi * f * t + 0.4)
    window = slice(1234, 1234 + 2345)  # not a whole number of periods
    # least squares on an exact model: round-off only
    assert steady_state_amplitude(x, window, f, DT, "harmonic") == pytest.approx(1.7, rel=1e-12)
    assert steady_state_amplitude(x, window, f, DT, "peak") == pytest.approx(2.0, rel=1e-5)


@pytest.mark.parametrize("f", [1.0, 3.3, 10.0])
def test_peak_amplitude_of_a_sampled_sine(f: float) -> None:
    t = np.arange(20000) * DT
    x = np.sin(2 * math.pi * f * t + 0.123)
    peak = steady_state_amplitude(x, slice(10000, 20000), f, DT, "peak")
    # the nearest sample is at most half a step from the crest: 1 - cos(π f dt) below 1
    assert 1.0 - math.cos(math.pi * f * DT) >= 1.0 - peak >= 0.0


def test_windows_hold_the_last_cycles_of_each_step() -> None:
    sine = SteppedSine(np.array([2.0, 5.0, 1.25]), cycles=4)
    assert sine.boundaries == pytest.approx([0.0, 2.0, 2.8, 6.0], abs=1e-15)
    windows = steady_state_windows(sine.boundaries, sine.frequencies, DT, 6001, 1.5)
    # 1.5 cycles before each step's end: 0.75 s, 0.3 s, 1.2 s
    assert [(w.start, w.stop) for w in windows] == [(1250, 2000), (2500, 2800), (4800, 6000)]


def test_frf_of_the_linear_tmdi_is_the_closed_form() -> None:
    """S1 Eq.7 ratios from a stepped sine through TMDIStructure equal S1 Fig.1a's FRF moduli."""
    par, inerter = s1_configuration("IM", "IF", inerter="ideal")
    lin = par.linear()
    freqs = np.array([1.5, 2.2, 4.0, 6.2])
    # 60 cycles: slowest decay 1.75 1/s → the previous step's transient is < e^-16 by the window
    sine = SteppedSine(freqs, cycles=60)
    table = IdealTable()
    motion = table.run(sine, command_amplitudes(table, freqs, 0.05, DT), DT)
    for method in ("harmonic", "peak"):
        frf, cycles = sweep_structure(lin, inerter, motion, sine, DT, 10.0, method)
        assert frf.channels == EQ7_QUANTITIES
        np.testing.assert_allclose(frf.frequency, freqs)
        closed = linear_frf(lin, inerter.inertance, freqs)
        for name in EQ7_QUANTITIES:
            # trapezoidal warping (ω dt)²/12 ≤ 1.3e-4 amplified ≤ 1/(2ζ) near resonance;
            # "peak" also loses ≤ 1 - cos(π f dt) = 1.9e-4 to sampling; measured 5.1e-4 for both
            np.testing.assert_allclose(
                frf.normalised(name), np.abs(closed[name]), rtol=2e-3, err_msg=f"{method} {name}"
            )
        assert len(cycles) == freqs.size
        assert abs(cycles[0]["u_I"].size - 1.0 / (1.5 * DT)) < 1.0  # one cycle of samples


def test_steps_in_any_order_give_the_same_frf() -> None:
    ps, _ = s1_configuration(None)
    freqs = np.array([2.0, 2.5, 3.0])
    table = IdealTable()
    frfs = []
    for order in (freqs, freqs[::-1]):
        sine = SteppedSine(order, cycles=60)
        motion = table.run(sine, command_amplitudes(table, order, 0.01, DT), DT)
        frfs.append(sweep_structure(ps.linear(), None, motion, sine, DT, 5.0, "harmonic")[0])
    assert frfs[0].channels == ("u_I", "a_I_tot", "F_I")
    # linear system, transients decayed (< e^-20): the history does not matter
    np.testing.assert_allclose(frfs[0].normalised("u_I"), frfs[1].normalised("u_I"), rtol=1e-7)


def synthetic(values: dict[str, np.ndarray], f: np.ndarray | None = None) -> FRF:
    f = np.linspace(1.0, 10.0, 91) if f is None else f
    return FRF(f, np.full(f.shape, 2.0), values)


def test_resonances_of_a_two_peak_curve() -> None:
    f = np.linspace(1.0, 10.0, 91)
    lorentz = lambda f0, w: 1.0 / (1.0 + ((f - f0) / w) ** 2)
    frf = synthetic(
        {
            "u_I": 2 * lorentz(2.2, 0.3),
            "a_I_tot": 2 * (lorentz(2.2, 0.3) + 0.5 * lorentz(6.1, 0.5)),
        },
        f,
    )
    assert resonance(frf) == Resonance(2.2, 1.0)  # excitation 2: Ĥ = H / 2
    assert resonance(frf, band=(5.0, 10.0)).frequency == pytest.approx(5.0)  # monotone tail
    assert second_resonance(frf, 2.2).frequency == pytest.approx(6.1)
    assert second_resonance(frf, 2.2, "u_I") is None  # a single peak


def test_nrmse_of_frfs() -> None:
    base = np.linspace(1.0, 2.0, 91)
    ref = synthetic({"u_I": base})
    assert frf_nrmse(ref, ref, "u_I") == 0.0
    assert frf_nrmse(ref, synthetic({"u_I": 1.1 * base}), "u_I") == pytest.approx(0.1, rel=1e-12)
    # in a band only the points inside count: an offset outside it is ignored
    other = synthetic({"u_I": np.where(ref.frequency > 5.0, 3.0 * base, base)})
    assert frf_nrmse(ref, other, "u_I", band=(1.0, 4.9)) == 0.0


def test_bad_inputs_are_rejected() -> None:
    f = np.array([1.0, 2.0])
    with pytest.raises(ParameterError, match="FRF frequencies must be ascending"):
        FRF(np.array([2.0, 1.0]), np.ones(2))
    with pytest.raises(ParameterError, match=r"FRF excitation must be positive with shape \(2,\)"):
        FRF(f, np.array([1.0, 0.0]))
    with pytest.raises(
        ParameterError, match=r"FRF response 'u_I' must have shape \(2,\); got \(3,\)"
    ):
        FRF(f, np.ones(2), {"u_I": np.ones(3)})
    with pytest.raises(ParameterError, match="FRF channel must be one of 'u_I'; got 'F_B'"):
        FRF(f, np.ones(2), {"u_I": np.ones(2)}).normalised("F_B")
    with pytest.raises(ParameterError, match="amplitude method must be one of 'peak', 'harmonic'"):
        steady_state_amplitude(np.ones(10), slice(0, 10), 1.0, DT, "rms")
    with pytest.raises(ParameterError, match=r"boundaries must have shape \(3,\); got \(2,\)"):
        steady_state_windows([0.0, 1.0], [1.0, 2.0], DT, 100, 1.0)
    with pytest.raises(ParameterError, match="steady cycles 3.0 exceed the cycles of a step"):
        steady_state_windows([0.0, 2.0], [1.0], DT, 3000, 3.0)
    with pytest.raises(ParameterError, match="steady cycles must be positive; got 0.0"):
        steady_state_windows([0.0, 2.0], [1.0], DT, 3000, 0.0)
    with pytest.raises(ParameterError, match=r"the steady window of step 0 \(1 Hz\) has 2 samples"):
        steady_state_windows([0.0, 2.0], [1.0], 0.6, 5, 1.0)
    with pytest.raises(ParameterError, match="step frequencies must be distinct"):
        estimate_frf({}, np.ones(3001), [1.0, 1.0], [0.0, 1.0, 2.0], DT, 1.0)
    with pytest.raises(ParameterError, match=r"signal 'u_I' must have shape \(3001,\); got \(5,\)"):
        estimate_frf({"u_I": np.ones(5)}, np.ones(3001), [1.0, 2.0], [0.0, 1.0, 1.5], DT, 1.0)
    ref = synthetic({"u_I": np.ones(91)})
    with pytest.raises(ParameterError, match=r"no FRF frequency inside the band \(11.0, 12.0\)"):
        resonance(ref, band=(11.0, 12.0))
    with pytest.raises(ParameterError, match="must share the same frequency grid"):
        frf_nrmse(ref, synthetic({"u_I": np.ones(10)}, np.linspace(1.0, 2.0, 10)), "u_I")
