"""Seed checks on the emulated S1 shake-table campaign (short sweeps around the peaks).

S1 §3.1 reports, for the uncontrolled PS and the IM-IF TMDI (S1 Table 1) under stepped sines at
0.05/0.10/0.15 g: softening (f0 falls as the PGA grows; down-sweep peaks higher and lower in
frequency than up-sweep peaks), f1 < f0 < f2, and a peak PS displacement reduction by the TMDI of
37 % at 0.05 g and 25 % at 0.15 g.  S1 §4.2: the ideal-inerter model matches the PS FRFs near f1
but not the secondary-mass and inerter accelerations.  The specimens here are the S1 §4.2
identified models (:func:`rths.sweep.model_configuration`); where that model cannot reproduce a
seed observation the test says so and checks the mechanism instead.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from plants.actuator import MTS_IDENTIFIED
from plants.hdrb import HDRB, S1_PRIMARY
from plants.tmdi import TMDIParameters
from rths.frf import FRF, frf_nrmse, resonance, second_resonance
from rths.sweep import (
    STANDARD_GRAVITY,
    IdealTable,
    SteppedSine,
    TransferFunctionTable,
    command_amplitudes,
    model_configuration,
    sweep_structure,
)

DT = 1e-3
PGAS = (0.05, 0.10, 0.15)
#: fine 0.05 Hz steps over f1 and f0 (1.7-3.0 Hz), 0.1 Hz up to beyond f2
GRID = np.round(np.concatenate([np.arange(1.7, 3.0, 0.05), np.arange(3.0, 7.01, 0.1)]), 9)


def sweep(structure, inerter, grid, pga: float, direction: str = "down", table=None) -> FRF:
    """One stepped-sine run through a table model (the MTS transfer function by default)."""
    table = table or TransferFunctionTable(MTS_IDENTIFIED.num, MTS_IDENTIFIED.den, DT)
    sine = SteppedSine.sweep(grid, direction, 20)
    motion = table.run(sine, command_amplitudes(table, sine.frequencies, pga, DT), DT)
    return sweep_structure(structure, inerter, motion, sine, DT, 5.0, "peak")[0]


def harmonic_balance_peak(iso: HDRB, mass: float, a_g: float) -> tuple[float, float]:
    """Peak amplitude [m] and frequency [Hz] of ``m ü + c u̇ + F_E(u) = -m a_g sin ωt``.

    With the describing-function stiffness ``k(A)`` (:meth:`HDRB.equivalent_stiffness`) the
    amplitude satisfies ``A²[(k - mω²)² + (cω)²] = (m a_g)²``; its largest ``A`` over ω is where
    the two frequency roots merge: ``A c sqrt(4 m k(A) - c²) = 2 m² a_g`` at
    ``ω² = k/m - c²/(2m²)``.
    """
    c = iso.c

    def gap(a: float) -> float:
        stiffness = iso.equivalent_stiffness(a)
        return a * c * math.sqrt(4.0 * mass * stiffness - c * c) - 2.0 * mass**2 * a_g

    amplitude = brentq(gap, 1e-6, iso.softening_limit(), xtol=1e-12)
    k = iso.equivalent_stiffness(amplitude)
    return amplitude, math.sqrt(k / mass - c * c / (2 * mass**2)) / (2 * math.pi)


@pytest.fixture(scope="module")
def campaign() -> dict[tuple[str, float], FRF]:
    """Down sweeps of the three S1 models at the three PGAs (MTS table, amplitude-corrected)."""
    out = {}
    for model in ("uncontrolled", "rack_pinion", "ideal"):
        structure, inerter = model_configuration(model)
        for pga in PGAS:
            out[model, pga] = sweep(structure, inerter, GRID, pga)
    return out


def test_uncontrolled_ps_softens_as_the_harmonic_balance_predicts(campaign) -> None:
    f0 = [resonance(campaign["uncontrolled", pga]).frequency for pga in PGAS]
    assert f0[0] > f0[1] > f0[2]  # measured 2.65 > 2.50 > 2.35 Hz (S1: f0 falls with the PGA)
    structure, _ = model_configuration("uncontrolled")
    for pga, f in zip(PGAS, f0):
        amplitude, f_peak = harmonic_balance_peak(structure.primary_isolator, 125.0,
                                                  pga * STANDARD_GRAVITY)
        peak = np.max(campaign["uncontrolled", pga].response["u_I"])
        # one fine step (0.05 Hz) of grid resolution; describing function + grid miss:
        # measured 0.2-1.0 % below the harmonic-balance peak, f0 within 0.011 Hz of its frequency
        assert abs(f - f_peak) <= 0.05 + 1e-9
        assert peak == pytest.approx(amplitude, rel=0.02)


def test_down_sweep_peaks_higher_and_lower_than_up_sweep_when_multivalued() -> None:
    """The sweep's history dependence: a softening PS with light damping jumps (S1 Fig.5).

    The S1 §4.2 PS (c_I = 538 N s/m, ζ = 12 %) stays single-valued up to 0.15 g (next test),
    so the mechanism is shown on the same springs with c = 150 N s/m (ζ = 3.4 %) at 0.05 g.
    """
    iso = S1_PRIMARY.with_damping(150.0)
    structure = TMDIParameters(125.0, iso)
    grid = np.round(np.arange(2.0, 2.8001, 0.025), 9)
    peaks = {}
    for direction in ("up", "down"):
        frf = sweep(structure, None, grid, 0.05, direction, IdealTable())
        peaks[direction] = (resonance(frf).frequency, float(np.max(frf.response["u_I"])))
    (f_up, u_up), (f_down, u_down) = peaks["up"], peaks["down"]
    assert u_down > 1.1 * u_up  # measured 27.7 mm vs 23.2 mm
    assert f_down < f_up  # measured 2.325 Hz vs 2.45 Hz
    amplitude, f_peak = harmonic_balance_peak(iso, 125.0, 0.05 * STANDARD_GRAVITY)
    # the down sweep climbs the upper branch to its crest: measured 1.1 % below, 0.002 Hz off
    assert u_down == pytest.approx(amplitude, rel=0.03)
    assert abs(f_down - f_peak) <= 0.025 + 1e-9


def test_s1_identified_ps_has_no_up_down_hysteresis() -> None:
    """Known departure from S1 Fig.5: the identified viscous c_I keeps the FRF single-valued."""
    structure, _ = model_configuration("uncontrolled")
    grid = np.round(np.arange(2.1, 2.6001, 0.05), 9)
    up, down = (sweep(structure, None, grid, 0.15, d, IdealTable()) for d in ("up", "down"))
    assert resonance(up).frequency == resonance(down).frequency  # 2.35 Hz both
    # the previous step's transient decays to e^-15 of itself in 20 cycles: no memory left
    assert resonance(down).value == pytest.approx(resonance(up).value, rel=1e-5)


def test_tmdi_resonances_bracket_the_ps_resonance(campaign) -> None:
    for pga in PGAS:
        f0 = resonance(campaign["uncontrolled", pga]).frequency
        for model in ("rack_pinion", "ideal"):
            frf = campaign[model, pga]
            f1 = resonance(frf).frequency
            second = second_resonance(frf, f1, "a_I_tot")
            assert second is not None
            # S1 §3.1: f1 < f0 < f2; measured rack 2.1/2.0/1.9 < 2.65/2.5/2.35 < 5.5/5.7/5.7 Hz
            assert f1 < f0 < second.frequency, (model, pga)


def test_tmdi_lowers_the_peak_ps_displacement(campaign) -> None:
    """S1 §3.1: -37 % at 0.05 g, -25 % at 0.15 g.

    Measured with the S1 §4.2 models (max Ĥ_uI ratio - 1, down sweep): rack-and-pinion
    -14.8 %, -3.9 %, +0.3 %; ideal inerter -2.4 %, -2.5 %, -2.8 %.  The rack-and-pinion model
    follows the seed's trend (smaller reduction at higher PGA) but loses the reduction at
    0.15 g: the same viscous c_I serves the PS alone, and the linearised TMDI is 31 % *worse*
    than the linear PS, the rack's friction and play supplying the reduction at low amplitude.
    """
    change = {
        model: [resonance(campaign[model, p]).value / resonance(campaign["uncontrolled", p]).value
                - 1.0 for p in PGAS]
        for model in ("rack_pinion", "ideal")
    }
    rack, ideal = change["rack_pinion"], change["ideal"]
    assert rack[0] < -0.10 and rack[1] < -0.02  # reductions at 0.05 g and 0.10 g
    assert rack[0] < rack[1] < rack[2]  # the reduction shrinks as the PGA grows (S1 trend)
    assert max(ideal) < -0.01  # the ideal-inerter model reduces the peak at every PGA


def test_ideal_inerter_matches_ps_near_f1_but_not_the_accelerations() -> None:
    """S1 §4.2 / Fig.17-18 at the identification PGA 0.10 g, full 1-10 Hz range."""
    grid = np.round(np.arange(1.0, 10.001, 0.1), 9)
    rack = sweep(*model_configuration("rack_pinion"), grid, 0.10)
    ideal = sweep(*model_configuration("ideal"), grid, 0.10)
    f1 = resonance(rack).frequency
    near = frf_nrmse(rack, ideal, "u_I", band=(0.85 * f1, 1.15 * f1))
    departures = {ch: frf_nrmse(rack, ideal, ch) for ch in ("a_T_tot", "a_T")}
    assert near < 0.05  # measured 2.3 %
    for channel, value in departures.items():
        # measured 77 % (ü_T^(tot)) and 70 % (ü_T): the play's impacts in the accelerations
        assert value > 0.5 and value > 10.0 * near, channel
