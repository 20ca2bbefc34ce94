"""CPU cost of one vRTHS comparison trial, per compensator, and the full comparison extrapolated.

Usage::

    python tools/bench_vrths.py                          # every kind, case 1, nominal plant
    python tools/bench_vrths.py --kinds pi_lead ff_lqg --repeats 3 --parts
    python tools/bench_vrths.py --data /work/shared/data

Each trial is :func:`rths.experiments.vrths.compare.run_one` (the unit a campaign maps: build the
compensator, run the trial through the loop on the fast clock, score F4's J1-J9), timed with
``time.process_time`` -- the CPU of this process, all its threads included, which a shared
machine's load does not inflate the way it inflates wall time.  One warm-up trial first (numba
caches, the record, the reference response: a worker pays those once).  The least of
``--repeats`` is reported with the others beside it.

The extrapolation: the comparison is ``7 kinds x 4 cases x (1 + 20) plants`` trials; the El
Centro record has the same length in every case, so a trial's cost depends on its compensator;
``sum over kinds of the per-trial CPU x 84 / workers`` is its CPU-bound time on that many
workers (no scheduler overhead, no load from others).

``--parts`` adds the per-step CPU of the plant parts alone (frame, actuator, lab, compensator),
``--before DIR`` runs the same on another source tree (e.g. ``git archive`` of an older commit)
in a subprocess, for before/after figures.  Needs the benchmark package (``--data`` or
``RTHS_DATA``/``RTHS_VRTHS_PACKAGE``); exits 0 with one line when it is absent.
"""

from __future__ import annotations

import argparse
import math
import os
import subprocess
import sys
import time

KINDS = ("pi_lead", "ff_lqg", "ff", "lqg", "ats", "polynomial", "none")
TRIALS_PER_KIND = 4 * 21


def trial_cpu(kind: str, case: int, repeats: int) -> tuple[list[float], dict[str, float] | None]:
    """CPU seconds of ``repeats`` runs of one trial (after a warm-up) and its J1-J9."""
    from rths.experiments.vrths.compare import run_one, trial_specs

    spec = trial_specs([kind], [case], perturbed=0)[0]
    run_one(spec)
    cpu = []
    result = None
    for _ in range(repeats):
        start = time.process_time()
        result = run_one(spec)
        cpu.append(time.process_time() - start)
    assert result is not None
    return cpu, result.scores


def parts(steps: int = 30000) -> None:
    """Per-step CPU of the plant parts alone (best of 3 after a warm-up)."""
    import numpy as np

    from plants.base import Kinematics
    from plants.frame.cases import CASES
    from plants.frame.substructure import FrameSubstructure
    from rths.experiments.vrths import rig
    from rths.experiments.vrths.compare import _ground
    from rths.experiments.vrths.draws import NOMINAL

    ground = _ground("el_centro", None, ())
    command = (3e-3 * np.sin(2 * math.pi * 2 * np.arange(steps) * rig.DT)).tolist()
    targets = [Kinematics(c, 0.1 * c, 0.0) for c in command]

    def best(reset, body) -> float:
        out = math.inf
        for _ in range(4):  # the first run warms up
            reset()
            start = time.process_time()
            body()
            out = min(out, time.process_time() - start)
        return 1e6 * out / steps

    sub = FrameSubstructure(CASES[1], NOMINAL.specimen(), ground, rig.DT)
    lab = rig.benchmark_lab(NOMINAL, rig.DT, 1)
    act = lab.actuator
    rows = [
        ("frame substructure.step", sub.reset, lambda: [sub.step(10.0 * c) for c in command]),
        ("actuator.step", act.reset, lambda: [act.step(c) for c in command]),
        ("lab.step (actuator incl.)", lab.reset, lambda: [lab.step(c) for c in command]),
    ]
    for kind in KINDS:
        comp = rig.benchmark_compensator(kind)
        rows.append(
            (f"{kind}.step", comp.reset,
             lambda comp=comp: [comp.step(t, c) for t, c in zip(targets, command, strict=True)])
        )  # fmt: skip
    for label, reset, body in rows:
        print(f"  {label:28s} {best(reset, body):6.2f} us/step", flush=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kinds", nargs="+", default=list(KINDS), choices=KINDS)
    ap.add_argument("--case", type=int, default=1, choices=(1, 2, 3, 4))
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--parts", action="store_true", help="per-step CPU of the plant parts")
    ap.add_argument("--before", metavar="DIR", help="also run on the source tree in DIR")
    ap.add_argument("--data", metavar="DIR", help="folder holding vrths-benchmark/ (RTHS_DATA)")
    args = ap.parse_args(argv)
    if args.data:
        os.environ["RTHS_DATA"] = args.data
    from plants.frame.ground_motion import package_dir
    from rths.core.errors import RTHSError

    try:
        package_dir(None)
    except RTHSError as exc:
        print(f"bench_vrths: skipped ({exc})")
        return 0
    if args.before:
        forwarded = [a for a in (argv if argv is not None else sys.argv[1:])]
        i = forwarded.index("--before")
        del forwarded[i : i + 2]
        env = dict(os.environ, PYTHONPATH=os.path.abspath(args.before))
        print(f"== before: {args.before}", flush=True)
        subprocess.run([sys.executable, os.path.abspath(__file__), *forwarded], env=env, check=True)
        print("== after: this tree", flush=True)
    with open("/proc/loadavg") as f:
        print(f"load average at start: {' '.join(f.read().split()[:3])}", flush=True)
    total = 0.0
    for kind in args.kinds:
        cpu, scores = trial_cpu(kind, args.case, args.repeats)
        total += min(cpu)
        shown = " ".join(f"{c:.2f}" for c in cpu)
        j = "" if scores is None else f"  J1 {scores['J1']} ms, J2 {scores['J2']} %"
        print(f"  {kind:11s} CPU per trial {min(cpu):6.2f} s (runs: {shown}){j}", flush=True)
    if set(args.kinds) == set(KINDS):
        full = total * TRIALS_PER_KIND
        print(
            f"full comparison ({TRIALS_PER_KIND * len(KINDS)} trials): {full / 60:.1f} CPU-min, "
            f"{full / args.workers / 60:.1f} min on {args.workers} workers (CPU-bound)"
        )
    if args.parts:
        parts()
    with open("/proc/loadavg") as f:
        print(f"load average at end: {' '.join(f.read().split()[:3])}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
