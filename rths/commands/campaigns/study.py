"""``rths study SCENARIO``: a parameter study over scenario keys, as a campaign.

Examples::

    rths study scenarios/study_imd_mode3.toml               # the file's [study] table
    rths study scenarios/study_imd_mode3.toml \\
        --vary specimen.inertance,model.inertance=200:2400:8 \\
        --vary specimen.damping,model.damping=4000,8841
    rths study scenarios/study_imd_mode3.toml --sampling lhs --samples 20 \\
        --vary specimen.inertance,model.inertance=200:2400 --vary specimen.damping=2000:12000

Every point runs as an RTHS on the fast clock (:mod:`rths.analysis.study`): tracking, the peak
midspan displacement while loaded, the modal damping of the free decay after the load stops,
the same from the fully numerical run, and the exact frequency equation's damping (``rths
damping``).  Writes the table (default ``runs/<name>-study.parquet``; re-run to resume) and the
figures ``<table>_damping.png`` and ``<table>_peak.png``; prints one line per point.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from rths.commands._campaign import add_options, cluster, summary_line

__all__ = ["add_parser", "run"]


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``rths study``.

    Parameters
    ----------
    subparsers
        The ``rths`` sub-command parsers.
    """
    p = subparsers.add_parser(
        "study",
        help="parameter study (grid or Latin hypercube over scenario keys) as a campaign",
        description="Parameter study: a grid or Latin hypercube over scenario keys, every point "
        "an RTHS on the fast clock, run as a campaign; the table (default "
        "runs/<name>-study.parquet; re-run to resume) and figures of the free-decay modal "
        "damping against the exact frequency equation and of the peak midspan displacement.",
        epilog="--vary KEY[,KEY...]=SPEC: SPEC is v1,v2,... or lo:hi:n (grid) or lo:hi (Latin "
        "hypercube), with :log for geometric spacing; keys joined by commas take the same value.",
    )
    p.add_argument("scenario", type=Path, metavar="SCENARIO", help="scenario TOML")
    p.add_argument(
        "--vary", action="append", default=[], metavar="SPEC", help="a varied key (repeatable)"
    )
    p.add_argument("--sampling", choices=("grid", "lhs"), help="default: [study] or grid")
    p.add_argument("--samples", type=int, metavar="N", help="Latin hypercube points")
    p.add_argument("--seed", type=int, metavar="S", help="Latin hypercube seed")
    p.add_argument("--compensator", metavar="KIND", help="override the scenario's compensator")
    p.add_argument(
        "--no-numerical", action="store_true", help="skip the fully numerical twin of each point"
    )
    p.add_argument("--no-figures", action="store_true", help="no figures")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true", help="print the rows as JSON")
    add_options(p)
    return p


def _cell(x: Any, scale: float = 1.0, fmt: str = ".4f") -> str:
    return "-" if x is None else format(scale * x, fmt)


def run(args: argparse.Namespace) -> int:
    """Run the study, write the table and figures, print a summary; 0.

    Parameters
    ----------
    args
        Parsed options.
    """
    from controllers.factory import kinds
    from rths.analysis.study import campaign, plan
    from rths.campaign import ResultTable, execute
    from rths.config.scenario import load_scenario
    from rths.core.errors import ConfigError, format_choices

    scn = load_scenario(args.scenario)
    if args.compensator is not None and args.compensator not in kinds():
        raise ConfigError(
            f"--compensator must be one of {format_choices(list(kinds()))}; "
            f"got {args.compensator!r}"
        )
    study = plan(scn, args.vary, args.sampling, args.samples, args.seed)
    c = campaign(scn, study, args.compensator, numerical=not args.no_numerical)
    where = cluster(args)
    path = args.table or Path("runs") / f"{scn.run.name}-study.parquet"
    table = ResultTable(path)
    stats = execute(c, table, where, progress=not args.no_progress, retry_failed=args.retry_failed)
    keys = [r.key for r in c.runs]
    rows = table.rows(keys)
    figures = []
    if not args.no_figures and rows:
        from rths.analysis.study_figures import study_figures

        figures = study_figures(scn, study, rows, path.with_name(path.stem))
    if args.json:
        print(
            json.dumps({"table": str(path), "digest": table.digest(keys), "rows": rows}, indent=2)
        )
        return 0
    labels = [v.label for v in study.varies]
    head = "".join(f"{k[-22:]:>23}" for k in labels)
    print(
        f"{head} {'status':>9} {'J2 %':>7} {'zeta1 %':>7} {'zeta2 %':>7} {'num1 %':>8}"
        f" {'exact %':>13} {'peak mm':>8}"
    )
    for r in rows:
        cells = "".join(f"{r[k]!s:>23}"[:23].rjust(23) for k in labels)
        lo, hi = r.get("zeta_exact_min"), r.get("zeta_exact_max")
        exact = (
            "-" if lo is None or hi is None else f"{_cell(lo, 100, '.3f')}-{_cell(hi, 100, '.3f')}"
        )
        print(
            f"{cells} {r['status']!s:>9} {_cell(r.get('j2'), 100, '.3f'):>7}"
            f" {_cell(r.get('zeta_1'), 100, '.3f'):>7} {_cell(r.get('zeta_2'), 100, '.3f'):>7}"
            f" {_cell(r.get('zeta_numerical_1'), 100, '.3f'):>8}"
            f" {exact:>13} {_cell(r.get('peak_midspan_m'), 1e3, '.2f'):>8}"
        )
    line = summary_line(stats, table, where, keys)
    print(line + ("" if not figures else "; figures " + ", ".join(str(f) for f in figures)))
    return 0
