"""The campaign layer: Dask execution, determinism across worker counts, resume, failures as rows.

Oracles: a run's row does not depend on where it ran -- the same campaign on LocalCluster(1
process), LocalCluster(2 processes), threads of this process and an external scheduler gives
tables with the same digest, and each J2 equals the run executed directly in this process
(:func:`rths.analysis.montecarlo.run_one`, no Dask); a resumed campaign equals one run straight
through.  Campaigns are tiny (0.25 s records) so the suite stays quick.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path

import pytest

from rths.analysis.montecarlo import campaign as mc_campaign
from rths.analysis.montecarlo import run_one
from rths.campaign import Campaign, Cluster, ResultTable, Run, digest, execute
from rths.campaign.runs import run_key
from rths.cli import main
from rths.config.scenario import load_scenario, parse_scenario
from rths.core.errors import ConfigError, DataError, ParameterError

SCENARIOS = Path(__file__).resolve().parent.parent / "scenarios"
MC = SCENARIOS / "benchmark_mc.toml"
THREADS = Cluster(workers=2, processes=False)


def _mc(duration: float = 0.25):
    text = MC.read_text().replace("duration = 10.0", f"duration = {duration}")
    return parse_scenario(text, str(MC))


def _small_campaign(draws: int = 2, kinds=("ff", "ff_lqg")):
    return mc_campaign(_mc(), list(kinds), draws, seed=7)


# ------------------------------------------------------------------------------ determinism
def test_same_table_on_one_and_two_worker_processes_and_without_dask():
    """The issue's determinism test: LocalCluster(n_workers=1) vs 2, bit-identical rows."""
    c = _small_campaign()
    tables = []
    for n in (1, 2):
        t = ResultTable(None)
        stats = execute(c, t, Cluster(workers=n), progress=False)
        assert stats.ran == len(c) == 4 and stats.failed == 0 and stats.workers == n
        tables.append(t)
    assert tables[0].digest() == tables[1].digest()
    # and equal to the runs done one by one in this process, bit for bit
    scn = _mc()
    for row in tables[1].rows():
        j2, stopped = run_one(scn, str(row["compensator"]), int(row["draw"]), 7)
        assert stopped is None and row["j2"] == j2
    # worker processes: the two-worker table really used both
    assert {r["worker"] for r in tables[1].rows()} == {"0", "1"}


def test_an_external_scheduler_runs_the_same_campaign(tmp_path):
    """--scheduler tcp://HOST:PORT: the client reaches a cluster it did not start."""
    from distributed import LocalCluster

    c = _small_campaign()
    local = ResultTable(None)
    execute(c, local, THREADS, progress=False)
    with LocalCluster(
        n_workers=1,
        threads_per_worker=1,
        processes=False,
        scheduler_port=0,
        dashboard_address=":0",
        silence_logs=logging.ERROR,
        protocol="tcp",
    ) as cluster:
        assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
        remote = ResultTable(tmp_path / "remote.parquet")
        stats = execute(c, remote, Cluster(scheduler=cluster.scheduler_address), progress=False)
    assert stats.ran == 4 and remote.digest() == local.digest()


def test_an_unreachable_scheduler_is_a_one_line_error(capsys):
    # port 9 (discard) on loopback: nothing listens there
    with pytest.raises(ConfigError, match="cannot reach the Dask scheduler at tcp://127.0.0.1:9"):
        execute(
            _small_campaign(1, ("ff",)),
            ResultTable(None),
            Cluster(scheduler="tcp://127.0.0.1:9", connect_timeout=1.0),
            progress=False,
        )
    with pytest.raises(ConfigError, match="tcp://HOST:8786"):
        Cluster(scheduler="127.0.0.1:8786")
    assert main(["run", str(MC), "--monte-carlo", "1", "--scheduler", "localhost"]) == 2
    assert "scheduler address must look like tcp://HOST:8786" in capsys.readouterr().err


# ------------------------------------------------------------------------------ the table
@pytest.mark.parametrize("suffix", [".parquet", ".csv"])
def test_resume_skips_rows_in_the_table_and_equals_a_straight_run(tmp_path, suffix):
    full = _small_campaign(draws=3)
    straight = ResultTable(None)
    execute(full, straight, THREADS, progress=False)

    path = tmp_path / f"mc{suffix}"
    first = Campaign(full.name, full.runs[:2], full.task)  # "interrupted" after two runs
    execute(first, ResultTable(path), THREADS, progress=False)
    resumed = ResultTable(path)  # read back from the file
    assert len(resumed) == 2
    stats = execute(full, resumed, THREADS, progress=False)
    assert (stats.skipped, stats.ran) == (2, 4)
    reread = ResultTable(path)
    assert [r["run"] for r in reread.rows()] == [r.key for r in full.runs]  # in campaign order
    assert reread.digest() == resumed.digest() == straight.digest()  # every bit survives the file


def test_a_campaign_resumed_with_more_runs_is_ordered_and_hashed_as_one_run_straight(tmp_path):
    """Adding a compensator later: the kept rows take their place in the larger campaign."""
    full = _small_campaign(draws=2)  # draw-major: ff, ff_lqg, ff, ff_lqg
    straight = ResultTable(None)
    execute(full, straight, THREADS, progress=False)
    path = tmp_path / "mc.parquet"
    execute(_small_campaign(draws=2, kinds=("ff_lqg",)), ResultTable(path), THREADS, progress=False)
    assert [r["index"] for r in ResultTable(path).rows()] == [0, 1]
    stats = execute(full, ResultTable(path), THREADS, progress=False)
    assert (stats.skipped, stats.ran) == (2, 2)
    reread = ResultTable(path)
    assert [r["index"] for r in reread.rows()] == [0, 1, 2, 3]
    assert [r["run"] for r in reread.rows()] == [r.key for r in full.runs]
    assert reread.digest() == straight.digest()


def test_an_interrupted_campaign_keeps_the_rows_it_finished(tmp_path):
    path = tmp_path / "mc.parquet"
    c = _small_campaign(draws=2)
    seen = []

    def stop_after_two(row):
        seen.append(row)
        if len(seen) == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        execute(
            c,
            ResultTable(path, flush_interval=60.0),
            THREADS,
            progress=False,
            on_row=stop_after_two,
        )
    assert ResultTable(path).keys() == {r["run"] for r in seen}
    stats = execute(c, ResultTable(path), THREADS, progress=False)
    assert (stats.skipped, stats.ran) == (2, 2)


def _fragile(x: float) -> dict:
    """A task that fails for negative inputs (a top-level function, as workers need)."""
    if x < 0:
        raise ValueError(f"negative input {x!r}")
    return {"root": math.sqrt(x)}


def test_a_failed_run_is_a_row_and_can_be_retried(tmp_path):
    runs = [Run(run_key("x", x), {"x": x}, x) for x in (4.0, -1.0, 9.0)]
    c = Campaign("fragile", runs, _fragile)
    table = ResultTable(tmp_path / "f.csv")
    stats = execute(c, table, THREADS, progress=False)
    assert (stats.ran, stats.failed) == (3, 1)
    rows = {r["x"]: r for r in table.rows()}
    assert rows[4.0]["root"] == 2.0 and rows[9.0]["root"] == 3.0
    assert rows[-1.0]["status"] == "error" and rows[-1.0]["root"] is None
    assert rows[-1.0]["error"] == "ValueError: negative input -1.0"
    # an ordinary re-run skips it; --retry-failed runs it again
    assert execute(c, table, THREADS, progress=False).ran == 0
    again = execute(c, table, THREADS, progress=False, retry_failed=True)
    assert (again.ran, again.failed) == (1, 1)


def test_an_interlock_is_a_result_not_an_error():
    """ATS trips the stroke interlock on the benchmark lab (tests/test_montecarlo.py)."""
    t = ResultTable(None)
    execute(mc_campaign(_mc(0.5), ["ats"], 1, seed=7), t, THREADS, progress=False)
    (row,) = t.rows()
    assert row["status"] == "interlock" and "outside the stroke" in row["stopped"]
    assert row["j2"] is None and row["error"] is None


def test_table_and_campaign_inputs_are_checked(tmp_path):
    with pytest.raises(DataError, match=r"must end in \.parquet or \.csv; got '\.xlsx'"):
        ResultTable(tmp_path / "t.xlsx")
    bad = tmp_path / "bad.parquet"
    bad.write_text("not parquet")
    with pytest.raises(DataError, match="cannot read the campaign table"):
        ResultTable(bad)
    run = Run("k", {"x": 1.0}, 1.0)
    with pytest.raises(ParameterError, match="runs 0 and 1 have the same key 'k'"):
        Campaign("dup", [run, run], _fragile)
    with pytest.raises(ParameterError, match="top-level function"):
        Campaign("lam", [run], lambda p: {})
    with pytest.raises(ParameterError, match="input 'x' of run 0 must be a number"):
        Campaign("obj", [Run("k", {"x": [1, 2]}, None)], _fragile)  # type: ignore[dict-item]


def test_digest_ignores_timing_and_sees_one_bit():
    row = {"run": "a", "index": 0, "j2": 0.1, "wall_s": 1.0, "worker": "0"}
    same = {**row, "wall_s": 2.0, "worker": "1"}
    assert digest([row]) == digest([same])
    assert digest([row]) != digest([{**row, "j2": math.nextafter(0.1, 1.0)}])
    assert digest([{**row, "x": 1}]) == digest([{**row, "x": 1.0}])  # Parquet widens int to float


# ------------------------------------------------------------------------------ overrides
def test_scenario_overrides_are_validated_like_the_file():
    scn = load_scenario(SCENARIOS / "cable_imd_mode3.toml", {"specimen.inertance": 1200.0})
    assert scn.specimen.options.inertance == 1200.0
    assert scn.overrides == (("specimen.inertance", 1200.0),)
    # a run of it carries the overrides to the worker (the text alone would lose them)
    from rths.campaign.scenario import scenario_run

    payload = scenario_run(scn, overrides={"run.seed": 3}).payload
    again = payload.scenario()
    assert again.specimen.options.inertance == 1200.0 and again.run.seed == 3
    with pytest.raises(ConfigError, match=r"\[specimen\] inertanse: unknown key"):
        load_scenario(SCENARIOS / "cable_imd_mode3.toml", {"specimen.inertanse": 1.0})
    with pytest.raises(ConfigError, match=r"\[specimen\] inertance: must be a number"):
        load_scenario(SCENARIOS / "cable_imd_mode3.toml", {"specimen.inertance": "big"})
    with pytest.raises(ConfigError, match="'run.seed' is a value, not a table"):
        load_scenario(SCENARIOS / "cable_imd_mode3.toml", {"run.seed.x": 1})
