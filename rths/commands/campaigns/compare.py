"""``rths compare``: every compensator on the vRTHS benchmark's cases, nominal and perturbed.

Prints, per compensator, the benchmark's evaluation table (F4's J1-J9, cases as columns) on the
nominal plant and the median / worst over the perturbed plants with interlocks and the actuator
force against its 8.9 kN capacity, then the worst J2 of every compensator and case and the wall
time; writes a figure of J2 per case (:mod:`rths.experiments.vrths`).  The trials run as a
campaign (:mod:`rths.campaign`): an embedded Dask cluster by default (``--workers``), or
``--scheduler``; one row per trial in ``--table`` (default
``runs/compare-<ground>-x<intensity>-p<N>-seed<S>.parquet``), and re-running the command resumes.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from rths.commands._campaign import add_options, cluster, summary_line

__all__ = ["add_parser", "run"]


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``rths compare``.

    Parameters
    ----------
    subparsers
        The ``rths`` sub-command parsers.
    """
    from rths.experiments.vrths.compare import COMPENSATORS

    p = subparsers.add_parser(
        "compare",
        help="every compensator on the vRTHS benchmark's 4 cases x (nominal + perturbed plants)",
        description="Run every compensator on the vRTHS benchmark (Silva et al. 2020): its four "
        "partitioning cases, the nominal plant and N perturbed ones, scored with its own J1-J9 "
        "(F4_evaluation.m). Records need the benchmark package (RTHS_VRTHS_PACKAGE, RTHS_DATA or "
        "--package); --ground chirp runs without it.",
    )
    p.add_argument(
        "--compensators",
        nargs="+",
        default=list(COMPENSATORS),
        metavar="KIND",
        help=f"kinds to compare (default: {' '.join(COMPENSATORS)})",
    )
    p.add_argument("--cases", nargs="+", type=int, default=[1, 2, 3, 4], help="cases (1-4)")
    p.add_argument(
        "--ground",
        default="el_centro",
        choices=("el_centro", "kobe", "morgan", "chirp"),
        help="ground motion (default el_centro)",
    )
    p.add_argument("--perturbed", type=int, default=20, help="perturbed plants per case (20)")
    p.add_argument("--intensity", type=float, default=0.4, help="eq_intensity (0.4)")
    p.add_argument("--seed", type=int, default=123, help="seed of the draws and the noise (123)")
    p.add_argument(
        "--package",
        help="benchmark package (default $RTHS_VRTHS_PACKAGE, else $RTHS_DATA/vrths-benchmark)",
    )
    p.add_argument("--json", type=Path, metavar="OUT", help="write every trial's result as JSON")
    p.add_argument(
        "--figure", type=Path, default=Path("vrths_j2.png"), help="J2 figure (vrths_j2.png)"
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_options(p)
    return p


def run(args: argparse.Namespace) -> int:
    """Run the comparison and print its tables; 0 (1 if some trials failed).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line of ``rths compare`` (the options :func:`add_parser`
        declares).
    """
    from rths.campaign import ResultTable
    from rths.core.errors import ConfigError
    from rths.experiments.vrths.compare import run_comparison
    from rths.experiments.vrths.tables import plot_j2, render

    if args.perturbed < 0:
        raise ConfigError(f"--perturbed must be >= 0; got {args.perturbed!r}")
    where = cluster(args)
    path = args.table or Path("runs") / (
        f"compare-{args.ground}-x{args.intensity:g}-p{args.perturbed}-seed{args.seed}.parquet"
    )
    table = ResultTable(path)
    comparison = run_comparison(
        args.compensators,
        args.cases,
        ground=args.ground,
        perturbed=args.perturbed,
        intensity=args.intensity,
        seed=args.seed,
        package=args.package,
        cluster=where,
        table=table,
        progress=not args.no_progress,
        retry_failed=args.retry_failed,
    )
    print(render(comparison))
    print(f"J2 figure -> {plot_j2(comparison, args.figure)}")
    if args.json is not None:
        args.json.write_text(json.dumps(comparison.to_dict(), indent=1, default=float))
        print(f"results -> {args.json}")
    stats = comparison.stats
    assert stats is not None
    print(summary_line(stats, table, where, comparison.keys))
    if stats.failed:
        print(
            f"rths compare: {stats.failed} trial(s) failed (rows with status = error; "
            "--retry-failed runs them again)",
            file=sys.stderr,
        )
        return 1
    return 0
