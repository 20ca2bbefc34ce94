"""The ``rths`` command line.

Each sub-command lives in its own module under :mod:`rths.commands` (or one of its sub-packages,
grouped by concern) and exposes::

    def add_parser(subparsers) -> argparse.ArgumentParser   # registers the sub-command
    def run(args: argparse.Namespace) -> int                 # does the work, returns the exit code

Modules there are discovered automatically, so adding a command never touches this file.  Command
modules import their heavy dependencies inside ``run`` so that ``rths --help`` stays fast.

Exit codes (the README's table):

=====  ==============================================================================
0      done
1      a verdict against the input, not an error: ``rths check``'s bound exceeded
2      bad input: a usage error, a bad scenario, data file, parameter or path
3      a run-time fault: the specimen process crashed, hung or vanished, an interlock
       or a diverging model stopped the run, the disk filled up (the log is finished
       up to the fault)
128+N  stopped by signal N after a clean stop: 130 Ctrl-C (SIGINT), 143 SIGTERM, 129
       SIGHUP (the log is finished and carries the run's summary)
=====  ==============================================================================

Errors are one line on stderr, ``rths <command>: error: <what, naming the input>``, with no
traceback: any :class:`rths.core.errors.RTHSError` (exit 2, or 3 for a
:class:`rths.core.errors.RunFault`), ``OSError`` (a path that cannot be read or written: 2; a full
disk or an I/O error: 3) and argparse's usage errors (2).  Warnings raised while a command works
are held back: a command that fails prints only its error line; one that succeeds prints each
distinct warning after its work, one line each.
"""

from __future__ import annotations

import argparse
import errno
import importlib
import os
import pkgutil
import signal
import sys
import warnings
from collections.abc import Sequence
from types import ModuleType
from typing import NoReturn

import rths.commands
from rths import __version__
from rths.core.errors import Interrupted, RTHSError, RTHSWarning, RunFault

__all__ = [
    "EXIT_BAD_INPUT",
    "EXIT_FAILED",
    "EXIT_FAULT",
    "EXIT_OK",
    "build_parser",
    "console",
    "main",
]

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_BAD_INPUT = 2
EXIT_FAULT = 3

#: ``OSError`` numbers that are the machine's fault, not the path's: exit code 3.
_FAULT_ERRNOS = {errno.ENOSPC, errno.EDQUOT, errno.EIO, errno.EROFS}


class _Parser(argparse.ArgumentParser):
    """argparse with one-line usage errors (the usage is in ``--help``)."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser with every sub-command found in :mod:`rths.commands`."""
    parser = _Parser(
        prog="rths",
        description="Real-time hybrid simulation: run, replay, report, check, diagnose RTHS tests.",
    )
    parser.add_argument("--version", action="version", version=f"rths {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for module in _command_modules():
        p = module.add_parser(sub)
        p.set_defaults(handler=module.run)
    return parser


def _command_modules() -> list[ModuleType]:
    """Every sub-command module under :mod:`rths.commands`, sub-packages included, in the order
    of their names (``_``-prefixed modules are helpers)."""
    found = []
    for info in pkgutil.walk_packages(rths.commands.__path__, prefix="rths.commands."):
        if info.ispkg or info.name.rpartition(".")[2].startswith("_"):
            continue
        found.append(importlib.import_module(info.name))
    return sorted(found, key=lambda module: module.__name__.rpartition(".")[2])


def _one_line(exc: BaseException | Warning | str) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


def main(argv: Sequence[str] | None = None) -> int:
    """Run one command and return its exit code (see the module docstring); in process.

    Parameters
    ----------
    argv
        The arguments after ``rths`` (default: ``sys.argv[1:]``).
    """
    parser = build_parser()
    args = parser.parse_args(argv)
    name = f"rths {args.command}"
    with warnings.catch_warnings(record=True) as held:  # the interpreter's filters still apply
        try:
            code = int(args.handler(args) or 0)
        except RunFault as exc:
            print(f"{name}: error: {_one_line(exc)}", file=sys.stderr)
            return EXIT_FAULT
        except RTHSError as exc:
            print(f"{name}: error: {_one_line(exc)}", file=sys.stderr)
            return EXIT_BAD_INPUT
        except OSError as exc:  # a path that cannot be read or written: bad input, not a crash
            print(f"{name}: error: {_one_line(exc)}", file=sys.stderr)
            return EXIT_FAULT if exc.errno in _FAULT_ERRNOS else EXIT_BAD_INPUT
        except Interrupted as exc:
            print(f"{name}: interrupted by {exc}", file=sys.stderr)
            return 128 + exc.signum
        except KeyboardInterrupt:
            print(f"{name}: interrupted", file=sys.stderr)
            return 128 + signal.SIGINT
    seen = set()
    for w in held:
        text = f"{name}: warning: {_one_line(w.message)}"
        if not issubclass(w.category, RTHSWarning):
            text += f" ({w.filename}:{w.lineno})"
        if text not in seen:
            seen.add(text)
            print(text, file=sys.stderr)
    return code


def console() -> NoReturn:
    """The ``rths`` console script (and ``python -m rths``): :func:`main`, then exit at once.

    Every command finishes its files and closes its sessions before :func:`main` returns; what
    the interpreter's teardown would add is the collection of numba's, scipy's and zenoh's
    module graphs -- 1 to 2.5 s measured on a loaded 2-core machine, paid by a run that was
    asked to stop and by a coordinator waiting for its specimen process to exit.
    """
    code = main()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe (``rths kinds | head``)
            pass
    os._exit(code)


if __name__ == "__main__":  # pragma: no cover
    console()
