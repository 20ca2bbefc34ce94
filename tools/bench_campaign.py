"""Campaign figures, measured: scheduler overhead per task, per-run cost, wall time and speed-up of
the Monte Carlo on 1 and 2 workers, identical tables across worker counts, and what a cluster
would do with a 10,000-run campaign.

Usage::

    python tools/bench_campaign.py [--draws 20] [--workers 1 2] [--tasks 2000] [--batch N]
                                   [--out runs/bench_campaign] [--json OUT.json]

Steps (each timing is printed with the machine's load average, ``os.getloadavg()``, taken just
before it: the machine is shared, and a loaded machine slows every figure):

0. **Background CPU** of an embedded 2-worker cluster with Dask's default settings and with the
   campaigns' quiet ones (:data:`rths.campaign.cluster.QUIET_CONFIG`): both workers spin a
   pure-Python loop for a few seconds; the CPU time of this process (scheduler, nannies, client)
   and of each worker process beyond its spinning thread, per second -- what the cluster's own
   wake-ups take from the runs.
1. **Scheduler overhead per task**: ``--tasks`` no-op tasks through an embedded (quiet)
   LocalCluster of each worker count (processes, one thread each), submitted at once; wall
   time / tasks.
2. **Monte Carlo** ``rths run scenarios/benchmark_mc.toml --monte-carlo N --compensator all``
   as a campaign (:func:`rths.analysis.montecarlo.run_draws`) on each worker count, fresh
   tables: wall time (cluster start-up and shut-down included; each printed too), tasks the
   runs were grouped in (``--batch``: runs per task, default automatic), per-run cost (median
   and mean of the rows' ``wall_s`` and ``cpu_s``), the digest of each table (equal digests:
   bit-identical results), speed-up.
3. **Scale on paper**: a campaign of ``R`` runs on ``W`` workers takes about
   ``startup + max(R c / W, (R / k) o)`` -- ``c`` the per-run cost measured in 2 (the mean CPU
   time of a run on its worker thread, ``cpu_s``: what a run costs on a core nobody else uses;
   the wall time on a shared machine is longer), ``o`` the scheduler's overhead per task
   measured in 1 (the scheduler hands out tasks one at a time, so ``(R / k) o`` bounds a
   campaign however many workers it has), ``k`` the runs per task
   (:func:`rths.campaign.executor.batch_size` for runs of cost ``c``).  Printed for 10,000 runs
   on a 100-node cluster of 2-core nodes like this one (200 workers).
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import statistics
import time
from pathlib import Path
from typing import Any

from controllers.factory import kinds
from rths.analysis.montecarlo import run_draws
from rths.campaign import Cluster, ResultTable
from rths.campaign.cluster import QUIET_CONFIG, client_for
from rths.campaign.executor import batch_size
from rths.config.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]


def _load() -> str:
    one, five, _ = os.getloadavg()
    return f"load {one:.2f} (1 min) {five:.2f} (5 min) on {os.cpu_count()} cores"


def _noop(x: int) -> int:
    return x


def _spin(seconds: float) -> tuple[str, float]:
    """Spin a pure-Python loop for ``seconds`` of wall time: the worker and this thread's CPU
    time [s]."""
    from distributed import get_worker

    start, end = time.thread_time(), time.perf_counter() + seconds
    x = 0
    while time.perf_counter() < end:
        for i in range(1000):
            x += i
    return get_worker().address, time.thread_time() - start


def _process_cpu() -> float:
    return time.process_time()


def background(quiet: bool, seconds: float = 8.0) -> dict[str, Any]:
    """CPU per second of an embedded 2-worker cluster's own wake-ups, both workers spinning."""
    import dask
    from distributed import Client, LocalCluster

    load = _load()
    with (
        dask.config.set(QUIET_CONFIG if quiet else {}),
        LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            dashboard_address=":0",
            silence_logs=logging.CRITICAL,
        ) as cluster,
        Client(cluster) as client,
    ):
        client.submit(_noop, -1).result()
        before, own = client.run(_process_cpu), time.process_time()
        spun = dict(client.gather(client.map(_spin, [seconds, seconds], pure=False)))
        after, own = client.run(_process_cpu), time.process_time() - own
    extra = [(after[w] - before[w] - spun.get(w, 0.0)) / seconds for w in before]
    return {"quiet": quiet, "client_core": own / seconds, "worker_core": extra, "load": load}


def overhead(workers: int, tasks: int) -> dict[str, Any]:
    """Per-task time of ``tasks`` no-op tasks on an embedded cluster of ``workers`` processes."""
    from distributed import wait

    load = _load()
    start = time.perf_counter()
    with client_for(Cluster(workers=workers)) as client:
        startup = time.perf_counter() - start
        client.submit(_noop, -1).result()  # the workers have imported this module
        t0 = time.perf_counter()
        wait(client.map(_noop, range(tasks), pure=False))
        wall = time.perf_counter() - t0
    return {
        "workers": workers,
        "tasks": tasks,
        "startup_s": startup,
        "wall_s": wall,
        "per_task_ms": 1e3 * wall / tasks,
        "load": load,
    }


def monte_carlo(draws: int, workers: int, out: Path, batch: int | None) -> dict[str, Any]:
    """The 20-draw Monte Carlo of every compensator on ``workers`` worker processes."""
    scn = load_scenario(ROOT / "scenarios" / "benchmark_mc.toml")
    path = out / f"mc{draws}_w{workers}.parquet"
    path.unlink(missing_ok=True)
    table = ResultTable(path)
    load = _load()
    start = time.perf_counter()
    result = run_draws(
        scn,
        list(kinds()),
        draws,
        scn.run.seed,
        progress=False,
        cluster=Cluster(workers=workers),
        table=table,
        batch=batch,
    )
    wall = time.perf_counter() - start
    costs = [float(r["wall_s"]) for r in result.rows if isinstance(r.get("wall_s"), float)]
    cpus = [float(r["cpu_s"]) for r in result.rows if isinstance(r.get("cpu_s"), float)]
    keys = [str(r["run"]) for r in result.rows]
    return {
        "workers": workers,
        "runs": len(result.rows),
        "wall_s": wall,
        "startup_s": result.stats.startup,
        "campaign_wall_s": result.stats.wall,
        "shutdown_s": result.stats.shutdown,
        "tasks": result.stats.tasks,
        "per_run_median_s": statistics.median(costs),
        "per_run_mean_s": statistics.fmean(costs),
        "cpu_per_run_median_s": statistics.median(cpus),
        "cpu_per_run_mean_s": statistics.fmean(cpus),
        "overhead_per_run_s": result.stats.overhead_per_run,
        "digest": table.digest(keys),
        "table": str(path),
        "load": load,
    }


def on_paper(runs: int, workers: int, cost: float, per_task: float, startup: float) -> float:
    """Estimated wall time [s] of ``runs`` runs on ``workers`` workers (module docstring)."""
    k = batch_size(cost, runs, workers)
    return startup + max(runs * cost / workers, runs / k * per_task)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n", 1)[0])
    parser.add_argument("--draws", type=int, default=20)
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--tasks", type=int, default=2000, help="no-op tasks for the overhead")
    parser.add_argument("--out", type=Path, default=ROOT / "runs" / "bench_campaign")
    parser.add_argument("--json", type=Path, help="write the figures as JSON")
    parser.add_argument("--skip-mc", action="store_true", help="only the scheduler overhead")
    parser.add_argument("--batch", type=int, help="runs per task (default: automatic)")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    doc: dict[str, Any] = {"background": [], "overhead": [], "monte_carlo": []}
    for quiet in (False, True):
        b = background(quiet)
        doc["background"].append(b)
        print(
            f"background CPU of a 2-worker cluster, {'quiet' if quiet else 'Dask default'} "
            f"settings: {b['client_core']:.3f} core in the client process, "
            + " + ".join(f"{c:.3f}" for c in b["worker_core"])
            + f" in the workers beside their runs [{b['load']}]",
            flush=True,
        )
    for w in args.workers:
        o = overhead(w, args.tasks)
        doc["overhead"].append(o)
        print(
            f"scheduler overhead, {w} worker(s): {o['per_task_ms']:.2f} ms per task "
            f"({o['tasks']} no-op tasks in {o['wall_s']:.2f} s; cluster start "
            f"{o['startup_s']:.1f} s) [{o['load']}]",
            flush=True,
        )
    if not args.skip_mc:
        for w in args.workers:
            m = monte_carlo(args.draws, w, args.out, args.batch)
            doc["monte_carlo"].append(m)
            print(
                f"Monte Carlo {args.draws} draws x {len(kinds())} compensators = {m['runs']} "
                f"runs in {m['tasks']} tasks, {w} worker(s): {m['wall_s']:.1f} s (cluster start "
                f"{m['startup_s']:.1f} s, runs {m['campaign_wall_s']:.1f} s, shut-down "
                f"{m['shutdown_s']:.1f} s); per run {m['per_run_median_s']:.2f} s median, "
                f"{m['per_run_mean_s']:.2f} s "
                f"mean wall, {m['cpu_per_run_mean_s']:.2f} s mean CPU; "
                f"digest {m['digest'][:16]} [{m['load']}]",
                flush=True,
            )
        mc = doc["monte_carlo"]
        if len(mc) >= 2:
            speedup = mc[0]["wall_s"] / mc[-1]["wall_s"]
            same = len({m["digest"] for m in mc}) == 1
            doc["speedup"] = speedup
            doc["identical_tables"] = same
            print(
                f"speed-up {mc[0]['workers']} -> {mc[-1]['workers']} workers: {speedup:.2f}x; "
                f"tables {'identical' if same else 'DIFFER'} across worker counts"
            )
        cost = mc[0]["cpu_per_run_mean_s"]  # CPU time: what a run costs on an idle core
        per_task = max(o["per_task_ms"] for o in doc["overhead"]) / 1e3
        startup = max(o["startup_s"] for o in doc["overhead"])
        runs, workers = 10_000, 200
        t = on_paper(runs, workers, cost, per_task, startup)
        k = batch_size(cost, runs, workers)
        doc["on_paper"] = {
            "runs": runs,
            "workers": workers,
            "per_run_s": cost,
            "per_task_s": per_task,
            "runs_per_task": k,
            "estimate_s": t,
            "serial_s": runs * cost,
        }
        print(
            f"on paper: {runs} runs x {cost:.2f} s on {workers} workers (100 nodes x 2 cores): "
            f"{t / 60:.1f} min (compute {runs * cost / workers / 60:.1f} min, scheduler "
            f"{runs / k * per_task:.0f} s for {runs // k} tasks of {k} runs); serially "
            f"{runs * cost / 3600:.1f} h"
        )
    if args.json:
        args.json.write_text(json.dumps(doc, indent=2))


if __name__ == "__main__":
    main()
