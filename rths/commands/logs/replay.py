"""``rths replay run.mcap [--speed x]``: republish a log on zenoh at its recorded pace."""

from __future__ import annotations

import argparse
from pathlib import Path

__all__ = ["add_parser", "run"]

#: zenoh's conventional port, so a monitor with zenoh's default settings can connect.
DEFAULT_LISTEN = "tcp/127.0.0.1:7447"


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``rths replay``.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``rths`` parser's sub-command group (``ArgumentParser.add_subparsers()``);
        the new sub-parser is returned.
    """
    p = subparsers.add_parser(
        "replay",
        help="republish a recorded run on zenoh at its recorded pace",
        description="Publish the rths/loop (and rths/specimen) records of an MCAP log on "
        "rths/<run-id>/log/<stream>, the keys a live run uses, paced by their log times.",
    )
    p.add_argument("log", type=Path, help="MCAP log written by 'rths run'")
    p.add_argument("--speed", type=float, default=1.0, help="pace multiplier (2 = twice as fast)")
    p.add_argument("--run-id", help="key prefix rths/<run-id>/ (default: the recorded run id)")
    p.add_argument(
        "--topic",
        action="append",
        default=None,
        metavar="TOPIC",
        help="topics to replay (default rths/loop and rths/specimen if present)",
    )
    p.add_argument(
        "--listen",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="zenoh endpoint to listen on for subscribers (default "
        f"{DEFAULT_LISTEN} when no --connect is given)",
    )
    p.add_argument(
        "--connect",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="zenoh endpoint of a subscriber/router to connect to",
    )
    p.add_argument(
        "--wait",
        type=float,
        default=0.0,
        metavar="S",
        help="wait this long for subscribers before publishing",
    )
    return p


def run(args: argparse.Namespace) -> int:
    """Republish the log; returns 0.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line of ``rths replay`` (the options :func:`add_parser`
        declares).
    """
    import math

    from rths.core.errors import DataError
    from rths.log.replay import prepare, replay
    from rths.wire.keys import check_run_id
    from rths.wire.transport import ZenohEndpoints

    if not args.speed > 0:
        raise DataError(f"--speed must be positive; got {args.speed!r}")
    if not (args.wait >= 0 and math.isfinite(args.wait)):
        raise DataError(f"--wait must be a number of seconds >= 0; got {args.wait!r}")
    if args.run_id is not None:
        check_run_id(args.run_id)
    prepare(args.log, args.topic)  # the log is checked before any endpoint is opened
    listen = tuple(args.listen) or (() if args.connect else (DEFAULT_LISTEN,))
    endpoints = ZenohEndpoints(listen=listen, connect=tuple(args.connect))
    count = replay(
        args.log, endpoints, speed=args.speed, run_id=args.run_id, topics=args.topic, wait=args.wait
    )
    print(f"replayed {count} records from {args.log}")
    return 0
