"""``rths compare`` as a campaign: one run per case x plant draw x compensator.

Oracles: the campaign's rows are the trials run one by one in this process, bit for bit (every
field but the wall time), on two worker processes as on one thread; the table's digest is the
same on both; a resumed comparison equals one run straight through; the command resumes from
its table.  Records: the benchmark's chirp (1 s, no package needed).
"""

from __future__ import annotations

import functools
import math

import pytest

from rths.campaign import Cluster, ResultTable
from rths.campaign.executor import one_blas_thread
from rths.cli import main
from rths.experiments.vrths import compare
from rths.experiments.vrths.compare import (
    comparison_campaign,
    run_comparison,
    run_one,
    trial_specs,
)

CHIRP = {"f_start": 0.5, "f_end": 6.0, "duration": 1.0}
THREADS = Cluster(workers=1, processes=False)
KINDS, CASES = ["pi_lead", "ff_lqg"], [1, 3]


def _same(a: float, b: float) -> bool:
    return a == b or (math.isnan(a) and math.isnan(b))


def _fields(r: compare.TrialResult) -> tuple:
    scores = None if r.scores is None else sorted(r.scores.items())
    return (r.kind, r.case, r.plant, scores, r.stopped)


def test_rows_are_the_in_process_trials_on_one_thread_and_two_processes(tmp_path):
    kw = {"ground": "chirp", "perturbed": 1, "chirp": CHIRP}
    threads, procs = ResultTable(tmp_path / "threads.csv"), ResultTable(tmp_path / "procs.parquet")
    a = run_comparison(KINDS, CASES, cluster=THREADS, table=threads, **kw)
    b = run_comparison(KINDS, CASES, cluster=Cluster(workers=2), table=procs, **kw)
    assert b.stats is not None and b.stats.workers == 2 and b.stats.failed == 0
    assert len(a.results) == len(b.results) == 2 * 2 * 2
    assert threads.digest(a.keys) == procs.digest(b.keys) and a.keys == b.keys
    assert len({procs.rows([k])[0]["worker"] for k in b.keys}) == 2  # both workers ran trials
    one_blas_thread()  # as every campaign run (threadpoolctl), so the reference has its bits
    for job, ra, rb in zip(trial_specs(KINDS, CASES, **kw), a.results, b.results, strict=True):
        ref = run_one(job)
        assert _fields(ref) == _fields(ra) == _fields(rb)
        for name in ("j2_noise_free", "noise_floor", "peak_force"):
            assert _same(getattr(ref, name), getattr(ra, name))
            assert _same(getattr(ref, name), getattr(rb, name))
    # the chirp drives every trial: scored, none interlocked
    assert all(r.stopped is None and r.scores for r in b.results)


def test_a_resumed_comparison_equals_one_run_straight(tmp_path):
    kw = {"ground": "chirp", "perturbed": 1, "chirp": CHIRP, "cluster": THREADS}
    table = ResultTable(tmp_path / "c.parquet")
    run_comparison(["pi_lead"], CASES, table=table, **kw)
    resumed = run_comparison(KINDS, CASES, table=ResultTable(tmp_path / "c.parquet"), **kw)
    assert resumed.stats is not None and resumed.stats.skipped == 4 and resumed.stats.ran == 4
    straight_table = ResultTable(None)
    straight = run_comparison(KINDS, CASES, table=straight_table, **kw)
    assert straight.keys == resumed.keys
    assert straight_table.digest(straight.keys) == ResultTable(tmp_path / "c.parquet").digest(
        resumed.keys
    )


def test_runs_are_keyed_by_what_determines_them():
    jobs = trial_specs(KINDS, CASES, ground="chirp", perturbed=2, chirp=CHIRP)
    campaign = comparison_campaign(jobs)
    assert len(campaign) == 2 * 2 * 3
    other_seed = comparison_campaign(
        trial_specs(KINDS, CASES, ground="chirp", perturbed=2, chirp=CHIRP, seed=124)
    )
    # the nominal plant is the same under any seed, but its sensor noise is seeded: new keys
    assert not {r.key for r in campaign.runs} & {r.key for r in other_seed.runs}
    row = campaign.runs[0].inputs
    assert row["compensator"] == "pi_lead" and row["plant"] == 0 and row["chirp.duration"] == 1.0


@pytest.mark.parametrize("suffix", [".csv"])
def test_the_command_runs_a_campaign_and_resumes(tmp_path, capsys, monkeypatch, suffix):
    monkeypatch.setattr(
        compare, "run_comparison", functools.partial(compare.run_comparison, chirp=CHIRP)
    )
    table = tmp_path / f"compare{suffix}"
    argv = ["compare", "--ground", "chirp", "--perturbed", "0", "--cases", "2"]
    argv += ["--compensators", *KINDS, "--in-process", "--table", str(table), "--no-progress"]
    argv += ["--figure", str(tmp_path / "j2.png")]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "ran 2 on" in out and "local worker threads" in out and table.exists()
    digest = out.rsplit("digest ", 1)[1].strip()
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "2 runs (2 already in the table)" in out and out.rstrip().endswith(digest)
    assert "2 trials (2 from the table); capacity" in out
    assert "Case 2" in out and (tmp_path / "j2.png").exists()


def test_bad_workers_is_one_line(capsys):
    assert main(["compare", "--ground", "chirp", "--workers", "0"]) == 2
    assert "--workers must be >= 1" in capsys.readouterr().err
