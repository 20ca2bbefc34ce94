"""The project's exception hierarchy and the small validators every module uses.

Every error a user can cause by bad input derives from :class:`RTHSError`; the CLI turns it into
a one-line message and exit code 2.  A :class:`RunFault` is not the input's fault but the run's
(the specimen process lost, the disk full): also one line, exit code 3.  Messages name the input
and carry the offending value, e.g.
``ParameterError("cable tension T must be positive; got -3.0")``.
"""

from __future__ import annotations

import math
import signal
from collections.abc import Sequence

__all__ = [
    "ConfigError",
    "DataError",
    "Interrupted",
    "NumericalError",
    "ParameterError",
    "RTHSError",
    "RTHSWarning",
    "RunFault",
    "TransportError",
    "check_finite",
    "check_in_range",
    "check_nonnegative",
    "check_positive",
    "check_positive_int",
    "format_choices",
]


class RTHSError(Exception):
    """Base class of every error the framework raises on purpose."""


class RTHSWarning(UserWarning):
    """Something a user should know that does not stop the command (e.g. an unfinished log was
    read up to its cut); the CLI prints it as one line after the command's output."""


class ParameterError(RTHSError, ValueError):
    """A model or function parameter is out of its physical or numerical range."""


class ConfigError(RTHSError, ValueError):
    """A scenario or nominal-model file is malformed (names the file, key and value)."""


class DataError(RTHSError, ValueError):
    """A data file (CSV, MCAP) cannot be used: missing columns, non-uniform sampling, ..."""


class NumericalError(RTHSError, RuntimeError):
    """A numerical method failed (a root finder did not converge, a run diverged)."""


class RunFault(RTHSError, RuntimeError):
    """A run could not go on for a reason found while it ran -- the specimen process crashed,
    hung or vanished, the disk filled up -- rather than in its input (the CLI's exit code 3)."""


class TransportError(RunFault):
    """The zenoh link to a peer failed or timed out."""


class Interrupted(KeyboardInterrupt):
    """A stop signal (SIGINT, SIGTERM, SIGHUP) ended a command before it could stop on its own
    terms; the CLI exits with ``128 + signum``.

    Parameters
    ----------
    signum
        The signal's number, e.g. ``signal.SIGTERM``.
    """

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def check_finite(value: float, name: str) -> float:
    """Return ``float(value)`` or raise :class:`ParameterError` naming ``name``.

    Parameters
    ----------
    value : float
        The number to check (anything ``float()`` accepts), in the caller's unit.
    name : str
        What the value is, with its symbol, for the message (e.g. ``"cable tension T"``).

    Raises
    ------
    ParameterError
        If ``value`` is not a number or not finite.
    """
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a number; got {value!r}") from None
    if not math.isfinite(x):
        raise ParameterError(f"{name} must be finite; got {value!r}")
    return x


def check_positive(value: float, name: str) -> float:
    """Return ``float(value)`` if it is finite and > 0, else raise :class:`ParameterError`.

    Parameters
    ----------
    value : float
        The number to check (anything ``float()`` accepts), in the caller's unit.
    name : str
        What the value is, with its symbol, for the message (e.g. ``"cable tension T"``).
    """
    x = check_finite(value, name)
    if x <= 0.0:
        raise ParameterError(f"{name} must be positive; got {value!r}")
    return x


def check_nonnegative(value: float, name: str) -> float:
    """Return ``float(value)`` if it is finite and >= 0, else raise :class:`ParameterError`.

    Parameters
    ----------
    value : float
        The number to check (anything ``float()`` accepts), in the caller's unit.
    name : str
        What the value is, with its symbol, for the message (e.g. ``"cable tension T"``).
    """
    x = check_finite(value, name)
    if x < 0.0:
        raise ParameterError(f"{name} must be non-negative; got {value!r}")
    return x


def check_positive_int(value: int, name: str) -> int:
    """Return ``value`` if it is an integer >= 1, else raise :class:`ParameterError`.

    Parameters
    ----------
    value : int
        The count to check; a ``bool`` or a float (even ``2.0``) is refused.
    name : str
        What the value is, for the message (e.g. ``"number of elements"``).
    """
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ParameterError(f"{name} must be a positive integer; got {value!r}")
    return value


def check_in_range(value: float, name: str, lo: float, hi: float) -> float:
    """Return ``float(value)`` if ``lo <= value <= hi``, else raise :class:`ParameterError`.

    Parameters
    ----------
    value : float
        The number to check (anything ``float()`` accepts), in the caller's unit.
    name : str
        What the value is, with its symbol, for the message (e.g. ``"cable tension T"``).
    lo, hi : float
        Inclusive bounds, in the unit of ``value``.
    """
    x = check_finite(value, name)
    if not lo <= x <= hi:
        raise ParameterError(f"{name} must lie in [{lo}, {hi}]; got {value!r}")
    return x


def format_choices(choices: Sequence[str]) -> str:
    """``['a', 'b']`` -> ``"'a', 'b'"`` for error messages listing valid names.

    Parameters
    ----------
    choices : sequence of str
        The valid names, in the order to list them.
    """
    return ", ".join(repr(c) for c in choices)
