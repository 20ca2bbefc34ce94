"""``rths sweep``: stepped-sine shake-table emulation of the S1 TMDI specimens, FRFs per S1 Eq.7.

Examples::

    rths sweep scenarios/tmdi_shake_table.toml
    rths sweep scenarios/tmdi_shake_table.toml --pga 0.1 --out out/ --json

Runs every model of the scenario up and down at each PGA -- each PGA and direction a task on an
embedded Dask cluster (or ``--scheduler``'s; :mod:`rths.experiments.s1_shake_table.sweep`) --
and writes into ``--out`` (default ``<scenario
name>_sweep``):

``frf.csv``       the normalised FRFs of every run
(:func:`rths.experiments.s1_shake_table.report.frf_table`); ``frf.json``      the same as JSON
arrays per run (:func:`rths.experiments.s1_shake_table.report.frf_records`); ``summary.json``
resonance frequencies, peak-displacement changes, ideal-vs-rack NRMSE and the
                  wall time (:func:`rths.experiments.s1_shake_table.report.summarise`);
``*.png``         the figures of :mod:`rths.experiments.s1_shake_table.report` (unless
``--no-figures``).

It prints a short table, or with ``--json`` the summary as JSON on stdout.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
from pathlib import Path
from typing import Any

from rths.commands._campaign import add_options, cluster

__all__ = ["add_parser", "run"]


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``rths sweep``.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``rths`` parser's sub-command group (``ArgumentParser.add_subparsers()``);
        the new sub-parser is returned.
    """
    p = subparsers.add_parser(
        "sweep",
        help="stepped-sine shake-table emulation of the S1 TMDI specimens (FRFs, figures)",
        description=__doc__.split("\n\n", 1)[0],
    )
    p.add_argument("scenario", metavar="SCENARIO", help="shake-table scenario TOML")
    p.add_argument(
        "--pga",
        type=float,
        nargs="+",
        metavar="G",
        help="peak table accelerations [g] (overrides the scenario's)",
    )
    p.add_argument("--out", metavar="DIR", help="output directory (default <name>_sweep)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_options(p, table=False)
    return p


def _percent(x: float | None) -> str:
    return "-" if x is None else f"{100.0 * x:+.1f} %"


def _hz(x: float | None) -> str:
    return "-" if x is None else f"{x:.2f}"


def _print_table(summary: dict[str, Any]) -> None:
    print(
        f"{summary['scenario']}: wall time {summary['wall_time_s']:.2f} s, "
        f"{len(summary['grid_hz'])} frequency steps"
    )
    print(
        f"{'PGA':>6} {'model':<14}{'dir':<6}{'f0/f1 [Hz]':>11}{'f2 [Hz]':>9}"
        f"{'max H_uI [s2]':>15}{'u_I [mm]':>10}{'vs PS':>10}"
    )
    for pga, entry in summary["pga"].items():
        for model, by_dir in entry["resonances"].items():
            for d, r in by_dir.items():
                change = entry["ps_peak_change"].get(model, {}).get(d)
                first = r.get("f0", r.get("f1"))
                print(
                    f"{pga:>6} {model:<14}{d:<6}{_hz(first):>11}{_hz(r.get('f2')):>9}"
                    f"{r['peak_H_u_I']:>15.5f}{1e3 * r['peak_u_I']:>10.2f}"
                    f"{_percent(change):>10}"
                )
        s1 = entry.get("s1", {})
        if s1:
            cells = []
            if "ps_peak_u_I" in s1:
                cells.append(f"PS peak u_I {1e3 * s1['ps_peak_u_I']:g} mm")
            if "f0" in s1:
                cells.append(f"f0 {s1['f0']:g} Hz")
            if "ps_peak_change" in s1:
                cells.append(f"TMDI vs PS {_percent(s1['ps_peak_change'])}")
            print(f"{pga:>6} S1 reports: {', '.join(cells)}")
        for d, channels in entry["nrmse_ideal_vs_rack_pinion"].items():
            joined = ", ".join(
                f"{ch} {100 * v['full']:.0f}/{100 * v['near_f1']:.0f}" for ch, v in channels.items()
            )
            print(f"{pga:>6} NRMSE ideal vs rack, {d} (full/near f1, %): {joined}")


def run(args: argparse.Namespace) -> int:
    """Run the sweep, write the outputs, print the summary; returns 0.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line of ``rths sweep`` (the options :func:`add_parser`
        declares).
    """
    from rths.experiments.s1_shake_table.report import (
        frf_records,
        frf_table,
        summarise,
        write_figures,
    )
    from rths.experiments.s1_shake_table.sweep import load_sweep, run_sweep

    config = load_sweep(args.scenario)
    result = run_sweep(
        config, pga=args.pga, progress=not args.quiet and sys.stderr.isatty(), cluster=cluster(args)
    )
    out = Path(args.out if args.out else f"{config.name}_sweep")
    out.mkdir(parents=True, exist_ok=True)
    header, rows = frf_table(result)
    with open(out / "frf.csv", "w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f)
        writer.writerow(header)
        writer.writerows(rows)
    (out / "frf.json").write_text(json.dumps(frf_records(result)), encoding="utf-8")
    summary = summarise(result)
    (out / "summary.json").write_text(json.dumps(summary, indent=2), encoding="utf-8")
    if not args.no_figures:
        write_figures(result, out)
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        _print_table(summary)
        print(
            f"wrote {out / 'frf.csv'}, {out / 'frf.json'}, {out / 'summary.json'}"
            + ("" if args.no_figures else " and figures")
        )
    return 0
