"""The vrths_case scenario files through `rths run` (fast and lockstep) and `rths report`:
F4's J1-J9 in the summary, the JSON and the report (chirp: no benchmark package needed)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from rths.cli import main
from rths.config.scenario import load_scenario, parse_scenario
from rths.log.reader import read_topic
from rths.session.runner import RunOptions, run_scenario

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"
CRITERIA = [f"J{i}" for i in range(1, 10)]


def _chirp(case: int, duration: float = 1.5) -> str:
    """The shipped scenario with the chirp (0.1-40 Hz compressed to 3 s) and a short run."""
    text = (SCENARIOS / f"vrths_case{case}.toml").read_text()
    text = text.replace(
        'ground_motion = "el_centro"', 'ground_motion = "chirp"\nchirp_duration = 3.0'
    )
    return text.replace("duration = 41.18", f"duration = {duration}")


@pytest.mark.parametrize("case", [1, 2, 3, 4])
def test_shipped_scenarios_parse(case: int) -> None:
    scn = load_scenario(SCENARIOS / f"vrths_case{case}.toml")
    assert scn.substructure.kind == "vrths_frame" and scn.substructure.options.case == case
    assert scn.compensator.kind == "pi_lead" and scn.run.rate == 4096.0
    assert scn.run.steps == 168673  # El Centro's tend = 41.18 s at 4096 Hz


@pytest.fixture(scope="module")
def fast_run(tmp_path_factory):
    path = tmp_path_factory.mktemp("vrths") / "run.mcap"
    scn = path.with_suffix(".toml")
    scn.write_text(_chirp(2))
    return scn, path


def test_run_json_prints_f4_criteria(fast_run, capsys) -> None:
    scn, path = fast_run
    assert main(["run", str(scn), "--out", str(path), "--no-progress", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert all(isinstance(doc[k], float) for k in CRITERIA)
    # the project's own metrics stay beside them under their own names (RMS, fractions, s)
    assert {"j1_delay", "j2", "j3", "sync_rmse"} <= set(doc["metrics"])
    assert doc["J1"] == pytest.approx(4.6, abs=0.25)  # the sample controller's ~19 samples
    assert doc["J2"] > 5.0


def test_report_scores_the_log_like_the_run(fast_run, tmp_path, capsys) -> None:
    scn, path = fast_run
    if not path.exists():
        main(["run", str(scn), "--out", str(path), "--no-progress"])
    capsys.readouterr()
    out = tmp_path / "rep"
    assert main(["report", str(path), "--out", str(out)]) == 0
    assert "vRTHS benchmark (F4): J1" in capsys.readouterr().out
    doc = json.loads((out / "metrics.json").read_text())
    summary = doc["summary"]
    for k in CRITERIA:
        assert doc["benchmark"][k] == pytest.approx(float(summary[k]), abs=1e-12), k
    assert 0 < doc["benchmark"]["peak_actuator_force"] < 8900
    assert (out / "benchmark_floors.png").stat().st_size > 1000


def test_lockstep_reproduces_the_fast_clock(tmp_path) -> None:
    scn = parse_scenario(_chirp(4, duration=0.5), "<vrths lockstep>")
    fast = run_scenario(scn, RunOptions(clock="fast", out=tmp_path / "f.mcap"))
    lock = run_scenario(scn, RunOptions(clock="lockstep", out=tmp_path / "l.mcap"))
    assert fast.benchmark == lock.benchmark and fast.benchmark is not None
    a, b = (
        read_topic(tmp_path / "f.mcap", "rths/loop"),
        read_topic(tmp_path / "l.mcap", "rths/loop"),
    )
    np.testing.assert_array_equal(a["measured"], b["measured"])
    np.testing.assert_array_equal(a["sub_x3"], b["sub_x3"])
