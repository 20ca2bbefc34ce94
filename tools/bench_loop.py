"""Benchmark the RTHS loop on the seed scenario.

* ``fast``: simulated seconds per wall second (whole run: build, loop, recording);
* ``realtime`` over zenoh at several loop rates: overrun fraction, p99 start jitter and the mean
  age of the measurement the loop uses (coordinator and specimen on this machine);
* ``lockstep``: wall time per step (round trip included).

Run on a quiet machine (the realtime figures depend on it)::

    python tools/bench_loop.py --rates 1024 2048 4096 --duration 20
"""

from __future__ import annotations

import argparse
import re
import tempfile
import time
from pathlib import Path

import numpy as np

from rths.config.scenario import parse_scenario
from rths.log.reader import read_metadata, read_topic
from rths.session.runner import RunOptions, run_scenario

SEED = Path(__file__).resolve().parent.parent / "scenarios" / "cable_imd_mode3.toml"


def scenario(rate: float, duration: float):
    text = SEED.read_text()
    text = re.sub(r"^rate = .*$", f"rate = {rate}", text, flags=re.M)
    text = re.sub(r"^duration = .*$", f"duration = {duration}", text, flags=re.M)
    return parse_scenario(text, str(SEED))


def run(clock: str, rate: float, duration: float, out: Path) -> dict:
    scn = scenario(rate, duration)
    start = time.perf_counter()
    outcome = run_scenario(scn, RunOptions(clock=clock, out=out))
    wall = time.perf_counter() - start
    loop = read_topic(out, "rths/loop")
    summary = read_metadata(out)["rths.summary"]
    t = outcome.result.timing
    return {
        "clock": clock,
        "rate": rate,
        "steps": outcome.result.steps,
        "wall_s": wall,
        "sim_per_wall": outcome.result.steps * scn.run.dt / wall,
        "overrun_fraction": t.overrun_fraction,
        "jitter_p99_us": 1e6 * t.jitter_p99,
        "busy_mean_us": 1e6 * t.busy_mean,
        "age_mean_us": 1e6 * float(np.mean(loop["age"])),
        "sync_rmse_pct": 100 * float(summary.get("sync_rmse", "nan")),
        "stopped": outcome.result.stopped,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rates", type=float, nargs="+", default=[1024.0, 2048.0, 4096.0])
    ap.add_argument("--duration", type=float, default=20.0)
    ap.add_argument("--skip-realtime", action="store_true")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        rows = [run("fast", 2048.0, args.duration, Path(tmp) / "fast.mcap")]
        rows.append(run("lockstep", 2048.0, args.duration, Path(tmp) / "lock.mcap"))
        if not args.skip_realtime:
            for rate in args.rates:
                rows.append(run("realtime", rate, args.duration, Path(tmp) / f"rt{rate:g}.mcap"))
    print(
        f"{'clock':<9} {'rate':>6} {'sim/wall':>9} {'overruns':>9} {'p99 jit us':>10} "
        f"{'busy us':>8} {'age us':>8} {'sync %':>7}  stopped"
    )
    for r in rows:
        print(
            f"{r['clock']:<9} {r['rate']:>6.0f} {r['sim_per_wall']:>9.2f} "
            f"{100 * r['overrun_fraction']:>8.2f}% {r['jitter_p99_us']:>10.0f} "
            f"{r['busy_mean_us']:>8.0f} {r['age_mean_us']:>8.0f} {r['sync_rmse_pct']:>7.3f}  "
            f"{r['stopped'] or ''}"
        )


if __name__ == "__main__":
    main()
