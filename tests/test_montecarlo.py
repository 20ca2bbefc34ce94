"""Monte-Carlo RTHS: perturbed benchmark labs, paired across compensators, reproducible by seed."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from rths.analysis.montecarlo import run_draws, run_one
from rths.campaign import Cluster
from rths.cli import main
from rths.config.scenario import parse_scenario

SCENARIO = Path(__file__).resolve().parent.parent / "scenarios" / "benchmark_mc.toml"


#: threads of this process: quick to start (the process-based cluster is tested in test_campaign)
LOCAL = Cluster(workers=1, processes=False)


def _short(duration: float = 1.0):
    return parse_scenario(
        SCENARIO.read_text().replace("duration = 10.0", f"duration = {duration}"), str(SCENARIO)
    )


def test_draws_are_reproducible_and_differ_from_each_other():
    scn = _short(0.5)
    a = run_draws(scn, ["ff"], draws=2, seed=5, progress=False, cluster=LOCAL)
    b = run_draws(scn, ["ff"], draws=2, seed=5, progress=False, cluster=LOCAL)
    np.testing.assert_array_equal(a.j2["ff"], b.j2["ff"])  # same seed -> same perturbed labs
    assert a.j2["ff"][0] != a.j2["ff"][1]  # draws perturb the plant
    # the campaign's rows are the draws run one by one in this process, bit for bit
    assert [run_one(scn, "ff", i, 5)[0] for i in range(2)] == a.j2["ff"].tolist()


def test_feedback_improves_on_feedforward_across_draws():
    """The LQG corrects what the feedforward misses on a perturbed plant (Phillips & Spencer):
    per draw, FF+LQG tracks better than FF alone, and both far better than no compensation."""
    result = run_draws(
        _short(1.0), ["none", "ff", "ff_lqg"], draws=3, seed=11, progress=False, cluster=LOCAL
    )
    j2 = result.j2
    assert np.all(j2["ff_lqg"] < j2["ff"]) and np.all(j2["ff"] < 0.2 * j2["none"])


def test_cli_uses_the_scenario_draws_and_prints_json(tmp_path, capsys):
    scn = tmp_path / "mc.toml"
    scn.write_text(
        SCENARIO.read_text()
        .replace("duration = 10.0", "duration = 0.25")
        .replace("draws = 20", "draws = 2")
    )
    table = tmp_path / "mc.csv"
    argv = ["run", str(scn), "--monte-carlo", "--compensator", "ff", "--no-progress"]
    argv += ["--in-process", "--table", str(table)]
    assert main([*argv, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["draws"] == 2 and doc["rows"][0]["kind"] == "ff" and len(doc["j2"]["ff"]) == 2
    assert table.exists() and (tmp_path / "mc_j2.png").exists()
    # again: every run is in the table already, nothing runs, same table
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "2 runs (2 already in the table)" in out and doc["digest"][:16] in out


def test_cli_refuses_an_unknown_compensator_before_running(tmp_path, capsys):
    assert main(["run", str(SCENARIO), "--monte-carlo", "2", "--compensator", "pid"]) == 2
    err = capsys.readouterr().err
    assert "--compensator must be one of" in err and "'pid'" in err


def test_zero_draws_is_refused(tmp_path, capsys):
    scn = tmp_path / "mc.toml"
    scn.write_text(SCENARIO.read_text().replace("draws = 20", "draws = 0"))
    assert main(["run", str(scn), "--monte-carlo", "--no-progress"]) == 2
    assert "number of draws >= 1" in capsys.readouterr().err


@pytest.mark.parametrize("kind", ["polynomial"])
def test_an_interlocked_draw_is_reported_not_hidden(kind):
    result = run_draws(_short(0.5), [kind], draws=1, seed=1, progress=False, cluster=LOCAL)
    row = result.table()[0]
    assert (row["stopped"] == 1) == bool(np.isnan(result.j2[kind][0]))
