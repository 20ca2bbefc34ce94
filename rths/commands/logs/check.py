"""``rths check run.mcap --max-rmse PCT``: gate a CI job on a run's synchronisation error.

Exit codes: 0 the sync-subspace RMSE is within the bound and the run is whole (it ran all its
steps, the log is finished, no sample is missing -- gaps are allowed with ``--allow-gaps``); 1 it
is not; 2 the log cannot be used (missing file, not an RTHS log).
"""

from __future__ import annotations

import argparse
from pathlib import Path

__all__ = ["add_parser", "run"]


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``rths check``.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``rths`` parser's sub-command group (``ArgumentParser.add_subparsers()``);
        the new sub-parser is returned.
    """
    p = subparsers.add_parser(
        "check",
        help="exit non-zero when a run's sync-subspace RMSE exceeds a bound (for CI)",
        description="Read the rths/loop topic of an MCAP log written by 'rths run' and compare "
        "the synchronisation-subspace RMSE = RMS(measured - target)/RMS(target) with a bound.",
    )
    p.add_argument("log", type=Path, help="MCAP log written by 'rths run'")
    p.add_argument(
        "--max-rmse",
        type=float,
        required=True,
        metavar="PCT",
        help="largest acceptable sync-subspace RMSE [%%]",
    )
    p.add_argument(
        "--from",
        dest="start",
        type=float,
        default=0.0,
        metavar="S",
        help="ignore the record before this time [s] (start-up transient)",
    )
    p.add_argument(
        "--allow-gaps",
        action="store_true",
        help="do not fail on missing loop samples (sequence gaps)",
    )
    return p


def run(args: argparse.Namespace) -> int:
    """Compare the log's sync-subspace RMSE with the bound; 0 pass, 1 fail.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line of ``rths check`` (the options :func:`add_parser`
        declares).
    """
    import math

    import numpy as np

    from rths.core.errors import DataError
    from rths.log.reader import is_complete, read_loop, read_metadata
    from rths.metrics import sync_subspace_rmse

    if not (math.isfinite(args.max_rmse) and args.max_rmse > 0):
        raise DataError(f"--max-rmse must be a positive percentage; got {args.max_rmse!r}")
    if not math.isfinite(args.start):
        raise DataError(f"--from must be a time in seconds; got {args.start!r}")
    loop = read_loop(args.log, ("t", "target", "measured"))
    meta = read_metadata(args.log)
    seq = loop["sequence"]
    gaps = int(np.sum(np.diff(seq) - 1)) if seq.size > 1 else 0
    keep = loop["t"] >= args.start
    if np.count_nonzero(keep) < 16:
        raise DataError(f"'{args.log}': fewer than 16 loop samples after t = {args.start} s")
    rmse = 100.0 * sync_subspace_rmse(loop["target"][keep], loop["measured"][keep])
    problems = []
    if rmse > args.max_rmse:
        problems.append(f"RMSE above {args.max_rmse:g} %")
    if gaps and not args.allow_gaps:
        problems.append(f"{gaps} missing samples")
    stopped = meta.get("rths.summary", {}).get("stopped")
    if stopped:
        problems.append(f"run stopped early ({stopped})")
    expected = meta.get("run", {}).get("steps")
    if expected is not None and loop["t"].size + gaps < int(expected):
        problems.append(f"{loop['t'].size} of {expected} steps recorded")
    if not is_complete(args.log):
        problems.append("log not finished (the run was cut off)")
    verdict = "FAIL: " + "; ".join(problems) if problems else "PASS"
    print(
        f"{verdict} -- sync-subspace RMSE {rmse:.3f} % (bound {args.max_rmse:g} %), "
        f"{int(np.count_nonzero(keep))} samples, {gaps} gaps -- {args.log}"
    )
    return 1 if problems else 0
