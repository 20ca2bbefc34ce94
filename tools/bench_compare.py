"""The vRTHS comparison (``rths compare``) as a campaign, measured: wall time on 1 and 2 workers,
per-run cost, identical tables across worker counts, and the full comparison projected.

Usage::

    python tools/bench_compare.py [--data DIR] [--cases 1 4] [--perturbed 0]
                                  [--workers 1 2] [--out runs/bench_compare] [--json OUT.json]

Needs the benchmark's records (El Centro): ``--data DIR`` or ``RTHS_DATA`` (the folder holding
``vrths-benchmark/``); without them it says so in one line and exits 0.

Steps (each timing printed with the load average taken just before it: the machine is shared):

1. The comparison restricted to ``--cases`` and ``--perturbed`` plants (every compensator) as a
   campaign on each worker count (embedded LocalCluster of processes, fresh tables): wall time
   (cluster start-up included), the summed CPU time of the runs (``cpu_s``: what they cost on a
   core nobody else uses), the digest of each table (equal: bit-identical results), speed-up.
2. Per-run cost per compensator (mean ``cpu_s`` and ``wall_s``) and steps per CPU second.
3. The full comparison (every compensator x 4 cases x (nominal + 20 perturbed) = 588 runs)
   projected from the per-compensator CPU cost: on ``W`` idle cores it takes about
   ``startup + sum(cpu) / W``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
FULL_CASES, FULL_PERTURBED = 4, 20


def _load() -> str:
    one, five, _ = os.getloadavg()
    return f"load {one:.2f} (1 min) {five:.2f} (5 min) on {os.cpu_count()} cores"


def _say(text: str) -> None:
    print(text, flush=True)


def measure(args: argparse.Namespace, workers: int) -> dict[str, Any]:
    """One comparison on an embedded cluster of ``workers`` processes, fresh table."""
    from rths.campaign import Cluster, ResultTable
    from rths.experiments.vrths.compare import COMPENSATORS, run_comparison

    path = args.out / f"compare-w{workers}.parquet"
    path.unlink(missing_ok=True)
    table = ResultTable(path)
    load = _load()
    start = time.perf_counter()
    c = run_comparison(
        COMPENSATORS,
        args.cases,
        ground="el_centro",
        perturbed=args.perturbed,
        package=args.package,
        cluster=Cluster(workers=workers),
        table=table,
    )
    wall = time.perf_counter() - start
    stats = c.stats
    assert stats is not None
    rows = table.rows(c.keys)
    per_kind: dict[str, dict[str, float]] = {}
    for kind in COMPENSATORS:
        mine = [r for r in rows if r["compensator"] == kind]
        cpu = [float(r["cpu_s"]) for r in mine]  # type: ignore[arg-type]
        per_kind[kind] = {
            "runs": len(mine),
            "cpu_s_mean": statistics.fmean(cpu),
            "wall_s_mean": statistics.fmean(float(r["wall_s"]) for r in mine),  # type: ignore[arg-type]
            "interlocked": sum(r["status"] != "ok" for r in mine),
        }
    out = {
        "workers": workers,
        "runs": stats.ran,
        "failed": stats.failed,
        "wall_s": wall,
        "startup_s": stats.startup,
        "cpu_s": stats.cpu,
        "busy_s": stats.busy,
        "digest": table.digest(c.keys),
        "load_before": load,
        "load_after": _load(),
        "per_kind": per_kind,
    }
    _say(
        f"comparison cases {args.cases} x (nominal + {args.perturbed}) x {len(COMPENSATORS)} "
        f"compensators = {stats.ran} runs on {workers} worker(s): {wall:.1f} s wall "
        f"(start-up {stats.startup:.1f} s), runs' CPU {stats.cpu:.1f} s, busy {stats.busy:.1f} s; "
        f"digest {out['digest'][:16]}  [{load}; after: {out['load_after']}]"
    )
    return out


def main(argv: list[str] | None = None) -> int:
    """Measure and print the figures; 0 (also when the records are absent)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, help="folder holding vrths-benchmark/ ($RTHS_DATA)")
    parser.add_argument("--cases", type=int, nargs="+", default=[1, 4])
    parser.add_argument("--perturbed", type=int, default=0)
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--out", type=Path, default=ROOT / "runs" / "bench_compare")
    parser.add_argument("--json", type=Path, help="write the figures as JSON")
    args = parser.parse_args(argv)
    data = args.data or (Path(os.environ["RTHS_DATA"]) if os.environ.get("RTHS_DATA") else None)
    package = None if data is None else data / "vrths-benchmark"
    if package is None or not package.is_dir():
        print("bench_compare: no benchmark records (--data DIR or RTHS_DATA); skipped")
        return 0
    args.package = str(package)
    args.out.mkdir(parents=True, exist_ok=True)
    from rths.experiments.vrths.compare import COMPENSATORS, _ground
    from rths.experiments.vrths.rig import DT

    steps = _ground("el_centro", args.package, ()).steps(DT)
    results = [measure(args, w) for w in args.workers]
    figures: dict[str, Any] = {"steps_per_run": steps, "measurements": results}
    digests = {r["digest"] for r in results}
    _say(f"identical tables across worker counts: {len(digests) == 1} ({sorted(digests)})")
    if len(results) >= 2:
        speedup = results[0]["wall_s"] / results[-1]["wall_s"]
        figures["speedup"] = speedup
        first, last = results[0]["workers"], results[-1]["workers"]
        _say(f"speed-up {first} -> {last} workers: {speedup:.2f}x")
    base = results[0]["per_kind"]
    full_cpu = 0.0
    for kind in COMPENSATORS:
        k = base[kind]
        full_cpu += k["cpu_s_mean"] * FULL_CASES * (FULL_PERTURBED + 1)
        _say(
            f"  {kind:<11} cpu {k['cpu_s_mean']:.2f} s/run ({steps / k['cpu_s_mean']:,.0f} "
            f"steps per CPU second), wall {k['wall_s_mean']:.2f} s/run on 1 worker, "
            f"{int(k['interlocked'])} interlocked"
        )
    n_full = len(COMPENSATORS) * FULL_CASES * (FULL_PERTURBED + 1)
    startup = results[-1]["startup_s"]
    figures["full"] = {"runs": n_full, "cpu_s": full_cpu}
    for w in (1, 2):
        est = startup + full_cpu / w
        figures["full"][f"idle_{w}_workers_s"] = est
        _say(
            f"full comparison ({n_full} runs): {full_cpu:.0f} CPU s -> about {est / 60:.1f} min "
            f"on {w} idle core(s)"
        )
    if args.json:
        args.json.write_text(json.dumps(figures, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
