"""``rths specimen SCENARIO``: serve the scenario's emulated lab over zenoh."""

from __future__ import annotations

import argparse
from pathlib import Path

__all__ = ["add_parser", "run"]


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``rths specimen``.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``rths`` parser's sub-command group (``ArgumentParser.add_subparsers()``);
        the new sub-parser is returned.
    """
    p = subparsers.add_parser(
        "specimen",
        help="serve the emulated lab (actuator + specimen + converters) over zenoh",
        description="The specimen process. 'rths run' starts it on loopback by default; start it "
        "yourself with --connect (or --listen) to put the lab on another host.",
    )
    p.add_argument(
        "scenario",
        type=Path,
        help="scenario TOML file (the same as the coordinator's); '-' reads it from stdin",
    )
    p.add_argument("--run-id", required=True, help="the coordinator's run id")
    p.add_argument(
        "--connect",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="coordinator endpoint, e.g. tcp/127.0.0.1:7447",
    )
    p.add_argument(
        "--listen",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="endpoint to listen on instead",
    )
    p.add_argument("--clock", choices=("lockstep", "realtime"), default="lockstep")
    p.add_argument("--ready-timeout", type=float, default=30.0, metavar="S")
    p.add_argument(
        "--seed", type=int, help="noise seed (default: the scenario's; 'rths run' passes its own)"
    )
    secret = p.add_mutually_exclusive_group()
    secret.add_argument(
        "--secret-file",
        type=Path,
        metavar="FILE",
        help="the run secret (hex, mode 600) written by 'rths run --external-specimen'; "
        "default: the environment variable RTHS_RUN_SECRET",
    )
    secret.add_argument(
        "--secret-stdin",
        action="store_true",
        help="read the run secret from standard input (how 'rths run' starts this process)",
    )
    return p


def run(args: argparse.Namespace) -> int:
    """Serve the lab until the coordinator stops; returns 0.

    SIGTERM and SIGHUP end it as Ctrl-C does (:class:`rths.core.errors.Interrupted`: its zenoh
    session closes, the coordinator sees it leave).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line of ``rths specimen`` (the options :func:`add_parser`
        declares).
    """
    import signal
    import sys

    from rths.config.scenario import load_scenario, parse_scenario
    from rths.core.errors import ConfigError, Interrupted
    from rths.session.specimen import serve
    from rths.wire.auth import read_secret
    from rths.wire.keys import check_run_id
    from rths.wire.transport import ZenohEndpoints

    def interrupted(signum: int, frame: object) -> None:
        raise Interrupted(signum)

    for sig in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, interrupted)
    if not args.connect and not args.listen:
        raise ConfigError("give the coordinator's endpoint with --connect (or --listen)")
    check_run_id(args.run_id)
    if args.seed is not None and args.seed < 0:
        raise ConfigError(f"--seed must be >= 0; got {args.seed}")
    # stdin holds the secret's line first, then (scenario '-') the scenario text
    secret = read_secret(args.secret_file, stdin=args.secret_stdin)
    if str(args.scenario) == "-":
        scn = parse_scenario(sys.stdin.read(), "<scenario on stdin>")
    else:
        scn = load_scenario(args.scenario)
    endpoints = ZenohEndpoints(listen=tuple(args.listen), connect=tuple(args.connect))
    serve(
        scn,
        args.run_id,
        endpoints,
        args.clock,
        ready_timeout=args.ready_timeout,
        seed=args.seed,
        secret=secret,
    )
    return 0
