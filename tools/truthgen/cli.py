"""Command line of the truth generator (see ``__main__`` for the full description)."""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ALLOWED_RATES = (1000.0, 1024.0, 2048.0, 4096.0)
VERSION = 1


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2
        sys.stderr.write(f"truthgen: error: {message}\n")
        raise SystemExit(2)


def _fail(msg: str) -> None:
    sys.stderr.write(f"truthgen: error: {msg}\n")
    raise SystemExit(2)


def _clean(obj):
    """JSON-safe copy (numpy scalars -> Python, non-finite -> None)."""
    import numpy as np

    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if isinstance(obj, (np.floating, float)):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj


def _job(args: tuple) -> tuple[str, dict, float]:
    from .generate import build_case

    name, ss, plan, rates, max_dur, out, ranges = args
    t0 = time.process_time()
    label = build_case(ss, plan, rates, max_dur, Path(out) / name, ranges=ranges)
    return name, label, time.process_time() - t0


def parse(argv: list[str] | None) -> argparse.Namespace:
    """Parse and validate arguments (one-line error and exit 2 on misuse)."""
    p = _Parser(prog="truthgen", description="Independent sim-to-real truth suite generator.")
    p.add_argument(
        "--out", required=True, help="suite folder to create (must not exist or be empty)"
    )
    p.add_argument("--cases", required=True, type=int, help="number of cases (>= 1)")
    p.add_argument("--seed", required=True, type=int, help="master seed (>= 0)")
    p.add_argument(
        "--rates",
        default="1000,1024,2048,4096",
        help="comma-separated output rates drawn from, Hz (subset of 1000,1024,2048,4096)",
    )
    p.add_argument(
        "--max-duration",
        type=float,
        default=40.0,
        help="cap on each record's length, s (3-40; default 40 = no cap)",
    )
    p.add_argument(
        "--effects",
        default="",
        help="comma-separated effect classes (and/or 'none') the cases are made of "
        "(default: all; pairs kept when both classes are listed)",
    )
    p.add_argument(
        "--ranges",
        choices=("default", "wide"),
        default="default",
        help="effect parameter ranges: default, or wide (series elements 1e5-1e10 N/m, "
        "clearance 1 um - 5 mm, lightly damped; friction 0.5-60 %%)",
    )
    p.add_argument(
        "--jobs", type=int, default=1, help="worker processes (output does not depend on it)"
    )
    a = p.parse_args(argv)
    if a.cases < 1:
        _fail("--cases must be >= 1")
    if a.seed < 0:
        _fail("--seed must be >= 0")
    if a.jobs < 1:
        _fail("--jobs must be >= 1")
    if not (3.0 <= a.max_duration <= 40.0):
        _fail("--max-duration must be within 3-40 s")
    try:
        rates = [float(r) for r in a.rates.split(",") if r.strip()]
    except ValueError:
        _fail(f"--rates must be comma-separated numbers, got {a.rates!r}")
    if not rates or any(r not in ALLOWED_RATES for r in rates):
        _fail(f"--rates must be a subset of 1000,1024,2048,4096, got {a.rates!r}")
    a.rate_list = sorted(set(rates))
    from .design import EFFECTS

    a.only = tuple(e.strip() for e in a.effects.split(",") if e.strip()) or None
    bad = [e for e in a.only or () if e not in (*EFFECTS, "none")]
    if bad:
        _fail(f"--effects: unknown effect class {bad[0]!r} (one of {', '.join(EFFECTS)}, none)")
    out = Path(a.out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        _fail(f"--out {a.out} exists and is not an empty folder")
    return a


def main(argv: list[str] | None = None) -> int:
    """Generate a suite; returns the exit status."""
    a = parse(argv)  # before the heavy imports: misuse fails fast
    import numpy as np

    from . import design

    out = Path(a.out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        _fail(f"cannot create {a.out}: {e.strerror}")
    root = np.random.SeedSequence(a.seed)
    plan_ss, case_root = root.spawn(2)
    plans = design.plan_cases(np.random.default_rng(plan_ss), a.cases, a.only)
    width = max(3, len(str(a.cases - 1)))
    names = [f"case_{i:0{width}d}" for i in range(a.cases)]
    jobs = [
        (nm, ss, pl, a.rate_list, a.max_duration, str(out), a.ranges)
        for nm, ss, pl in zip(names, case_root.spawn(a.cases), plans)
    ]
    labels: dict[str, dict] = {}
    t_start = time.time()
    done = 0

    def report(name: str, label: dict, cpu: float) -> None:
        nonlocal done
        done += 1
        eff = "+".join(e["effect"] for e in label["effects"])
        secs = sum(r["duration"] for r in label["records"])
        sys.stderr.write(
            f"truthgen: [{done}/{a.cases}] {name}: {eff}, {label['rate']:g} Hz, "
            f"{len(label['records'])} records ({secs:.0f} s) in {cpu:.1f} s cpu\n"
        )
        labels[name] = label

    try:
        if a.jobs == 1:
            for j in jobs:
                report(*_job(j))
        else:
            with ProcessPoolExecutor(max_workers=a.jobs) as ex:
                for res in ex.map(_job, jobs):
                    report(*res)
    except (RuntimeError, OSError) as e:  # generation failure: one line, status 1
        sys.stderr.write(f"truthgen: error: {e}\n")
        return 1
    ordered = {nm: _clean(labels[nm]) for nm in names}
    (out / "labels.json").write_text(json.dumps(ordered, indent=1) + "\n")
    meta = {
        "generator": "truthgen",
        "version": VERSION,
        "seed": a.seed,
        "cases": a.cases,
        "rates": a.rate_list,
        "max_duration": a.max_duration,
        "effect_classes": list(design.EFFECTS) + ["none"],
        "only": list(a.only) if a.only else None,
        "ranges": a.ranges,
        "channels": {k: v for k, v in design.CHANNEL.items()},
    }
    (out / "generator.json").write_text(json.dumps(meta, indent=1) + "\n")
    sys.stderr.write(f"truthgen: wrote {a.cases} cases to {out} in {time.time() - t_start:.1f} s\n")
    return 0
