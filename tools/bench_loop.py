"""The real-time figure table of issue 11 in one command: every clock and rate, repeated, median
and worst, with the machine's load.

For each scenario (default: the seed scenario) and rate:

* ``fast``      simulated seconds per wall second: of the whole run (build, loop, recording) and
                of the loop alone (``dt`` over the mean wall time per step);
* ``lockstep``  the same (the whole run includes starting the specimen process: seconds of
                imports), the mean round trip, and the sync-subspace RMSE every other clock is
                compared with;
* ``realtime``  synchronous real time over zenoh (coordinator and specimen process on this
                machine): overruns and deadline misses [% of steps], p50/p99/max start jitter,
                work per step outside the round trip, mean round trip, p99 measurement age,
                sync RMSE and its difference to lockstep [percentage points], whether the run
                ended early (interlock) -- ``finished k/n``;

and, for every clock, CPU time per step (independent of how loaded the machine is): the loop
thread's, the coordinator process's (loop, recorder, zenoh threads; build and summary included)
and the specimen process's (whole life, start-up included); then the per-step cost of each
component (substructure, compensator, emulated lab, and their row writes), measured in process
as the loop thread's CPU time (``time.thread_time_ns``, the clock's own cost subtracted).
Every figure is the median over ``--repeats`` runs with the worst beside it.  CPU time is
inflated somewhat on a loaded machine too (caches, shared cores), far less than wall time.
Real-time figures depend on the machine: run it on a quiet one; the 1-minute load average
before and after is printed with the table.

    python tools/bench_loop.py                                  # the whole table (long)
    python tools/bench_loop.py --rates 2048 --clocks realtime --repeats 10 --duration 60
    python tools/bench_loop.py --rates 2048 4096 --duration 10 --repeats 1   # a quick look
    python tools/bench_loop.py --scenario scenarios/other.toml --rates 4096
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from rths.config import build
from rths.config.scenario import parse_scenario
from rths.core.channels import RowBlock
from rths.log.reader import read_metadata
from rths.session.runner import RunOptions, run_scenario

SEED = Path(__file__).resolve().parent.parent / "scenarios" / "cable_imd_mode3.toml"


def scenario(path: Path, rate: float, duration: float):
    text = path.read_text()
    text = re.sub(r"^rate = .*$", f"rate = {rate}", text, count=1, flags=re.M)
    text = re.sub(r"^duration = .*$", f"duration = {duration}", text, count=1, flags=re.M)
    return parse_scenario(text, str(path))


def run(path: Path, clock: str, rate: float, duration: float, out: Path) -> dict:
    scn = scenario(path, rate, duration)
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    start, cpu = time.perf_counter(), time.process_time()
    outcome = run_scenario(scn, RunOptions(clock=clock, out=out))
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    child = after.ru_utime + after.ru_stime - children.ru_utime - children.ru_stime
    summary = read_metadata(out)["rths.summary"]
    r, t = outcome.result, outcome.result.timing
    steps = max(r.steps, 1)
    return {
        "speed": r.steps * scn.run.dt / wall,
        "loop_speed": scn.run.dt / t.busy_mean if t.busy_mean > 0 else float("nan"),
        "loop_cpu_us": 1e6 * getattr(r, "cpu_mean", float("nan")),  # (older LoopResult: none)
        "process_cpu_us": 1e6 * cpu / steps,
        "specimen_cpu_us": 1e6 * child / steps if clock != "fast" else float("nan"),
        "overruns_pct": 100 * t.overruns / steps,
        "misses_pct": 100 * r.misses / steps,
        "jitter_p50_us": 1e6 * t.jitter_p50,
        "jitter_p99_us": 1e6 * t.jitter_p99,
        "jitter_max_us": 1e6 * t.jitter_max,
        "work_us": 1e6 * r.work_mean,
        "round_trip_us": 1e6 * r.link_mean,
        "age_p99_us": 1e6 * outcome.age_p99,
        "sync_pct": 100 * float(summary.get("sync_rmse", "nan")),
        "gc_in_loop": outcome.gc[0],
        "finished": r.stopped is None,
        "stopped": r.stopped or "",
    }


def component_costs(path: Path, rate: float, steps: int = 4000) -> dict[str, float]:
    """Mean CPU time per step [µs] of each component's step and row write, in process (the
    loop thread's CPU clock, its own cost per reading subtracted)."""
    scn = scenario(path, rate, 1.0)
    sub, comp, lab = build.substructure(scn), build.compensator(scn), build.lab(scn)
    sub.predict(0.0)
    rows = [RowBlock(x.channels(), 1).values[0] for x in (comp, sub, lab)]
    names = ("substructure", "compensator", "lab", "rows")
    total = dict.fromkeys(names, 0)
    clock = time.thread_time_ns
    t0 = clock()
    for _ in range(1000):
        clock()
    reading = (clock() - t0) / 1001  # one reading of the clock [ns]
    fed, measured = 0.0, 0.0
    lam_u, lam_f = scn.scaling.displacement, scn.scaling.force
    for k in range(steps):
        t0 = clock()
        target = sub.step(fed).scaled(lam_u)
        t1 = clock()
        command = comp.step(target, measured)
        t2 = clock()
        measured, force = lab.step(command)
        t3 = clock()
        comp.write_channels(rows[0])
        sub.write_channels(rows[1])
        lab.write_channels(rows[2])
        t4 = clock()
        fed = lam_f * force - sub.device_force
        if k >= 200:  # after warm-up
            for name, dt_ns in zip(names, (t1 - t0, t2 - t1, t3 - t2, t4 - t3)):
                total[name] += dt_ns
    return {name: (v / (steps - 200) - reading) / 1e3 for name, v in total.items()}


def fmt(values: list[float], worst: str, digits: int = 1) -> str:
    finite = [v for v in values if np.isfinite(v)]
    if not finite:
        return "–"
    med = statistics.median(finite)
    bad = max(finite) if worst == "max" else min(finite)
    if len(values) == 1:
        return f"{med:.{digits}f}"
    return f"{med:.{digits}f} ({bad:.{digits}f})"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", type=Path, nargs="+", default=[SEED])
    ap.add_argument("--rates", type=float, nargs="+", default=[1024.0, 2048.0, 4096.0])
    ap.add_argument("--clocks", nargs="+", default=["fast", "lockstep", "realtime"])
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--no-components", action="store_true")
    args = ap.parse_args()
    load_before = os.getloadavg()
    rows: list[tuple[str, str, float, list[dict]]] = []
    with tempfile.TemporaryDirectory() as tmp:
        for path in args.scenario:
            for rate in args.rates:
                for clock in args.clocks:
                    runs = []
                    for i in range(args.repeats):
                        out = Path(tmp) / f"{clock}-{rate:g}-{i}.mcap"
                        runs.append(run(path, clock, rate, args.duration, out))
                        print(f"{path.name} {clock} {rate:g} #{i}: {runs[-1]}", file=sys.stderr)
                        out.unlink()
                    rows.append((path.name, clock, rate, runs))
    load_after = os.getloadavg()
    print(
        f"\n{args.duration:g} s runs, {args.repeats} repeats, median (worst); load average "
        f"(1/5/15 min) before {load_before[0]:.2f}/{load_before[1]:.2f}/{load_before[2]:.2f}, "
        f"after {load_after[0]:.2f}/{load_after[1]:.2f}/{load_after[2]:.2f}\n"
    )
    lock = {
        (s, r): statistics.median([x["sync_pct"] for x in runs])
        for s, c, r, runs in rows
        if c == "lockstep"
    }
    print(
        "| scenario | clock | rate | sim s / wall s: run; loop | overruns % | deadline misses % | "
        "jitter p50 / p99 / max [µs] | work/step [µs] | round trip [µs] | age p99 [µs] | "
        "sync RMSE % | vs lockstep [pp] | finished |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name, clock, rate, runs in rows:
        col = lambda key: [r[key] for r in runs]
        rt = clock == "realtime"
        ref = lock.get((name, rate))
        diff = [abs(r["sync_pct"] - ref) for r in runs] if ref is not None else []
        jitter = (
            f"{fmt(col('jitter_p50_us'), 'max', 0)} / {fmt(col('jitter_p99_us'), 'max', 0)} / "
            f"{fmt(col('jitter_max_us'), 'max', 0)}"
            if rt
            else "–"
        )
        print(
            f"| {name} | {clock} | {rate:g} | {fmt(col('speed'), 'min', 2)}; "
            f"{fmt(col('loop_speed'), 'min', 2)} | "
            f"{fmt(col('overruns_pct'), 'max', 3) if rt else '–'} | "
            f"{fmt(col('misses_pct'), 'max', 3) if rt else '–'} | {jitter} | "
            f"{fmt(col('work_us'), 'max')} | "
            f"{fmt(col('round_trip_us'), 'max') if clock != 'fast' else '–'} | "
            f"{fmt(col('age_p99_us'), 'max', 0) if rt else '–'} | "
            f"{fmt(col('sync_pct'), 'max', 3)} | {fmt(diff, 'max', 3) if rt and diff else '–'} | "
            f"{sum(col('finished'))}/{len(runs)} |"
        )
    print(
        "\n| scenario | clock | rate | loop thread CPU [µs/step] | coordinator process CPU "
        "[µs/step] | specimen process CPU [µs/step] | CPU-bound speed [sim s / CPU s] |"
    )
    print("|---|---|---|---|---|---|---|")
    for name, clock, rate, runs in rows:
        col = lambda key: [r[key] for r in runs]
        total = [
            r["process_cpu_us"] + (0.0 if clock == "fast" else r["specimen_cpu_us"]) for r in runs
        ]
        print(
            f"| {name} | {clock} | {rate:g} | {fmt(col('loop_cpu_us'), 'max')} | "
            f"{fmt(col('process_cpu_us'), 'max')} | "
            f"{fmt(col('specimen_cpu_us'), 'max') if clock != 'fast' else '–'} | "
            f"{fmt([1e6 / rate / t for t in total], 'min', 2)} |"
        )
    stops = {r["stopped"] for _, _, _, runs in rows for r in runs if r["stopped"]}
    for reason in sorted(stops):
        print(f"\nstopped early: {reason}")
    if not args.no_components:
        print(
            "\n| scenario | rate | substructure | compensator | lab | row writes "
            "[µs/step, loop thread CPU] |"
        )
        print("|---|---|---|---|---|---|")
        for path in args.scenario:
            for rate in args.rates:
                costs = [component_costs(path, rate) for _ in range(args.repeats)]
                cells = " | ".join(
                    fmt([c[n] for c in costs], "max")
                    for n in ("substructure", "compensator", "lab", "rows")
                )
                print(f"| {path.name} | {rate:g} | {cells} |")


if __name__ == "__main__":
    main()
