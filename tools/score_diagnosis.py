"""Score ``rths diagnose`` on the three sources: own plants, an independent generator, real data.

    python tools/score_diagnosis.py suite DIR [--jobs N] [--limit N] [--json OUT]
    python tools/score_diagnosis.py friction-damper [--data DIR] [--nominal viscous|coulomb]
                                                    [--jobs N] [--json OUT]
    python tools/score_diagnosis.py mts [--data DIR] [--json OUT]

``suite DIR`` scores a labelled suite in the shared labels schema (``DIR/labels.json``:
``{case: {"effects": [{"effect", "channel", "params"}, ...], ...}}``, strongest effect first;
``DIR/case_NNN/rec_*.csv`` and ``NOMINAL.toml``): the one written by ``tools/blind_suite.py``
(own plants) and the one written by ``python -m tools.truthgen`` (an independent generator).
Each case is diagnosed with the default split (the first half of its records identify, the
rest are held out).  Reported:

- confusion matrix of the verdict against the primary (first-labelled) effect;
- top-1 accuracy two ways: ``strict`` (verdict = primary effect) and ``any`` (verdict is one
  of the labelled effects -- a combined case's effects may be ranked differently by size);
- full-set accuracy: the set of named effects equals the labelled set (``none``: no effect);
- parameter errors: ``|identified / true - 1|`` of the headline parameter of every correctly
  named effect (stiffness, gap, friction, delay, velocity_limit, c1), quantiles 50/90 % and the
  share within 10 %;
- held-out shrink: quantiles of the share of the reducible gap the effects close (``shrink``,
  the effects' own noise floors credited) and of the share by which they lower the held-out
  residual itself, ``(J_0 - J_S)/(J_0 - N_0)`` on the verdict's channel (``residual``);
- false ``none`` (an effect present) and false ``unexplained`` rates; time per case.

With ``--json`` the suite's file also holds every case's diagnosis (``results``: the
``rths diagnose --json`` document, every candidate tried with its held-out scores), so a miss
can be read without diagnosing the case again.

``friction-damper`` diagnoses the real friction damper with backlash (ARTS Laboratory,
University of South Carolina; Downey et al., Engineering Structures 113 (2016) 287-298,
CC BY-SA 4.0): per band tension, each record in turn is held out and the others of that
tension identify (the earthquake profiles, 36 lb, are always held out); the nominal is the
viscous or plain Coulomb least-squares fit of ``tools/friction_damper_loops.py``.  Per held-out
run: the verdict, the effects, friction [kN] and clearance [mm] beside the loop-read values of
``tools/friction_damper_reading.py`` (an independent reading of the same loops).

``mts`` diagnoses the public MTS actuator record (``mts-actuator/0A.txt``) against the
MTS-identified nominal (no effect is known; reported as is).

Data from ``--data DIR`` or ``RTHS_DATA``; without it the real-data commands print one
``skipped: ...`` line and exit 0.  Cases run as one campaign (:mod:`rths.campaign`, Dask): over
``--jobs`` local worker processes (one core each) or on a cluster (``--scheduler tcp://HOST:8786``);
with ``--table FILE`` every diagnosis is kept as a row and a rerun skips the cases the table
holds (resume); a case that fails is a row, not a crash.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from collections import Counter
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

#: Headline parameter of each effect: (our name, the labels' name).
HEADLINE = {
    "internal_stiffness": ("stiffness", "stiffness"),
    "backlash": ("gap", "gap"),
    "coulomb_friction": ("friction", "friction"),
    "amplitude_damping": ("c1", "c1"),
    "actuator_delay": ("delay", "delay"),
    "rate_limit": ("velocity_limit", "velocity_limit"),
}
CLASSES = ("none", *HEADLINE, "unexplained")


def _run(tasks: list, args: argparse.Namespace, name: str) -> list[dict]:
    """Diagnose every case as one campaign (:mod:`rths.campaign`: ``--jobs`` local worker
    processes or ``--scheduler``; with ``--table`` resumable, a case already in the table is not
    diagnosed again); a line per finished case on stderr; results in task order."""
    from rths.campaign import Campaign, Cluster, ResultTable, Run, execute
    from rths.diagnose.suite import case_key, diagnose_case

    runs = [
        Run(case_key(folder, held), {"case": Path(folder).name}, (folder, held))
        for folder, held in tasks
    ]
    table = ResultTable(args.table)
    done = [0]

    def report(row: dict) -> None:
        done[0] += 1
        print(
            f"[{done[0]}/{len(runs)}] {row['case']}: {row.get('verdict', row.get('status'))} "
            f"({row['wall_s']:.1f} s)",
            file=sys.stderr,
            flush=True,
        )

    cluster = Cluster(scheduler=args.scheduler, workers=args.jobs)
    stats = execute(Campaign(name, runs, diagnose_case), table, cluster, on_row=report)
    if stats.skipped:
        print(f"{stats.skipped} case(s) already in {args.table}: not run again", file=sys.stderr)
    out: list[dict] = []
    for row in table.rows([r.key for r in runs]):
        if row.get("status") == "error" or not isinstance(row.get("diagnosis"), str):
            doc = {"verdict": "error", "error": str(row.get("error")), "effects": []}
        else:
            doc = json.loads(str(row["diagnosis"]))
        doc["seconds"] = float(row["wall_s"])  # type: ignore[arg-type]
        out.append(doc)
    return out


def _quantiles(x: list[float]) -> dict[str, float]:
    if not x:
        return {}
    a = np.asarray(x, dtype=float)
    return {
        "n": float(a.size),
        "q10": float(np.quantile(a, 0.1)),
        "q50": float(np.quantile(a, 0.5)),
        "q90": float(np.quantile(a, 0.9)),
    }


def residual_shrink(result: dict) -> float | None:
    """Share of the verdict channel's reducible gap ``J_0 - N_0`` by which the effects lower
    the held-out mean square itself, ``(J_0 - J_S)/(J_0 - N_0)`` (from the channel's held-out
    NRMSEs: baseline, after, floor); None for a channel at its floor or no effect named."""
    ch = result.get("channels", {}).get(result.get("gap", {}).get("channel"))
    if not ch or not result.get("effects"):
        return None
    j0, js, n0 = (ch[k] ** 2 for k in ("baseline_nrmse", "after_nrmse", "floor_nrmse"))
    return (j0 - js) / (j0 - n0) if j0 > n0 else None


def score_case(label: dict, result: dict) -> dict:
    """Score one diagnosis against its label (module docstring)."""
    truth = [e["effect"] for e in label["effects"] if e["effect"] != "none"]
    named = [e["name"] for e in result.get("effects", [])]
    verdict = result["verdict"]
    primary = truth[0] if truth else "none"
    errors = {}
    for e in label["effects"]:
        name = e["effect"]
        if name not in named or name not in HEADLINE:
            continue
        ours, theirs = HEADLINE[name]
        found = next(x["params"] for x in result["effects"] if x["name"] == name)
        if ours in found and theirs in e["params"] and e["params"][theirs] != 0.0:
            errors[name] = abs(found[ours] / e["params"][theirs] - 1.0)
    return {
        "truth": truth or ["none"],
        "verdict": verdict,
        "named": named,
        "top1_strict": verdict == primary,
        "top1_any": verdict in (truth or ["none"]),
        "full_set": set(named) == set(truth) and (bool(truth) or verdict == "none"),
        "errors": errors,
        "shrink": result.get("shrink"),
        "residual_shrink": residual_shrink(result),
        "false_none": bool(truth) and verdict == "none",
        "false_unexplained": verdict == "unexplained",
        "seconds": result["seconds"],
        "combined": len(truth) > 1,
    }


def summarize(scores: dict[str, dict]) -> dict:
    """Accuracy, confusion, parameter errors, shrink, false rates, time (module docstring)."""
    s = list(scores.values())
    n = len(s)
    rate = lambda key, sub=s: sum(x[key] for x in sub) / max(len(sub), 1)
    combined = [x for x in s if x["combined"]]
    errs = [v for x in s for v in x["errors"].values()]
    confusion: Counter[tuple[str, str]] = Counter((x["truth"][0], x["verdict"]) for x in s)
    return {
        "cases": n,
        "top1_strict": rate("top1_strict"),
        "top1_any": rate("top1_any"),
        "full_set": rate("full_set"),
        "combined_cases": len(combined),
        "combined_top1_any": rate("top1_any", combined),
        "combined_full_set": rate("full_set", combined),
        "param_error": _quantiles(errs),
        "param_within_10pct": sum(e <= 0.1 for e in errs) / max(len(errs), 1),
        "shrink": _quantiles([x["shrink"] for x in s if x["shrink"] is not None]),
        "residual_shrink": _quantiles(
            [x["residual_shrink"] for x in s if x.get("residual_shrink") is not None]
        ),
        "false_none": sum(x["false_none"] for x in s)
        / max(sum(x["truth"] != ["none"] for x in s), 1),
        "false_unexplained": rate("false_unexplained"),
        "seconds": _quantiles([x["seconds"] for x in s]),
        "confusion": {f"{a} -> {b}": c for (a, b), c in sorted(confusion.items())},
    }


def _print_summary(title: str, summary: dict, scores: dict[str, dict]) -> None:
    print(f"== {title}")
    for case, x in scores.items():
        mark = "ok " if x["full_set"] else ("top" if x["top1_any"] else "XX ")
        errs = ", ".join(f"{k} {100 * v:.1f}%" for k, v in x["errors"].items())
        print(
            f"{mark} {case}: truth {'+'.join(x['truth'])}; verdict {x['verdict']}; "
            f"effects {'+'.join(x['named']) or '-'}; errors [{errs}]; {x['seconds']:.1f} s"
        )
    labels = sorted({k.split(" -> ")[0] for k in summary["confusion"]})
    cols = [c for c in CLASSES if any(k.endswith(f"-> {c}") for k in summary["confusion"])]
    cols += sorted({k.split(" -> ")[1] for k in summary["confusion"]} - set(cols))
    print("confusion (rows: primary label, columns: verdict)")
    print(f"{'':20}" + "".join(f"{c[:11]:>12}" for c in cols))
    for r in labels:
        row = [summary["confusion"].get(f"{r} -> {c}", 0) for c in cols]
        print(f"{r:20}" + "".join(f"{v:>12}" for v in row))
    pe, sh, sec = summary["param_error"], summary["shrink"], summary["seconds"]
    print(
        f"top-1 {100 * summary['top1_strict']:.0f} % strict / {100 * summary['top1_any']:.0f} % "
        f"any-of-set; full set {100 * summary['full_set']:.0f} %; combined cases "
        f"{summary['combined_cases']}: top-1 {100 * summary['combined_top1_any']:.0f} %, "
        f"full set {100 * summary['combined_full_set']:.0f} %"
    )
    if pe:
        print(
            f"parameter error: median {100 * pe['q50']:.1f} %, 90 % {100 * pe['q90']:.1f} %, "
            f"within 10 %: {100 * summary['param_within_10pct']:.0f} % of {int(pe['n'])}"
        )
    if sh:
        print(f"held-out shrink: median {100 * sh['q50']:.0f} %, 90 % {100 * sh['q90']:.0f} %")
    rs = summary.get("residual_shrink")
    if rs:
        print(
            f"held-out residual shrink (no floor credited): median {100 * rs['q50']:.0f} %, "
            f"10 % quantile {100 * rs['q10']:.0f} %"
        )
    print(
        f"false none {100 * summary['false_none']:.0f} %, false unexplained "
        f"{100 * summary['false_unexplained']:.0f} %; time per case median {sec['q50']:.1f} s, "
        f"90 % {sec['q90']:.1f} s"
    )


def cmd_suite(args: argparse.Namespace) -> int:
    labels = json.loads((args.dir / "labels.json").read_text())
    cases = sorted(labels)[: args.limit] if args.limit else sorted(labels)
    results = _run([(str(args.dir / c), None) for c in cases], args, args.dir.name)
    scores = {c: score_case(labels[c], r) for c, r in zip(cases, results, strict=True)}
    for c, r in zip(cases, results, strict=True):
        if r["verdict"] == "error":
            print(f"{c}: error: {r['error']}", file=sys.stderr)
    summary = summarize(scores)
    _print_summary(str(args.dir), summary, scores)
    if args.json:
        results_by_case = dict(zip(cases, results, strict=True))
        args.json.write_text(
            json.dumps({"summary": summary, "cases": scores, "results": results_by_case}, indent=1)
        )
    return 0


def _groups(manifest: dict) -> dict[float, list[str]]:
    out: dict[float, list[str]] = {}
    for name, m in manifest["records"].items():
        out.setdefault(m["tension_lb"], []).append(name)
    return out


def cmd_friction_damper(args: argparse.Namespace) -> int:
    from friction_damper_data import SKIP_MESSAGE, find_data_dir, list_records, load_record
    from friction_damper_loops import nominal_toml
    from friction_damper_reading import read_record
    from friction_damper_reading import summarize as read_summary
    from friction_damper_to_csv import columns, write_csv

    folder = find_data_dir(args.data)
    if folder is None:
        print(SKIP_MESSAGE)
        return 0
    work = Path(tempfile.mkdtemp(prefix="score_fd_"))
    records = {n: load_record(folder, n) for n in list_records(folder)}
    tension = {n: r.tension_lb for n, r in records.items()}
    read = {}
    for n, r in records.items():
        s = read_summary(read_record(r))
        read[n] = (s["friction"]["median"], s["clearance_tangent"]["median"])
    tasks: list[tuple[str, tuple[str, ...] | None]] = []
    meta = []
    for t in sorted(set(tension.values())):
        names = sorted(n for n in records if tension[n] == t)
        sines = [n for n in names if not n.startswith("eq_")]
        held_sets = [(n,) for n in sines] if len(sines) > 1 else []
        held_sets += [(n,) for n in names if n.startswith("eq_")]
        for held in held_sets:
            ident = [n for n in sines if n not in held]
            if not ident:
                continue
            nominal = nominal_toml(args.nominal, t, [records[n] for n in ident])
            case = work / f"{int(t)}lb_{held[0]}"
            case.mkdir()
            (case / "NOMINAL.toml").write_text(nominal)
            for i, n in enumerate([*ident, *held], 1):
                write_csv(case / f"rec_{i}.csv", columns(records[n])[0])
            tasks.append((str(case), (f"rec_{len(ident) + 1}.csv",)))
            meta.append((t, held[0], ident))
    results = _run(tasks, args, f"friction-damper-{args.nominal}")
    rows = []
    print(f"== friction damper, nominal = {args.nominal} fit per tension (held out one at a time)")
    print(
        f"{'tension':>7} {'held-out run':34} {'verdict':18} {'effects':36} "
        f"{'friction kN':>11} {'loop kN':>8} {'gap mm':>7} {'loop mm':>8} {'shrink':>7} {'s':>5}"
    )
    for (t, held, ident), r in zip(meta, results, strict=True):
        eff = {e["name"]: e["params"] for e in r.get("effects", [])}
        fr = eff.get("coulomb_friction", {}).get("friction")
        gap = eff.get("backlash", {}).get("gap")
        lf, lg = read[held]
        row = {
            "tension_lb": t,
            "held_out": held,
            "identification": ident,
            "verdict": r["verdict"],
            "effects": list(eff),
            "friction_N": fr,
            "loop_friction_N": lf,
            "gap_m": gap,
            "loop_gap_m": lg,
            "shrink": r.get("shrink"),
            "seconds": r["seconds"],
            "named_both": {"coulomb_friction", "backlash"} <= set(eff),
        }
        rows.append(row)
        f = lambda v, s: "-" if v is None else f"{v * s:.2f}"
        print(
            f"{t:7g} {held:34} {r['verdict']:18} {'+'.join(eff) or '-':36} {f(fr, 1e-3):>11} "
            f"{f(lf, 1e-3):>8} {f(gap, 1e3):>7} {f(lg, 1e3):>8} "
            f"{100 * (r.get('shrink') or 0):6.0f}% {r['seconds']:5.0f}"
        )
    both = sum(r["named_both"] for r in rows)
    print(f"friction and backlash both named on {both} of {len(rows)} held-out runs")
    if args.json:
        args.json.write_text(json.dumps({"nominal": args.nominal, "runs": rows}, indent=1))
    return 0


def cmd_mts(args: argparse.Namespace) -> int:
    from friction_damper_data import find_data_dir

    folder = find_data_dir(args.data)
    src = None if folder is None else folder.parent / "mts-actuator" / "0A.txt"
    if src is None or not src.exists():
        print("skipped: no mts-actuator/0A.txt under --data or RTHS_DATA")
        return 0
    import subprocess

    work = Path(tempfile.mkdtemp(prefix="score_mts_"))
    done = subprocess.run(
        [
            sys.executable,
            str(Path(__file__).parent / "mts_to_csv.py"),
            str(src),
            "--out",
            str(work / "rec_1.csv"),
        ],
        capture_output=True,
        text=True,
    )
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["(no message)"])[-1]
        print(f"score_diagnosis.py: error: converting {src} failed: {last}", file=sys.stderr)
        return 2
    nominal = (
        Path(__file__).resolve().parents[1]
        / "scenarios"
        / "nominal"
        / "nominal_mts_identified.toml"
    )
    (work / "NOMINAL.toml").write_text(nominal.read_text())
    (r,) = _run([(str(work), None)], args, "mts")
    print(
        f"== MTS record: verdict {r['verdict']}; effects "
        f"{'+'.join(e['name'] for e in r.get('effects', [])) or '-'}; gap "
        f"{r.get('gap')}; {r['seconds']:.1f} s"
    )
    if args.json:
        args.json.write_text(json.dumps(r, indent=1, default=str))
    return 0


def main(argv: list[str] | None = None) -> int:
    """Command line (module docstring); returns the exit code."""
    from friction_damper_data import OneLineParser

    p = OneLineParser(prog="score_diagnosis.py", description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="source", required=True)
    s = sub.add_parser("suite", help="a labelled suite (blind_suite or truthgen)")
    s.add_argument("dir", type=Path)
    s.add_argument("--limit", type=int, default=0, help="score only the first N cases")
    f = sub.add_parser("friction-damper", help="the real friction damper records")
    f.add_argument("--nominal", choices=("viscous", "coulomb"), default="coulomb")
    m = sub.add_parser("mts", help="the real MTS actuator record")
    for q in (s, f, m):
        q.add_argument("--data", help="folder holding friction-damper/ (default: $RTHS_DATA)")
        q.add_argument("--jobs", type=int, default=1, help="local worker processes (default 1)")
        q.add_argument("--scheduler", help="run on a Dask cluster (tcp://HOST:8786)")
        q.add_argument(
            "--table",
            type=Path,
            help="campaign table (.parquet or .csv) of the diagnoses: a rerun skips the cases "
            "it holds (delete it after changing the diagnosis code)",
        )
        q.add_argument("--json", type=Path, help="write the scores as JSON")
    args = p.parse_args(argv)
    if args.source == "suite" and not (args.dir / "labels.json").is_file():
        p.error(f"no labels.json in {args.dir}")
    if args.jobs < 1:
        p.error(f"--jobs must be >= 1; got {args.jobs}")
    if args.table is not None and args.table.suffix not in (".parquet", ".csv"):
        p.error(f"--table must end in .parquet or .csv; got {str(args.table)!r}")
    return {"suite": cmd_suite, "friction-damper": cmd_friction_damper, "mts": cmd_mts}[
        args.source
    ](args)


if __name__ == "__main__":
    sys.exit(main())
