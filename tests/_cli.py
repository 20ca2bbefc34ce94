"""Run the ``rths`` CLI in this process the way a user's shell would see it.

:func:`run_cli` calls :func:`rths.cli.main` with stdout and stderr captured, argparse's
``SystemExit`` turned into its exit code, warnings shown on the captured stderr (as an
interpreter does by default, not recorded by pytest) and exceptions that escape any thread
printed there too -- so "one line on stderr" means what it means in a terminal.
"""

from __future__ import annotations

import contextlib
import io
import sys
import threading
import warnings
from dataclasses import dataclass

from rths.cli import main

__all__ = ["CliResult", "run_cli"]


@dataclass(frozen=True)
class CliResult:
    """Exit code and the captured streams of one ``rths`` invocation."""

    code: int
    out: str
    err: str

    @property
    def err_lines(self) -> list[str]:
        """Non-empty stderr lines."""
        return [line for line in self.err.splitlines() if line.strip()]


def run_cli(argv: list[str]) -> CliResult:
    """``rths *argv`` in process; see the module docstring."""
    out, err = io.StringIO(), io.StringIO()

    def show(message, category, filename, lineno, file=None, line=None):
        err.write(warnings.formatwarning(message, category, filename, lineno, line))

    def thread_hook(args: threading.ExceptHookArgs) -> None:
        err.write(
            f"Exception in thread {args.thread}: {args.exc_type.__name__}: {args.exc_value}\n"
        )

    previous_hook = threading.excepthook
    threading.excepthook = thread_hook
    try:
        with (
            warnings.catch_warnings(),
            contextlib.redirect_stdout(out),
            contextlib.redirect_stderr(err),
        ):
            warnings.resetwarnings()
            warnings.simplefilter("default")
            warnings.showwarning = show
            try:
                code = main(argv)
            except SystemExit as exc:  # argparse
                code = exc.code if isinstance(exc.code, int) else 1
            except BaseException as exc:  # what the interpreter would print
                err.write(f"Traceback (most recent call last):\n{type(exc).__name__}: {exc}\n")
                code = 1
    finally:
        threading.excepthook = previous_hook
    sys.stdout.flush()
    return CliResult(int(code), out.getvalue(), err.getvalue())
