"""The ``rths`` command line.

Each sub-command lives in its own module under :mod:`rths.commands` and exposes::

    def add_parser(subparsers) -> argparse.ArgumentParser   # registers the sub-command
    def run(args: argparse.Namespace) -> int                 # does the work, returns the exit code

Modules there are discovered automatically, so adding a command never touches this file.  Command
modules import their heavy dependencies inside ``run`` so that ``rths --help`` stays fast.

Errors: any :class:`rths.core.errors.RTHSError` (bad scenario, bad data, bad parameter) or
``OSError`` (a path that cannot be read or written) becomes one line on stderr and exit code 2, with
no traceback; argparse usage errors also exit with 2.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys
from collections.abc import Sequence

import rths.commands
from rths import __version__
from rths.core.errors import RTHSError

__all__ = ["build_parser", "main"]


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser with every sub-command found in :mod:`rths.commands`."""
    parser = argparse.ArgumentParser(
        prog="rths",
        description="Real-time hybrid simulation: run, replay, report, check, diagnose RTHS tests.",
    )
    parser.add_argument("--version", action="version", version=f"rths {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for info in sorted(pkgutil.iter_modules(rths.commands.__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"rths.commands.{info.name}")
        p = module.add_parser(sub)
        p.set_defaults(handler=module.run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``rths`` console script; returns the process exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.handler(args) or 0)
    except RTHSError as exc:
        print(f"rths {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:  # a path that cannot be read or written: bad input, not a crash
        print(f"rths {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"rths {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
