"""What a campaign is: independent runs, each with a stable key, its inputs and a payload.

The task is a top-level function (so worker processes on any host can import it by name) called
once per run with the run's payload; it returns the run's results as a flat ``dict`` of scalars
(one table row).  A run's key is derived from everything that determines its result
(:func:`run_key`): the same inputs give the same key in every invocation, which is what lets a
campaign resume by skipping the keys its table already holds.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from rths.core.errors import ParameterError

__all__ = ["Campaign", "Run", "Scalar", "Task", "check_scalar", "run_key"]

#: A table cell: what a row may hold (Parquet and CSV both store these).
Scalar = bool | int | float | str | None

#: A campaign's task: payload -> row of results.
Task = Callable[[Any], dict[str, Scalar]]


def check_scalar(value: Any, name: str) -> Scalar:
    """``value`` if it can be a table cell, else :class:`ParameterError` naming ``name``.

    Parameters
    ----------
    value
        The candidate cell.
    name
        What it is (named in the error).
    """
    if value is None or isinstance(value, bool | int | float | str):
        return value
    raise ParameterError(f"{name} must be a number, a string, a boolean or None; got {value!r}")


def _canonical(value: Any) -> Any:
    """JSON-ready form in which floats keep every bit (``repr``) and NaN is representable."""
    if isinstance(value, float):
        return {"float": repr(value)} if math.isfinite(value) else {"float": str(value)}
    if isinstance(value, Mapping):
        return {str(k): _canonical(v) for k, v in sorted(value.items())}
    if isinstance(value, list | tuple):
        return [_canonical(v) for v in value]
    return value


def run_key(*parts: Any) -> str:
    """A stable 16-hex-digit key of ``parts`` (strings, numbers, sequences and mappings of them):
    the same parts give the same key on any machine and in any process.

    Parameters
    ----------
    *parts
        Everything that determines a run's result (e.g. scenario text, compensator, seed,
        draw), in a fixed order: the key depends on the order of ``parts`` but not on the order
        of a mapping's keys.

    Returns
    -------
    str
        The first 16 hex digits of the SHA-256 of the parts' canonical JSON.
    """
    text = json.dumps(_canonical(list(parts)), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


@dataclass(frozen=True)
class Run:
    """One independent run.

    Attributes
    ----------
    key
        Stable identifier (:func:`run_key` of what determines the result); unique in a campaign.
    inputs
        Table columns saying what was run (e.g. ``scenario``, ``compensator``, ``seed``,
        ``draw``, ``specimen.inertance``).
    payload
        What the task receives (picklable: it travels to a worker process or another host).
    """

    key: str
    inputs: Mapping[str, Scalar]
    payload: Any


@dataclass(frozen=True)
class Campaign:
    """A named list of independent runs and the task that executes one of them.

    Parameters
    ----------
    name
        Campaign name (progress bar, messages).
    runs
        The runs; keys must be unique.
    task
        Top-level function ``task(payload) -> dict`` of scalars (importable by name on the
        workers).  A row's ``status`` is the task's ``status`` entry if it gives one (e.g.
        ``"interlock"``), else ``"ok"``; an exception makes it ``"error"``.
    """

    name: str
    runs: Sequence[Run]
    task: Task

    def __post_init__(self) -> None:
        object.__setattr__(self, "runs", tuple(self.runs))
        seen: dict[str, int] = {}
        for i, run in enumerate(self.runs):
            if run.key in seen:
                raise ParameterError(
                    f"campaign {self.name!r}: runs {seen[run.key]} and {i} have the same key "
                    f"{run.key!r} (identical inputs)"
                )
            seen[run.key] = i
            for column, value in run.inputs.items():
                check_scalar(value, f"input {column!r} of run {i}")
        if getattr(self.task, "__name__", "<lambda>") == "<lambda>":
            raise ParameterError(
                f"campaign {self.name!r}: the task must be a top-level function (workers import "
                "it by name); got a lambda"
            )

    def __len__(self) -> int:
        return len(self.runs)
