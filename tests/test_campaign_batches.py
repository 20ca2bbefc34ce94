"""Short runs share a task (one row each), and the embedded cluster is a quiet one.

Oracles: a campaign's table does not depend on how its runs were grouped into tasks nor on the
worker count -- the same digest with one run per task on one worker process, four per task on
two, and the runs done one by one without Dask (:func:`rths.analysis.montecarlo.run_one`); a
resumed batched campaign equals one run straight through; a run that raises, or a worker that
dies, fails only its own row.  :func:`batch_size` is checked against its definition.
"""

from __future__ import annotations

import os
from pathlib import Path

import dask
import pytest

from rths.analysis.montecarlo import campaign as mc_campaign
from rths.analysis.montecarlo import run_one
from rths.campaign import Campaign, Cluster, ResultTable, Run, execute
from rths.campaign.cluster import QUIET_CONFIG, client_for
from rths.campaign.executor import MAX_BATCH, TASK_TARGET, batch_size
from rths.campaign.runs import run_key
from rths.config.scenario import parse_scenario
from rths.core.errors import ParameterError

MC = Path(__file__).resolve().parent.parent / "scenarios" / "benchmark_mc.toml"
THREADS = Cluster(workers=2, processes=False)


def _campaign(draws: int = 2, kinds=("ff", "ff_lqg", "lqg")):
    text = MC.read_text().replace("duration = 10.0", "duration = 0.1")
    return mc_campaign(parse_scenario(text, str(MC)), list(kinds), draws, seed=11)


def _fragile(x: float) -> dict:
    """A task that fails for a negative input and kills its worker process for NaN."""
    if x != x:
        os._exit(3)  # a worker dying mid-task (as if killed for memory)
    if x < 0:
        raise ValueError(f"negative input {x!r}")
    return {"twice": 2.0 * x}


def test_batch_size_fills_the_target_and_ends_on_single_runs():
    assert batch_size(None, 100, 2) == 1  # nothing measured yet: one run
    assert batch_size(0.5, 100, 2) == int(TASK_TARGET / 0.5)  # 4 runs of 0.5 s
    assert batch_size(0.001, 10_000, 2) == MAX_BATCH
    assert batch_size(5.0, 100, 2) == 1  # long runs: one per task
    assert batch_size(0.5, 9, 2) == 2 and batch_size(0.5, 3, 2) == 1  # the tail: 9 // 4, then 1
    # a campaign drained with it: every run once, the last 2 x workers tasks single runs
    sizes, left = [], 140
    while left:
        sizes.append(min(batch_size(0.55, left, 2), left))
        left -= sizes[-1]
    assert sum(sizes) == 140 and sizes[0] == 3 and sizes[-4:] == [1, 1, 1, 1]


def test_grouping_and_worker_count_leave_the_table_unchanged():
    """One run per task on 1 worker process vs four per task on 2: bit-identical rows."""
    c = _campaign()
    single, grouped = ResultTable(None), ResultTable(None)
    s1 = execute(c, single, Cluster(workers=1), progress=False, batch=1)
    s2 = execute(c, grouped, Cluster(workers=2), progress=False, batch=4)
    assert (s1.ran, s1.tasks, s1.failed) == (6, 6, 0)
    assert s2.ran == 6 and s2.tasks < 6 and s2.failed == 0 and s2.shutdown >= 0.0
    assert single.digest() == grouped.digest()
    assert [r["run"] for r in grouped.rows()] == [r.key for r in c.runs]  # one row per run
    text = MC.read_text().replace("duration = 10.0", "duration = 0.1")
    scn = parse_scenario(text, str(MC))
    for row in grouped.rows():
        j2, stopped = run_one(scn, str(row["compensator"]), int(row["draw"]), 11)
        assert stopped is None and row["j2"] == j2


def test_a_batched_campaign_resumes_where_it_stopped(tmp_path):
    full = _campaign(draws=3)
    straight = ResultTable(None)
    execute(full, straight, THREADS, progress=False, batch=1)
    path = tmp_path / "mc.parquet"
    seen = []

    def stop_after_four(row):
        seen.append(row)
        if len(seen) == 4:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        execute(full, ResultTable(path, 60.0), THREADS, progress=False, on_row=stop_after_four)
    assert ResultTable(path).keys() == {r["run"] for r in seen}  # what finished is kept
    stats = execute(full, ResultTable(path), THREADS, progress=False, batch=3)
    assert (stats.skipped, stats.ran) == (4, 5)
    assert ResultTable(path).digest() == straight.digest()


def test_a_failing_run_in_a_batch_fails_alone(tmp_path):
    runs = [Run(run_key("x", x), {"x": x}, x) for x in (1.0, -1.0, 3.0, 4.0)]
    table = ResultTable(tmp_path / "f.csv")
    stats = execute(Campaign("fragile", runs, _fragile), table, THREADS, progress=False, batch=4)
    assert (stats.ran, stats.failed, stats.tasks) == (4, 1, 1)
    rows = {r["x"]: r for r in table.rows()}
    assert [rows[x]["twice"] for x in (1.0, 3.0, 4.0)] == [2.0, 6.0, 8.0]
    assert (
        rows[-1.0]["status"] == "error" and rows[-1.0]["error"] == "ValueError: negative input -1.0"
    )
    with pytest.raises(ParameterError, match="runs per task"):
        execute(Campaign("fragile", runs, _fragile), ResultTable(None), THREADS, batch=0)


def test_a_worker_dying_in_a_batch_fails_only_the_run_that_killed_it():
    """The batch is run again one run per task: the others' rows are results.  (The dying run is
    the last, so no other task waits on its worker when it dies: with ``allowed-failures = 0``
    the scheduler would give up on that one too.)"""
    runs = [Run(run_key("x", x), {"x": x}, x) for x in (1.0, 3.0, float("nan"))]
    table = ResultTable(None)
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        stats = execute(
            Campaign("dying", runs, _fragile), table, Cluster(workers=1), progress=False, batch=3
        )
    assert (stats.ran, stats.failed) == (3, 1)
    by_x = {r["run"]: r for r in table.rows()}
    dead = by_x[runs[2].key]
    assert dead["status"] == "error" and "KilledWorker" in str(dead["error"])
    assert [by_x[runs[i].key]["twice"] for i in (0, 1)] == [2.0, 6.0]


def test_the_embedded_cluster_is_quiet_in_its_worker_processes():
    """The settings reach the spawned workers (what removes their background wake-ups)."""

    def settings():
        import dask

        return {k: dask.config.get(k) for k in QUIET_CONFIG}

    with client_for(Cluster(workers=1)) as client:
        (seen,) = client.run(settings).values()
    assert seen == QUIET_CONFIG
