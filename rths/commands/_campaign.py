"""Options shared by the commands that run campaigns (``run --monte-carlo``, ``study``,
``sweep``): where to run, the results table, progress."""

from __future__ import annotations

import argparse
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rths.campaign import CampaignStats, Cluster, ResultTable

__all__ = ["add_options", "cluster", "summary_line"]


def add_options(p: argparse.ArgumentParser, table: bool = True) -> None:
    """Add ``--workers``, ``--scheduler``, ``--in-process`` (and ``--table``,
    ``--retry-failed``) to a command's parser.

    Parameters
    ----------
    p
        The command's parser.
    table
        Also the table options.
    """
    g = p.add_argument_group("campaign (Dask)")
    g.add_argument(
        "--workers",
        type=int,
        metavar="N",
        help="worker processes of the embedded cluster (default: one per core)",
    )
    g.add_argument(
        "--scheduler",
        metavar="ADDR",
        help="run on an existing Dask cluster, e.g. tcp://HOST:8786 (workers need rths installed)",
    )
    g.add_argument(
        "--in-process",
        action="store_true",
        help="embedded workers as threads of this process (quick start, one core: small runs)",
    )
    if table:
        g.add_argument(
            "--table",
            type=Path,
            metavar="FILE",
            help="results table, .parquet or .csv (one row per run; runs already in it are "
            "skipped: re-run the command to resume); figures are written beside it",
        )
        g.add_argument(
            "--retry-failed",
            action="store_true",
            help="run again the runs whose rows say status = error",
        )


def cluster(args: argparse.Namespace) -> Cluster:
    """The :class:`rths.campaign.Cluster` of the options.

    Parameters
    ----------
    args
        Parsed options (:func:`add_options`).
    """
    from rths.campaign import Cluster
    from rths.core.errors import ConfigError

    if args.workers is not None and args.workers < 1:
        raise ConfigError(f"--workers must be >= 1; got {args.workers}")
    if args.scheduler and (args.workers is not None or args.in_process):
        raise ConfigError("--scheduler runs on that cluster: drop --workers/--in-process")
    return Cluster(args.scheduler, args.workers, processes=not args.in_process)


def summary_line(
    stats: CampaignStats, table: ResultTable, where: Cluster, keys: Iterable[str]
) -> str:
    """``N runs (R already in the table, F failed) ran ... in T s; table PATH; digest D``.

    Parameters
    ----------
    stats
        What :func:`rths.campaign.execute` did.
    table
        The results table.
    where
        Where the campaign ran.
    keys
        The campaign's run keys: the digest covers their rows (equal digests: bit-identical
        results).
    """
    parts = [f"{stats.total} runs"]
    extra = []
    if stats.skipped:
        extra.append(f"{stats.skipped} already in the table")
    if stats.failed:
        extra.append(f"{stats.failed} failed")
    if extra:
        parts.append("(" + ", ".join(extra) + ")")
    if stats.ran:
        parts.append(f"ran {stats.ran} on {where.describe()} in {stats.wall:.1f} s")
    text = " ".join(parts)
    if table.path is not None:
        text += f"; table {table.path}"
    return text + f"; digest {table.digest(keys)[:16]}"
