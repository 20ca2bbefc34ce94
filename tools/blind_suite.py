"""Blind suite for ``rths diagnose``: generate labelled lab cases, then score the diagnosis.

    python tools/blind_suite.py generate --cases 36 --out /tmp/suite --seed 7
    python tools/blind_suite.py score /tmp/suite [--workers N | --scheduler tcp://HOST:8786]

``generate`` runs the project's emulated lab (:class:`plants.lab.EmulatedLab`: 16-bit +/-10 V
converters with noise, :class:`plants.actuator.TransferFunctionActuator` with the
MTS-identified TF, an IMD specimen) with one hidden effect per case, the six classes in turn, and
writes per case ``case_NNN/run_1.csv``, ``run_2.csv`` (two independent band-limited random tests:
the first identifies, the second is held out) and ``NOMINAL.toml``.  The labels and true parameters
go to ``truth.json`` beside the case folders; ``score`` reads it only *after* running the diagnosis,
which sees the case folder alone.

Random draws (uniform unless said; physically plausible and detectable at the default settings):

==================  ============================================================================
every case          inertance 800-2500 kg; damping ``c = 2 zeta m (2 pi 20 Hz)``, zeta 0.05-0.3
                    (S0 Eq.18 spans 0.02-0.3); true actuator gain 0.95-1.05; excitation band
                    0.3 Hz to 4-8 Hz, 1.5-4 mm RMS, 2 x 20 s at 2048 Hz; converter noise 0.5-2x
                    the seed lab's (3.8 um, 1 N); nominal: MTS TF with unit gain, inertance
                    x0.9-1.1 and damping x0.7-1.3 of the truth (the baseline must absorb them)
internal_stiffness  series k = m (2 pi f_e)^2, f_e 8-20 Hz (S0 Types I/II: 12.3, 13.8 Hz)
backlash            total clearance 0.05-0.5 mm (log-uniform; S0 Table 6: 0.01-0.4 mm) before a
                    contact of 15-30 Hz; zeta 0.15-0.3 so the contact is damped (zeta_c >= 0.1):
                    a lightly damped contact makes the force chaotic (the same model re-driven
                    with the sampled drive departs by ~100 % RMS), which no replay can identify
coulomb_friction    2-8 % of the RMS force of the test (S0 Eq.1 F_r)
actuator_delay      2-15 ms beyond the nominal (S0: ~20 ms total actuator lag)
rate_limit          50-85 % of the peak velocity the linear actuator would reach
none                nothing beyond the mis-calibrations above
==================  ============================================================================

Measured (``generate --cases 36 --seed 7``, then ``score``; six cases per class): top-1 accuracy
36/36 with the default drive and with ``--drive measured``; median parameter error 0.0-1.0 %
(worst 2.2 %, friction); median held-out shrink 100 % (worst 97.1 %); no false alarm on 6 none
cases; 5-6 s per case.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from rths.campaign import Cluster, map_tasks
from rths.diagnose._signals import actuator_replay
from rths.diagnose.data import write_csv
from rths.diagnose.nominal import nominal_toml
from rths.diagnose.synthetic import (
    CLASSES,
    LabCase,
    band_limited_command,
    lab_record,
    seed_converters,
)

DT = 1.0 / 2048.0
DURATION = 20.0
#: The verdict parameter compared with the truth, per class.
PARAMETER = {
    "internal_stiffness": "stiffness",
    "backlash": "gap",
    "coulomb_friction": "friction",
    "actuator_delay": "delay",
    "rate_limit": "velocity_limit",
}


def _draw(rng: np.random.Generator, label: str, commands: list[np.ndarray]) -> LabCase:
    m = rng.uniform(800.0, 2500.0)
    zeta = rng.uniform(0.15, 0.3) if label == "backlash" else rng.uniform(0.05, 0.3)
    c = 2.0 * zeta * m * 2.0 * math.pi * 20.0
    gain = rng.uniform(0.95, 1.05)
    scale = rng.uniform(0.5, 2.0)
    conv = seed_converters(5e-4 * scale, 1e-3 * scale)
    contact = rng.uniform(15.0, 30.0)
    base = LabCase("none", 0.0, m, c, gain, contact_frequency=contact)
    x = [gain * actuator_replay(base.num, base.den, DT, u) for u in commands]
    value = 0.0
    if label == "internal_stiffness":
        value = m * (2.0 * math.pi * rng.uniform(8.0, 20.0)) ** 2
    elif label == "backlash":
        value = math.exp(rng.uniform(math.log(0.05e-3), math.log(0.5e-3)))
    elif label == "coulomb_friction":
        v = [np.gradient(xi, DT) for xi in x]
        force = np.concatenate([m * np.gradient(vi, DT) + c * vi for vi in v])
        value = rng.uniform(0.02, 0.08) * float(np.sqrt(np.mean(force**2)))
    elif label == "actuator_delay":
        value = rng.uniform(0.002, 0.015)
    elif label == "rate_limit":
        peak = max(float(np.max(np.abs(np.diff(xi)))) / DT for xi in x)
        value = rng.uniform(0.5, 0.85) * peak
    return LabCase(label, value, m, c, gain, contact_frequency=contact, converters=conv)


def generate(cases: int, out: Path, seed: int) -> None:
    """Write ``cases`` labelled cases and ``truth.json`` into ``out``."""
    rng = np.random.default_rng(seed)
    out.mkdir(parents=True, exist_ok=True)
    truth = {}
    for i in range(cases):
        label = CLASSES[i % len(CLASSES)]
        f_hi = rng.uniform(4.0, 8.0)
        rms = rng.uniform(1.5e-3, 4e-3)
        commands = [band_limited_command(rng, DURATION, DT, (0.3, f_hi), rms) for _ in range(2)]
        case = _draw(rng, label, commands)
        folder = out / f"case_{i:03d}"
        folder.mkdir(exist_ok=True)
        for k, u in enumerate(commands, start=1):
            r = lab_record(case, u, DT, seed=int(rng.integers(2**31)), name=f"run_{k}.csv")
            write_csv(folder / r.name, r.time, r.command, r.measured, r.force)
        nominal = case.nominal(
            case.inertance * rng.uniform(0.9, 1.1), case.damping * rng.uniform(0.7, 1.3), 1.0
        )
        (folder / "NOMINAL.toml").write_text(nominal_toml(nominal, "blind-suite case"))
        truth[folder.name] = {
            "label": label,
            "params": {PARAMETER[label]: case.value} if label in PARAMETER else {},
        }
        print(f"{folder.name}: written", flush=True)
    (out / "truth.json").write_text(json.dumps(truth, indent=2) + "\n")


def _diagnose(folder: Path, drive: str) -> dict:
    """Run ``rths diagnose`` on a case through the CLI entry point, as a user would."""
    from rths.cli import main

    target = folder / f"diagnosis_{drive}.json"
    code = main(
        [
            "diagnose",
            str(folder / "run_1.csv"),
            str(folder / "run_2.csv"),
            "--nominal",
            str(folder / "NOMINAL.toml"),
            "--json",
            str(target),
            "--quiet",
            "--drive",
            drive,
        ]
    )
    if code != 0:
        raise RuntimeError(f"rths diagnose failed on {folder} (exit {code})")
    return json.loads(target.read_text())


def _diagnose_case(job: tuple[str, str]) -> tuple[dict, float]:
    """One case of the suite as a campaign task: its diagnosis and wall time [s]."""
    t0 = time.perf_counter()
    result = _diagnose(Path(job[0]), job[1])
    return result, time.perf_counter() - t0


def score(directory: Path, drive: str = "auto", cluster: Cluster | None = None) -> None:
    """Diagnose every case (each a task on ``cluster``: an embedded Dask cluster by default;
    the workers read the case folders, so a remote cluster needs them on a shared file system),
    then compare with ``truth.json`` and print the figures."""
    folders = sorted(p for p in directory.iterdir() if p.is_dir() and p.name.startswith("case_"))
    jobs = [(str(folder), drive) for folder in folders]
    done = map_tasks(_diagnose_case, jobs, cluster, desc="blind suite")
    results = {folder.name: d[0] for folder, d in zip(folders, done, strict=True)}
    times = [d[1] for d in done]
    truth = json.loads((directory / "truth.json").read_text())  # read only after diagnosing
    confusion = {a: dict.fromkeys(CLASSES, 0) for a in CLASSES}
    errors: dict[str, list[float]] = {c: [] for c in PARAMETER}
    shrink, false_alarm, n_none, correct = [], 0, 0, 0
    for name, res in results.items():
        label = truth[name]["label"]
        confusion[label][res["verdict"]] += 1
        correct += res["verdict"] == label
        if label == "none":
            n_none += 1
            false_alarm += res["verdict"] != "none"
            continue
        key = PARAMETER[label]
        cand = next(c for c in res["candidates"] if c["name"] == label)
        true = truth[name]["params"][key]
        errors[label].append(abs(cand["params"][key] - true) / true)
        shrink.append(cand["closed"])
        print(
            f"{name}: {label:18} -> {res['verdict']:18} {key}={cand['params'][key]:.4g} "
            f"(true {true:.4g}) closed {100 * cand['closed']:.1f} %"
        )
    print(f"\n{len(results)} cases, top-1 accuracy {100 * correct / len(results):.1f} %")
    print("confusion (rows: truth, columns: verdict)")
    short = [c[:10] for c in CLASSES]
    print(f"{'':19}" + " ".join(f"{s:>10}" for s in short))
    for a in CLASSES:
        print(f"{a:19}" + " ".join(f"{confusion[a][b]:10d}" for b in CLASSES))
    print("median relative parameter error (true-effect candidate):")
    for c, e in errors.items():
        if e:
            print(
                f"  {c:19} {PARAMETER[c]:15} {100 * statistics.median(e):.2f} %  (max "
                f"{100 * max(e):.2f} %, n={len(e)})"
            )
    if shrink:
        print(
            f"median held-out shrink (true-effect cases): {100 * statistics.median(shrink):.1f}"
            f" % of the reducible gap (min {100 * min(shrink):.1f} %)"
        )
    if n_none:
        print(f"false-alarm rate on none: {false_alarm}/{n_none}")
    print(f"diagnosis time per case: median {statistics.median(times):.2f} s")


def main(argv: list[str] | None = None) -> int:
    """Command line (module docstring)."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n", 1)[0])
    sub = p.add_subparsers(dest="action", required=True)
    g = sub.add_parser("generate", help="write labelled cases and truth.json")
    g.add_argument("--cases", type=int, default=36)
    g.add_argument("--out", type=Path, required=True)
    g.add_argument("--seed", type=int, default=0)
    s = sub.add_parser("score", help="diagnose every case and compare with truth.json")
    s.add_argument("directory", type=Path)
    s.add_argument(
        "--drive",
        choices=("auto", "measured"),
        default="auto",
        help="rths diagnose --drive (default auto)",
    )
    s.add_argument("--workers", type=int, help="worker processes (default: one per core)")
    s.add_argument("--scheduler", help="a Dask cluster's scheduler, tcp://HOST:8786")
    args = p.parse_args(argv)
    if args.action == "generate":
        generate(args.cases, args.out, args.seed)
    else:
        score(args.directory, args.drive, Cluster(args.scheduler, args.workers))
    return 0


if __name__ == "__main__":
    sys.exit(main())
