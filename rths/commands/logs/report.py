"""``rths report run.mcap [--out DIR]``: metrics (JSON) and the seed paper's figures."""

from __future__ import annotations

import argparse
from pathlib import Path

__all__ = ["add_parser", "run"]


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``rths report``.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``rths`` parser's sub-command group (``ArgumentParser.add_subparsers()``);
        the new sub-parser is returned.
    """
    p = subparsers.add_parser(
        "report",
        help="write metrics.json and figures (time history, sync subspace, RTHS vs mock)",
        description="Reads an MCAP log written by 'rths run' and writes metrics.json, "
        "time_history.png (S0 Fig.32), sync_subspace.png (Fig.33) and rths_vs_mock.png (Fig.34).",
    )
    p.add_argument("log", type=Path, help="MCAP log written by 'rths run'")
    p.add_argument("--out", type=Path, help="output directory (default <log>.report/)")
    p.add_argument(
        "--cycles",
        type=float,
        default=3.0,
        help="steady-state cycles of the load shown in the figures",
    )
    p.add_argument("--no-mock", action="store_true", help="skip the fully numerical mock runs")
    return p


def run(args: argparse.Namespace) -> int:
    """Write metrics.json and the figures; returns 0.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line of ``rths report`` (the options :func:`add_parser`
        declares).
    """
    from rths.analysis.report import write_report
    from rths.core.errors import DataError

    if not args.cycles > 0:
        raise DataError(f"--cycles must be positive; got {args.cycles!r}")
    out = args.out or args.log.with_suffix(".report")
    doc = write_report(args.log, out, cycles=args.cycles, mock=not args.no_mock)
    tr = doc["tracking"]
    bench = doc.get("benchmark")
    if bench is not None:
        js = ", ".join(f"{k} {bench[k]:g}" for k in (f"J{i}" for i in range(1, 10)))
        force = bench.get("peak_actuator_force")
        cap = "" if force is None else f", max|F_a| {force / 1e3:.2f} kN (capacity 8.9)"
        print(f"vRTHS benchmark (F4): {js} (J1 ms, J2-J9 %){cap}")
        print(  # the project's own metrics: RMS-based, sub-sample delay, not rounded
            f"project metrics: delay {1e3 * tr['j1_delay']:.3f} ms, NRMS {100 * tr['j2']:.3f} %, "
            f"peak {100 * tr['j3']:.3f} % -> {out}/"
        )
        return 0
    print(
        f"J1 {1e3 * tr['j1_delay']:.3f} ms, J2 {100 * tr['j2']:.3f} %, "
        f"J3 {100 * tr['j3']:.3f} %, sync RMSE {100 * tr['sync_rmse']:.3f} % -> {out}/"
    )
    return 0
