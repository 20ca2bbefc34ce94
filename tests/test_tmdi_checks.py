"""Seed checks on the emulated S1 shake-table campaign (short sweeps around the peaks).

S1 §3.1 reports, for the uncontrolled PS and the IM-IF TMDI (S1 Table 1) under stepped sines at
0.05/0.10/0.15 g: softening (f0 falls as the PGA grows; down-sweep peaks higher and lower in
frequency than up-sweep peaks), f1 < f0 < f2, and a peak PS displacement reduction by the TMDI of
37 % at 0.05 g and 25 % at 0.15 g.  S1 §4.2: the ideal-inerter model matches the PS FRFs near f1
but not the secondary-mass and inerter accelerations.

The specimens are the ``hdrb = "amplitude"`` models of :func:`rths.experiments.s1_shake_table.sweep.model_configuration`:
the uncontrolled PS calibrated on the numbers S1 reports for it (:mod:`rths.experiments.s1_shake_table.calibration`:
5 mm at 0.05 g, 38 mm at 0.15 g, f0 = 2.25 Hz at 0.10 g), the TMDIs with the S1 §4.2 bearings
and the same amplitude law anchored at S1's dashpots.  Each test states our numbers next to the
seed's; where the model departs from a seed observation the test says so and checks what holds.
"""

from __future__ import annotations

import numpy as np
import pytest

from plants.actuator import MTS_IDENTIFIED
from plants.tmdi.hdrb import (
    AMPLITUDE_EXPONENT,
    HDRB,
    S1_PRIMARY,
    S1_PRIMARY_UNCONTROLLED,
    UNCONTROLLED_STIFFNESS_SCALE,
)
from rths.core.errors import NumericalError, ParameterError
from rths.experiments.s1_shake_table.calibration import (
    S1_UNCONTROLLED,
    calibrate_uncontrolled_ps,
    harmonic_balance_crest,
    stepped_sine_crest,
)
from rths.experiments.s1_shake_table.frf import (
    FRF,
    frf_nrmse,
    resonance,
    second_resonance,
)
from rths.experiments.s1_shake_table.sweep import (
    STANDARD_GRAVITY,
    SteppedSine,
    TransferFunctionTable,
    command_amplitudes,
    model_configuration,
    sweep_structure,
)

DT = 1e-3
PGAS = (0.05, 0.10, 0.15)
MODELS = ("uncontrolled", "rack_pinion", "ideal")
#: S1 §2.3 steps: 0.05 Hz over f1 and f0 (1.5-3.0 Hz), 0.1 Hz up to beyond f2
GRID = np.round(np.concatenate([np.arange(1.5, 3.0, 0.05), np.arange(3.0, 7.01, 0.1)]), 9)
#: S1 §3.1: peak PS displacement change by the IM-IF TMDI
S1_PEAK_CHANGE = {0.05: -0.37, 0.15: -0.25}


def table() -> TransferFunctionTable:
    return TransferFunctionTable(MTS_IDENTIFIED.num, MTS_IDENTIFIED.den, DT)


def sweep(
    model: str, grid: np.ndarray, pga: float, direction: str = "down", hdrb: str = "amplitude"
) -> FRF:
    """One stepped-sine run of a scenario model through the MTS table (amplitude-corrected)."""
    tab = table()
    sine = SteppedSine.sweep(grid, direction, 20)
    motion = tab.run(sine, command_amplitudes(tab, sine.frequencies, pga, DT), DT)
    structure, inerter = model_configuration(model, hdrb=hdrb)
    return sweep_structure(structure, inerter, motion, sine, DT, 5.0, "peak")[0]


@pytest.fixture(scope="module")
def campaign() -> dict[tuple[str, float, str], FRF]:
    """Up and down sweeps of the three models at the three PGAs (S1 grid, MTS table)."""
    return {
        (model, pga, d): sweep(model, GRID, pga, d)
        for model in MODELS
        for pga in PGAS
        for d in ("up", "down")
    }


def peak_mm(frf: FRF) -> float:
    return 1e3 * float(np.max(frf.response["u_I"]))


# --- the calibration ---------------------------------------------------------------------------
def test_s1_identified_ps_misses_the_uncontrolled_numbers() -> None:
    """Why a PS calibration: S1 §4.2's bearing (identified with the TMDI at 0.10 g) alone."""
    crest = [harmonic_balance_crest(S1_PRIMARY, 125.0, pga) for pga in PGAS]
    # harmonic balance of the viscous S1 bearing: 6.8 / 22.8 mm against S1's 5 / 38 mm, and
    # f0 = 2.51 Hz at 0.10 g against 2.25 Hz
    assert crest[0][0] > 0.0065 and crest[2][0] < 0.024 and crest[1][1] > 2.45


def test_calibration_reproduces_the_presets_and_s1_numbers() -> None:
    fit = calibrate_uncontrolled_ps()
    law = S1_PRIMARY_UNCONTROLLED.damping_law
    # the presets are the fit rounded to 4 digits; the time-domain crests jitter by ~1e-4
    assert fit.exponent == pytest.approx(AMPLITUDE_EXPONENT, rel=1e-3)
    assert fit.stiffness_scale == pytest.approx(UNCONTROLLED_STIFFNESS_SCALE, rel=1e-3)
    assert fit.reference_damping == pytest.approx(S1_PRIMARY_UNCONTROLLED.c, rel=1e-3)
    assert law is not None and law.reference_amplitude == 0.010
    # three numbers, three unknowns: the emulated crests meet S1's to 2 % of their reading
    # uncertainty (the stop rule); measured 5.000 mm, 38.00 mm, 2.2500 Hz
    assert max(abs(r) for r in fit.residuals) < 0.05
    assert fit.peaks == pytest.approx((0.005, 0.038), abs=0.05 * 0.0005)
    # harmonic balance is the fit's engine; its crest differs from the time-domain one by the
    # describing function and the peak-vs-first-harmonic measure: measured 0.3 % at 5 mm,
    # 1.6 % at 38 mm, 2 mHz on f0
    (a1, _), (a3, _), (_, f0) = fit.harmonic_balance
    assert a1 == pytest.approx(0.005, rel=0.01) and a3 == pytest.approx(0.038, rel=0.03)
    assert f0 == pytest.approx(2.25, abs=0.01)


def test_s1_springs_alone_cannot_give_f0() -> None:
    """With the S1 §4.2 springs unscaled (s = 1) no damping law meets all three numbers."""
    fit = calibrate_uncontrolled_ps(fit_stiffness=False, time_domain=False)
    # best weighted fit: 6.5 mm (+3.1 σ), 38.4 mm (+0.8 σ), f0 = 2.45 Hz (+8.0 σ): the
    # uncontrolled tests need springs 17 % softer than S1's identification with the TMDI
    assert fit.stiffness_scale == 1.0
    assert fit.residuals[-1] > 5.0


def test_calibration_inputs_are_checked() -> None:
    with pytest.raises(ParameterError, match="reference amplitude A_ref must be positive"):
        calibrate_uncontrolled_ps(reference_amplitude=0.0, time_domain=False)
    with pytest.raises(ParameterError, match="max_iterations must be a positive integer; got 0"):
        calibrate_uncontrolled_ps(max_iterations=0)
    empty = type(S1_UNCONTROLLED)(125.0, (), 0.0005, (0.1, 2.25), 0.025)
    with pytest.raises(ParameterError, match="needs at least one observed peak; got none"):
        calibrate_uncontrolled_ps(empty, time_domain=False)
    with pytest.raises(ParameterError, match="sweep band must span at least two steps"):
        stepped_sine_crest(S1_PRIMARY, 125.0, 0.1, (2.0, 2.005))
    with pytest.raises(ParameterError, match="PGA must be positive; got 0.0"):
        harmonic_balance_crest(S1_PRIMARY, 125.0, 0.0)
    # no dashpot: the harmonic-balance branch grows without a crest
    with pytest.raises(NumericalError, match="no harmonic-balance crest"):
        harmonic_balance_crest(S1_PRIMARY.with_damping(0.0), 125.0, 0.1)


# --- softening (S1 §3.1, Fig.4/5) --------------------------------------------------------------
def folds(iso: HDRB, mass: float, pga: float) -> int:
    """Turning points of the harmonic-balance response curve below its crest.

    Parametrised by the amplitude ``A``, ``A²[(k(A) - mω²)² + (c(A)ω)²] = (m a_g)²`` gives
    ``ω²_±(A)`` (a quadratic in ``ω²``); the FRF is multi-valued -- the sweep direction matters
    -- exactly where ``ω_-(A)`` or ``ω_+(A)`` is not monotonic.
    """
    a = np.geomspace(1e-5, 0.06, 60000)
    c, k = iso.damping_coefficient(a), iso.equivalent_stiffness(a)
    b = c * c - 2.0 * k * mass
    disc = b * b - 4.0 * mass**2 * (k * k - (mass * pga * STANDARD_GRAVITY / a) ** 2)
    real = disc >= 0.0
    turns = 0
    for sign in (-1.0, 1.0):
        w2 = (-b[real] + sign * np.sqrt(disc[real])) / (2.0 * mass**2)
        slope = np.sign(np.diff(w2))
        turns += int(np.count_nonzero(slope[1:] != slope[:-1]))
    return turns


def test_uncontrolled_ps_meets_the_s1_numbers(campaign) -> None:
    """On S1's own grid and the MTS table: the numbers the calibration was given."""
    peaks = {pga: peak_mm(campaign["uncontrolled", pga, "down"]) for pga in PGAS}
    # S1 §3.1 printed to the millimetre: measured 5.00 mm and 37.99 mm (16.33 mm at 0.10 g)
    assert peaks[0.05] == pytest.approx(5.0, abs=0.5)
    assert peaks[0.15] == pytest.approx(38.0, abs=0.5)
    # S1 Fig.12: f0 = 2.25 Hz at 0.10 g; measured 2.25 Hz up and down
    assert resonance(campaign["uncontrolled", 0.10, "down"]).frequency == pytest.approx(2.25)


def test_uncontrolled_ps_softens(campaign) -> None:
    """f0 falls with the PGA; the down sweep peaks higher and lower where the FRF folds.

    Measured (up / down): f0 = 2.40 / 2.40, 2.25 / 2.25, 2.00 / 1.95 Hz; peaks 5.00 / 5.00,
    16.33 / 16.33, 37.14 / 37.99 mm.  S1 Fig.5 shows the down sweep ahead at every PGA; here it
    is ahead at 0.15 g only, where harmonic balance finds the fold.  At 0.05 g S1's spring shape
    cannot fold: a 5 mm peak needs c ≈ 800 N s/m (ζ ≈ 0.2), while the backbone frequency drops
    by only 3.4 % from 0 to 5 mm.
    """
    for d in ("up", "down"):
        f0 = [resonance(campaign["uncontrolled", pga, d]).frequency for pga in PGAS]
        assert f0[0] > f0[1] > f0[2], d
    area = []
    for pga in PGAS:
        up, down = campaign["uncontrolled", pga, "up"], campaign["uncontrolled", pga, "down"]
        r_up, r_down = resonance(up), resonance(down)
        # a single-valued FRF forgets the previous step (transient e^-12 after 20 cycles at
        # ζ >= 0.1): equal to 1e-6; where it folds the down sweep stays on the upper branch
        assert r_down.value >= r_up.value * (1.0 - 1e-6)
        assert r_down.frequency <= r_up.frequency
        area.append(
            float(
                np.sum(down.normalised("u_I") - up.normalised("u_I"))
                / np.sum(down.normalised("u_I"))
            )
        )
        assert (folds(S1_PRIMARY_UNCONTROLLED, 125.0, pga) > 0) == (pga == 0.15)
    assert r_down.value > 1.02 * r_up.value and r_down.frequency < r_up.frequency  # 0.15 g
    # the up/down "hysteresis area" (S1 §3.1) relative to the area under the FRF: measured
    # -9e-8, 5e-5 (slow transients near the fold, not a fold), 1.9e-2 -- growing with the PGA
    assert abs(area[0]) < 1e-3 and abs(area[1]) < 1e-3 and area[2] > 1e-2


# --- the TMDI (S1 §3.1) ------------------------------------------------------------------------
def test_tmdi_resonances_bracket_the_ps_resonance(campaign) -> None:
    for pga in PGAS:
        for d in ("up", "down"):
            f0 = resonance(campaign["uncontrolled", pga, d]).frequency
            for model in ("rack_pinion", "ideal"):
                frf = campaign[model, pga, d]
                f1 = resonance(frf).frequency
                second = second_resonance(frf, f1, "a_I_tot")
                assert second is not None
                # S1 §3.1: f1 < f0 < f2; measured (down) rack 2.10/2.00/1.80 <
                # 2.40/2.25/1.95 < 5.5/5.6/5.7 Hz, ideal f1 the same, f2 6.1/6.0/6.0 Hz
                assert f1 < f0 < second.frequency, (model, pga, d)


def test_tmdi_lowers_the_peak_ps_displacement(campaign) -> None:
    """S1 §3.1: -37 % at 0.05 g, -25 % at 0.15 g (max Ĥ_uI ratio - 1).

    Measured (down sweep): rack-and-pinion -13.5 %, -16.4 %, -24.5 %; ideal inerter -8.1 %,
    -15.2 %, -20.6 % (up sweep at 0.15 g: -23.0 %, -19.1 %).  At 0.15 g the rack model meets
    the seed; at 0.05 g the S1 §4.2 TMDI, identified at 0.10 g, stays well above the seed's
    implied 3.2 mm (4.3 mm), so the reduction grows with the PGA where S1's shrinks.
    """
    for pga in PGAS:
        for d in ("up", "down"):
            ps = resonance(campaign["uncontrolled", pga, d]).value
            rack = resonance(campaign["rack_pinion", pga, d]).value / ps - 1.0
            ideal = resonance(campaign["ideal", pga, d]).value / ps - 1.0
            assert rack < -0.10 and ideal < -0.05, (pga, d)  # lower at every PGA
    change = (
        resonance(campaign["rack_pinion", 0.15, "down"]).value
        / resonance(campaign["uncontrolled", 0.15, "down"]).value
        - 1.0
    )
    assert change == pytest.approx(S1_PEAK_CHANGE[0.15], abs=0.01)


# --- the S1 §4.2 models at the identification PGA ----------------------------------------------
@pytest.fixture(scope="module")
def full_range() -> dict[tuple[str, str], FRF]:
    """Down sweeps over 1-10 Hz at 0.10 g (the S1 Eq.14 identification test)."""
    grid = np.round(np.arange(1.0, 10.001, 0.1), 9)
    return {
        (model, hdrb): sweep(model, grid, 0.10, "down", hdrb)
        for model, hdrb in (
            ("rack_pinion", "amplitude"),
            ("ideal", "amplitude"),
            ("rack_pinion", "viscous"),
        )
    }


def test_amplitude_law_keeps_the_s1_identification(full_range) -> None:
    """At 0.10 g the amplitude-law TMDI stays close to the S1 §4.2 model S1 found to match."""
    law, viscous = full_range["rack_pinion", "amplitude"], full_range["rack_pinion", "viscous"]
    # anchored at the viscous model's peak: measured 13.65 vs 13.66 mm
    assert peak_mm(law) == pytest.approx(peak_mm(viscous), rel=0.005)
    # the law damps the flanks (A < 13.7 mm) more than a dashpot: measured NRMSE over 1-10 Hz
    # u_I 4.9 %, ü_I 2.9 %, u_TI 5.7 %, ü_T 3.0 %, F_B 6.2 % (the S1 Eq.14 quantities)
    for channel in ("u_I", "a_I_tot", "u_TI", "a_T_tot", "F_B"):
        assert frf_nrmse(viscous, law, channel) < 0.07, channel


def test_ideal_inerter_matches_ps_near_f1_but_not_the_accelerations(full_range) -> None:
    """S1 §4.2 / Fig.17-18 at the identification PGA 0.10 g, full 1-10 Hz range."""
    rack, ideal = full_range["rack_pinion", "amplitude"], full_range["ideal", "amplitude"]
    f1 = resonance(rack).frequency
    near = frf_nrmse(rack, ideal, "u_I", band=(0.85 * f1, 1.15 * f1))
    departures = {ch: frf_nrmse(rack, ideal, ch) for ch in ("a_T_tot", "a_T")}
    assert near < 0.05  # measured 1.3 %
    for channel, value in departures.items():
        # measured 78 % (ü_T^(tot)) and 73 % (ü_T): the play's impacts in the accelerations
        assert value > 0.5 and value > 10.0 * near, channel


def test_crests_of_a_linear_ps_are_the_closed_form() -> None:
    """Linear viscous SDOF: peak of |H| = 2 m / (c sqrt(4 m k - c²)) at ω² = k/m - c²/(2 m²)."""
    iso, m, pga = HDRB(3.94e4, c=538.13), 125.0, 0.10
    a_g = pga * STANDARD_GRAVITY
    amplitude = 2.0 * m * m * a_g / (iso.c * np.sqrt(4.0 * m * iso.k1 - iso.c**2))
    frequency = np.sqrt(iso.k1 / m - iso.c**2 / (2.0 * m * m)) / (2.0 * np.pi)
    hb = harmonic_balance_crest(iso, m, pga)
    assert hb[0] == pytest.approx(amplitude, rel=1e-10)  # brentq to 1e-12
    assert hb[1] == pytest.approx(frequency, rel=1e-10)
    td = stepped_sine_crest(iso, m, pga, (0.95 * frequency, 1.05 * frequency))
    # trapezoidal warping (ω dt)²/12 = 2e-5, sampled peak 1 - cos(ω dt/2) = 5e-5, parabola
    # through a flat crest on 5 mHz steps: measured -8e-7 and -0.1 mHz
    assert td[0] == pytest.approx(amplitude, rel=2e-4)
    assert td[1] == pytest.approx(frequency, abs=1e-3)
    with pytest.raises(NumericalError, match="largest response of the sweep is at its edge"):
        stepped_sine_crest(iso, m, pga, (1.05 * frequency, 1.2 * frequency))


def test_crest_methods_agree_for_a_viscous_bearing() -> None:
    """Cross-check of the two crest estimates on the S1 bearing (no law): time domain vs
    harmonic balance."""
    amplitude, frequency = harmonic_balance_crest(S1_PRIMARY, 125.0, 0.10)
    td_amplitude, td_frequency = stepped_sine_crest(
        S1_PRIMARY, 125.0, 0.10, (0.95 * frequency, 1.05 * frequency)
    )
    # describing function + peak measure at 14 mm: measured -0.5 % and +1 mHz
    assert td_amplitude == pytest.approx(amplitude, rel=0.01)
    assert td_frequency == pytest.approx(frequency, abs=0.01)
