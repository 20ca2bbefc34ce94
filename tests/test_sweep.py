"""Stepped-sine shake-table emulation (rths.experiments.s1_shake_table.sweep): signal, tables, scenario file, runs, CLI."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from plants.actuator import MTS_IDENTIFIED, TransferFunctionActuator
from plants.base import Specimen
from plants.tmdi import (
    NominalInerter,
    TMDIStructure,
    TMDISubstructure,
    s1_configuration,
)
from plants.tmdi.inerter import IdealInerter
from rths.campaign import Cluster
from rths.cli import main
from rths.core.errors import ConfigError, ParameterError
from rths.experiments.s1_shake_table.report import frf_table, loops_figure, summarise
from rths.experiments.s1_shake_table.sweep import (
    STANDARD_GRAVITY,
    IdealTable,
    SteppedSine,
    TransferFunctionTable,
    command_amplitudes,
    frequency_grid,
    load_sweep,
    model_configuration,
    parse_sweep,
    run_sweep,
    step_frequencies,
    stepped_sine_acceleration,
)

SCENARIO = Path(__file__).resolve().parents[1] / "scenarios" / "tmdi_shake_table.toml"
DT = 1e-3

TINY = """
[sweep]
name = "tiny"
rate = 1000.0
pga = [0.1]
cycles = 6
steady_cycles = 2
[sweep.grid]
f_start = 1.8
f_stop = 2.8
coarse_step = 0.5
fine_step = 0.25
fine_band = [0.9, 1.1]
[specimen]
models = ["uncontrolled", "rack_pinion", "ideal"]
[table]
kind = "ideal"
"""


# --- frequency grid and stepped sine ------------------------------------------------------------
def test_grid_is_coarse_away_from_and_fine_near_resonance() -> None:
    grid = frequency_grid(1.0, 10.0, 0.1, 0.05, centres=[2.0, 6.0], band=(0.75, 1.15))
    fine = (grid >= 1.5 - 1e-9) & (grid <= 2.3 + 1e-9) | (grid >= 4.5 - 1e-9) & (grid <= 6.9)
    steps = np.diff(grid)
    assert grid[0] == 1.0 and grid[-1] == 10.0
    np.testing.assert_allclose(steps[fine[1:] & fine[:-1]], 0.05, atol=1e-9)
    np.testing.assert_allclose(steps[~fine[1:] & ~fine[:-1]], 0.1, atol=1e-9)
    # 91 coarse points + the half-steps in [1.5, 2.3] (8) and [4.5, 6.9] (24)
    assert grid.size == 91 + 8 + 24
    assert frequency_grid(1.03, 1.97, 0.1, 0.05).tolist() == pytest.approx(
        [1.03, 1.1, 1.2, 1.3, 1.4, 1.5, 1.6, 1.7, 1.8, 1.9, 1.97]
    )


def test_stepped_sine_timing_and_continuity() -> None:
    sine = SteppedSine.sweep([1.0, 2.5, 4.0], "down", cycles=3)
    assert sine.frequencies.tolist() == [4.0, 2.5, 1.0]
    assert sine.duration == pytest.approx(3 / 4 + 3 / 2.5 + 3.0, rel=1e-15)
    bounds = sine.boundaries
    # phase zero at every step start and whole cycles: zero at every boundary from both sides
    for b in bounds[1:-1]:
        assert abs(sine.signal(b - 1e-12, 1.0)) < 1e-9 and abs(sine.signal(b, 1.0)) < 1e-12
    t = np.linspace(-0.1, sine.duration + 0.5, 777)
    f = sine.function(2.0)
    np.testing.assert_allclose([f(x) for x in t], sine.signal(t, 2.0), atol=1e-12)
    assert f(-1.0) == 0.0 and f(sine.duration + 0.1) == 0.0
    assert sine.sample_times(DT)[-1] >= sine.duration
    up = SteppedSine.sweep([4.0, 1.0, 2.5], "up")
    assert up.frequencies.tolist() == [1.0, 2.5, 4.0] and up.cycles == 20


def test_stepped_sine_drives_an_rths_substructure() -> None:
    """stepped_sine_acceleration as the ü_G of TMDISubstructure = the sampled monolithic run."""
    grid = [2.0, 2.2]
    accel = stepped_sine_acceleration(grid, 0.1, cycles=4, direction="down")
    assert accel(0.01) == pytest.approx(0.1 * STANDARD_GRAVITY * math.sin(2 * math.pi * 2.2 * 0.01))
    sine = SteppedSine.sweep(grid, "down", 4)
    t = sine.sample_times(DT)
    par, _ = s1_configuration("IM", "IF")
    b = 47.84
    mono = TMDIStructure(par, IdealInerter(b), DT).run([accel(x) for x in t])
    sub = TMDISubstructure(par, accel, DT, device=NominalInerter(b))
    u_i = [0.0] + [(sub.step(0.0), sub.outputs()["u_I"])[1] for _ in range(t.size - 1)]
    np.testing.assert_allclose(u_i, mono.u_I, rtol=0, atol=1e-15)  # same kernel, same samples
    as_given = stepped_sine_acceleration([2.2, 2.0], 0.1, cycles=4)
    assert as_given(0.3) == accel(0.3)


# --- table models -------------------------------------------------------------------------------
class _Rigid(Specimen):
    def _reset_impl(self) -> None:
        pass

    def _step_impl(self, u: float, v: float, a: float, dt: float) -> float:
        return 0.0


def test_transfer_function_table_is_the_project_actuator_stepped() -> None:
    """lfilter of the ZOH model = TransferFunctionActuator driven sample by sample."""
    sine = SteppedSine(np.array([2.0, 7.5]), cycles=3)
    table = TransferFunctionTable(MTS_IDENTIFIED.num, MTS_IDENTIFIED.den, DT)
    motion = table.run(sine, 0.01)
    actuator = TransferFunctionActuator(MTS_IDENTIFIED.num, MTS_IDENTIFIED.den, _Rigid(), DT)
    reference = np.zeros((motion.time.size, 3))
    for n in range(motion.time.size - 1):
        kin, _ = actuator.step(motion.command[n])
        reference[n + 1] = kin.displacement, kin.velocity, kin.acceleration
    for i, x in enumerate((motion.displacement, motion.velocity, motion.acceleration)):
        # two exact ZOH realisations of one model: round-off (measured ≤ 7e-13)
        np.testing.assert_allclose(
            x, reference[:, i], rtol=0, atol=1e-10 * np.max(np.abs(reference[:, i]))
        )


@pytest.mark.parametrize(
    "table", [IdealTable(), TransferFunctionTable(MTS_IDENTIFIED.num, MTS_IDENTIFIED.den, DT)]
)
def test_amplitude_correction_gives_the_target_pga(table) -> None:
    freqs = np.array([1.0, 4.0, 10.0])
    sine = SteppedSine(freqs, cycles=20)
    motion = table.run(sine, command_amplitudes(table, freqs, 0.15, DT), DT)
    bounds = sine.boundaries
    for k, f in enumerate(freqs):
        last = (motion.time >= bounds[k + 1] - 5 / f) & (motion.time < bounds[k + 1])
        peak = np.max(np.abs(motion.acceleration[last]))
        # steady state (table poles decay ≥ 44 1/s: e^-22 after 0.5 s) sampled within
        # 1 - cos(π f dt) of its crest
        assert peak == pytest.approx(0.15 * STANDARD_GRAVITY, rel=1 - math.cos(math.pi * f * DT))
    plain = command_amplitudes(table, freqs, 0.15, DT, correction=False)
    np.testing.assert_allclose(
        plain, 0.15 * STANDARD_GRAVITY / (2 * np.pi * freqs) ** 2, rtol=1e-15
    )


def test_ideal_table_derivatives_are_consistent() -> None:
    sine = SteppedSine(np.array([3.0]), cycles=2)
    m = IdealTable().run(sine, 0.002, DT)
    inner = slice(1, m.time.size - 2)
    # central differences of a 3 Hz sine at 1 kHz: relative error (ω dt)²/6 = 6e-5
    np.testing.assert_allclose(
        np.gradient(m.displacement, DT)[inner],
        m.velocity[inner],
        atol=1e-4 * np.max(np.abs(m.velocity)),
    )
    np.testing.assert_allclose(
        np.gradient(m.velocity, DT)[inner],
        m.acceleration[inner],
        atol=1e-4 * np.max(np.abs(m.acceleration)),
    )
    assert np.array_equal(m.command, m.displacement)


# --- scenario file ------------------------------------------------------------------------------
def test_shipped_scenario() -> None:
    cfg = load_sweep(SCENARIO)
    assert cfg.pga == (0.05, 0.10, 0.15) and cfg.directions == ("up", "down")
    assert cfg.cycles == 20 and cfg.dt == 1e-3 and cfg.amplitude == "peak"
    assert cfg.table.num == MTS_IDENTIFIED.num and cfg.table.amplitude_correction
    assert cfg.hdrb == "amplitude"
    grid = step_frequencies(cfg)
    # fine (0.05 Hz) steps around the resonances: f1 ≈ 1.8-2.1 Hz, f0 ≈ 1.95-2.4 Hz (linearised
    # 2.57 Hz, band from 1.93 Hz), f2 ≈ 5.5-6.1 Hz
    for f in (1.8, 1.85, 1.95, 2.0, 2.25, 2.4, 2.5, 2.55, 5.65):
        assert np.any(np.isclose(grid, f, atol=1e-9)), f
    assert np.min(np.diff(grid)) == pytest.approx(0.05, abs=1e-9)


@pytest.mark.parametrize(
    "edit, match",
    [
        (("rate = 1000.0", "rate = -1.0"), r"\[sweep\] rate: must be positive; got -1.0"),
        (("pga = [0.1]", "pga = [0.1, -0.2]"), r"\[sweep\] pga: entries must be positive"),
        (
            ("pga = [0.1]", "pga = [0.1]\ndirections = ['up', 'sideways']"),
            r"\[sweep\] directions: entries must be among 'up', 'down'; got 'sideways'",
        ),
        (
            ("pga = [0.1]", "pga = [0.1]\ndirections = []"),
            r"\[sweep\] directions: must be a non-empty list",
        ),
        (
            ("pga = [0.1]", "pga = [0.1]\ndirections = ['up', 'up']"),
            r"\[sweep\] directions: entries must be distinct",
        ),
        (
            ("steady_cycles = 2", "steady_cycles = 7"),
            r"\[sweep\] steady_cycles: must not exceed cycles = 6; got 7",
        ),
        (("f_stop = 2.8", "f_stop = 1.0"), r"\[sweep.grid\] f_stop: must exceed f_start"),
        (
            ("fine_band = [0.9, 1.1]", "fine_band = [1.1, 0.9]"),
            r"\[sweep.grid\] fine_band: must be \[lo, hi\] with 0 < lo <= 1 <= hi",
        ),
        (
            ("fine_band = [0.9, 1.1]", "fine_band = [0.9, 1.1, 1.2]"),
            r"\[sweep.grid\] fine_band: must be \[lo, hi\]",
        ),
        (
            ('models = ["uncontrolled", "rack_pinion", "ideal"]', 'models = ["tmd"]'),
            r"\[specimen\] models: entries must be among 'uncontrolled', 'rack_pinion', 'ideal'",
        ),
        (("[specimen]", "[specimen]\nmass = 'XL'"), r"\[specimen\] mass: must be one of 'SM'"),
        (
            ("[specimen]", "[specimen]\nhdrb = 'bouc_wen'"),
            r"\[specimen\] hdrb: must be one of 'viscous', 'amplitude'; got 'bouc_wen'",
        ),
        (('kind = "ideal"', 'kind = "ideal"\nspeed = 3'), r"\[table\] speed: unknown key"),
        (('kind = "ideal"', 'kind = "hexapod"'), r"\[table\] kind: must be one of"),
        (
            (
                'kind = "ideal"',
                'kind = "transfer_function"\npreset = "mts_identified"\nnum = [1.0]',
            ),
            r"\[table\] preset: give either preset or num/den",
        ),
        (
            ('kind = "ideal"', 'kind = "transfer_function"\npreset = "moog"'),
            r"\[table\] preset: must be one of 'mts_identified'; got 'moog'",
        ),
        (
            ('kind = "ideal"', 'kind = "transfer_function"\nnum = [1.0]\nden = [1.0, 2.0, 1.0]'),
            r"\[table\] den: relative degree must be >= 3; got 2",
        ),
        (("cycles = 6", "cycles = 6\nrepeat = 2"), r"\[sweep\] repeat: unknown key"),
        (("[sweep]", "[run]\n[sweep]"), r"\[top level\] run: unknown key"),
    ],
)
def test_scenario_errors_name_file_table_and_key(edit: tuple[str, str], match: str) -> None:
    old, new = edit
    assert old in TINY
    with pytest.raises(ConfigError, match=r"tiny.toml: " + match):
        parse_sweep(TINY.replace(old, new, 1), "tiny.toml")


def test_scenario_file_errors(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="no such file"):
        load_sweep(tmp_path / "missing.toml")
    with pytest.raises(ConfigError, match=r"x.toml: \[top level\] sweep: missing \(required\)"):
        parse_sweep("", "x.toml")
    cfg = parse_sweep(
        TINY.replace(
            'kind = "ideal"',
            'kind = "transfer_function"\nnum = [8.0e6]\nden = [1.0, 400.0, 4.0e4, 8.0e6]',
        ),
        "t.toml",
    )
    assert cfg.table.num == (8.0e6,) and cfg.table.den == (1.0, 400.0, 4.0e4, 8.0e6)


# --- runs, report, CLI --------------------------------------------------------------------------
def test_tiny_sweep_runs_and_reports() -> None:
    cfg = parse_sweep(TINY, "tiny.toml")
    result = run_sweep(cfg, progress=True)
    # the same jobs as a campaign on Dask workers (threads here): the same FRFs, bit for bit
    on_dask = run_sweep(cfg, cluster=Cluster(workers=2, processes=False))
    assert [(r.model, r.direction, r.pga) for r in on_dask.runs] == [
        (r.model, r.direction, r.pga) for r in result.runs
    ]
    for a, b in zip(result.runs, on_dask.runs, strict=True):
        for name in a.frf.channels:
            np.testing.assert_array_equal(a.frf.response[name], b.frf.response[name])
    # coarse 0.5 Hz lattice + ends, and the 0.25 Hz points within 0.9-1.1 x the linearised
    # f1 (2.245 Hz rack-and-pinion, 2.238 Hz ideal) and f0 (2.577 Hz, the calibrated PS):
    # 2.25 and 2.5, 2.75
    assert result.grid.tolist() == pytest.approx([1.8, 2.0, 2.25, 2.5, 2.75, 2.8])
    assert len(result.runs) == 3 * 2 and result.pgas == (0.1,)
    run = result.get("rack_pinion", "down", 0.1)
    assert run.frf.frequency.tolist() == result.grid.tolist()
    # the ideal table delivers the PGA (sampled crest within 1 - cos(π f dt) = 4e-5)
    np.testing.assert_allclose(run.frf.excitation, 0.1 * STANDARD_GRAVITY, rtol=4e-5)
    freq, cycle = run.cycle_at(2.26)
    assert freq == 2.25 and set(cycle) == {*run.frf.channels, "a_G"}
    assert result.get("uncontrolled", "up", 0.1).frf.channels == ("u_I", "a_I_tot", "F_I")
    summary = summarise(result)
    entry = summary["pga"]["0.1"]
    assert set(entry["resonances"]) == {"uncontrolled", "rack_pinion", "ideal"}
    assert set(entry["nrmse_ideal_vs_rack_pinion"]["up"]["u_I"]) == {"full", "near_f1"}
    header, rows = frf_table(result)
    assert len(rows) == 6 * 6 and header[5] == "u_I [s^2]" and rows[0][-1] == ""
    with pytest.raises(ParameterError, match="no run of model 'ideal', direction 'up', PGA 0.2"):
        result.get("ideal", "up", 0.2)
    with pytest.raises(ParameterError, match="PGA must be positive; got -0.1"):
        run_sweep(cfg, pga=[-0.1])
    with pytest.raises(ParameterError, match="at least one PGA is needed"):
        run_sweep(cfg, pga=[])


def test_cli_writes_table_summary_and_figures(tmp_path: Path, capsys) -> None:
    scenario = tmp_path / "tiny.toml"
    scenario.write_text(
        TINY.replace('["uncontrolled", "rack_pinion", "ideal"]', '["uncontrolled", "rack_pinion"]'),
        encoding="utf-8",
    )
    out = tmp_path / "out"
    assert (
        main(["sweep", str(scenario), "--pga", "0.05", "--out", str(out), "--json", "--in-process"])
        == 0
    )
    summary = json.loads(capsys.readouterr().out)
    assert list(summary["pga"]) == ["0.05"] and summary["scenario"] == "tiny"
    assert json.loads((out / "summary.json").read_text()) == summary
    lines = (out / "frf.csv").read_text().splitlines()
    assert lines[0].startswith("pga [g],model,direction,frequency [Hz],a_G [m/s^2],u_I [s^2]")
    assert len(lines) == 1 + 2 * 2 * 6
    records = json.loads((out / "frf.json").read_text())
    assert records["units"]["F_B"] == "kg" and len(records["runs"]) == 4
    first = records["runs"][0]
    assert first["model"] == "uncontrolled" and set(first["frf"]) == {"u_I", "a_I_tot", "F_I"}
    # the JSON and the CSV carry the same numbers (CSV at 9 significant digits)
    assert float(lines[1].split(",")[5]) == pytest.approx(first["frf"]["u_I"][0], rel=1e-8)
    assert sorted(p.name for p in out.glob("*.png")) == [
        "frf_0.05g.png",
        "loops_0.05g.png",
        "ps_displacement.png",
    ]
    assert (
        main(
            [
                "sweep",
                str(scenario),
                "--out",
                str(tmp_path / "o2"),
                "--no-figures",
                "--quiet",
                "--in-process",
            ]
        )
        == 0
    )
    text = capsys.readouterr().out
    assert "rack_pinion" in text and "wrote" in text
    assert not list((tmp_path / "o2").glob("*.png"))


def test_cli_reports_a_bad_scenario_in_one_line(tmp_path: Path, capsys) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text(TINY.replace("rate = 1000.0", "rate = 0.0"), encoding="utf-8")
    assert main(["sweep", str(bad), "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("rths sweep: error:") and "rate: must be positive; got 0.0" in err


def test_model_and_table_validation() -> None:
    assert model_configuration("uncontrolled")[1] is None
    assert isinstance(model_configuration("ideal")[1], IdealInerter)
    with pytest.raises(ParameterError, match="model must be one of 'uncontrolled', 'rack_pinion'"):
        model_configuration("tmd")
    with pytest.raises(ParameterError, match="relative degree >= 3 .*; got 1"):
        TransferFunctionTable([1.0], [1.0, 1.0], DT)
    with pytest.raises(ParameterError, match="table transfer function is unstable"):
        TransferFunctionTable([1.0], [1.0, 0.0, 1.0, -1.0], DT)
    with pytest.raises(ParameterError, match="needs finite, non-zero num and den"):
        TransferFunctionTable([0.0], [1.0, 1.0, 1.0, 1.0], DT)
    table = TransferFunctionTable(MTS_IDENTIFIED.num, MTS_IDENTIFIED.den, DT)
    with pytest.raises(ParameterError, match="dt must be the table's 0.001 s; got 0.002"):
        table.run(SteppedSine(np.array([1.0])), 1.0, 2e-3)
    with pytest.raises(ParameterError, match="dt must be the table's 0.001 s; got 0.002"):
        table.acceleration_gain(1.0, 2e-3)
    with pytest.raises(ParameterError, match="sweep direction must be 'up' or 'down'; got 'in'"):
        SteppedSine.sweep([1.0], "in")
    with pytest.raises(ParameterError, match="step frequencies must be a non-empty 1-D array"):
        SteppedSine(np.array([1.0, -2.0]))
    with pytest.raises(ParameterError, match="cycles per step must be a positive integer; got 0"):
        SteppedSine(np.array([1.0]), 0)
    with pytest.raises(ParameterError, match="f_stop must exceed f_start = 2.0 Hz; got 1.0"):
        frequency_grid(2.0, 1.0, 0.1, 0.05)
    with pytest.raises(
        ParameterError, match=r"fine band must satisfy 0 < lo <= 1 <= hi; got \(1.2, 1.5\)"
    ):
        frequency_grid(1.0, 2.0, 0.1, 0.05, [1.5], (1.2, 1.5))
    with pytest.raises(ParameterError, match="resonance centre must be positive; got -1.5"):
        frequency_grid(1.0, 2.0, 0.1, 0.05, [-1.5])
    with pytest.raises(ParameterError, match="PGA must be positive; got 0.0"):
        stepped_sine_acceleration([1.0], 0.0)
    with pytest.raises(ParameterError, match="PGA must be positive; got -0.1"):
        command_amplitudes(IdealTable(), [1.0], -0.1, DT)
    with pytest.raises(ParameterError, match="f_start must be positive; got 0.0"):
        frequency_grid(0.0, 1.0, 0.1, 0.05)
    with pytest.raises(ParameterError, match="coarse_step must be positive; got 0.0"):
        frequency_grid(1.0, 2.0, 0.0, 0.05)
    with pytest.raises(ParameterError, match="fine_step must be positive; got -0.05"):
        frequency_grid(1.0, 2.0, 0.1, -0.05)
    with pytest.raises(ParameterError, match="time step dt must be positive; got 0.0"):
        SteppedSine(np.array([1.0])).sample_times(0.0)


def test_loops_need_a_tmdi_model() -> None:
    cfg = parse_sweep(
        TINY.replace('["uncontrolled", "rack_pinion", "ideal"]', '["uncontrolled"]'), "ps.toml"
    )
    result = run_sweep(cfg)
    with pytest.raises(ParameterError, match="force-deformation loops need a TMDI model"):
        loops_figure(result, 0.1)
