"""``rths recover LOG [--out FILE]``: rewrite an unfinished or damaged log as a finished one."""

from __future__ import annotations

import argparse
from pathlib import Path

__all__ = ["add_parser", "run"]


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``rths recover``.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``rths`` parser's sub-command group (``ArgumentParser.add_subparsers()``);
        the new sub-parser is returned.
    """
    p = subparsers.add_parser(
        "recover",
        help="rewrite the log of a killed run (no footer, or a corrupt chunk) as a finished log",
        description="Copy every whole record of an MCAP log -- up to where a killed run or a "
        "full disk cut it, skipping chunks that fail their checks -- into a finished log the "
        "plain mcap reader reads, with an rths.recovered metadata record (and an rths.summary "
        "computed from the recovered loop records when the cut cost the run its own).",
    )
    p.add_argument("log", type=Path, help="the MCAP log to recover (never modified)")
    p.add_argument("--out", type=Path, help="the finished copy (default <log stem>.recovered.mcap)")
    return p


def run(args: argparse.Namespace) -> int:
    """Write the finished copy; print one line saying what was kept.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line of ``rths recover`` (the options :func:`add_parser`
        declares).
    """
    from rths.log.recover import recover

    out = args.out or args.log.with_name(f"{args.log.stem}.recovered.mcap")
    r = recover(args.log, out)
    if r.finished:
        state = "the log was already finished; copied"
    else:
        dropped = f", dropped {r.bad_chunks} corrupt chunk(s)" if r.bad_chunks else ""
        orphans = f" and {r.orphans} message(s) of their channels" if r.orphans else ""
        state = (
            f"read {r.bytes_read} of {r.size} bytes{dropped}{orphans}; kept {r.messages} "
            f"messages up to t = {r.last_time:.6f} s"
        )
    print(f"{state} -> {out}")
    return 0
