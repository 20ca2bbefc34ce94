"""Declared log channels and preallocated blocks of rows.

Every component that logs something per step -- the loop, a substructure, a compensator, the
emulated lab -- declares its channels once (:class:`Channel`: name, unit, meaning) and writes its
values each step into a slice of a preallocated row of floats (``write_channels(out)``), not into a
``dict``.  Rows are collected in a :class:`RowBlock` that goes to the log (and to a live viewer) a
block at a time, so nothing is encoded on the loop thread; the MCAP topic's JSON schema is
generated from the same declarations (:func:`json_schema`), so the documented log contract and
the code cannot drift.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rths.core.errors import ParameterError

__all__ = ["Channel", "RowBlock", "json_schema", "prefixed"]


@dataclass(frozen=True, slots=True)
class Channel:
    """One logged quantity.

    Attributes
    ----------
    name
        Field name in the log's JSON (``[A-Za-z0-9_.]``).
    unit
        SI unit, e.g. ``"m"``, ``"N"``, ``"s"``; ``"1"`` for a dimensionless number.
    description
        What it is.
    """

    name: str
    unit: str = "1"
    description: str = ""

    def __post_init__(self) -> None:
        if not self.name or not all(c.isalnum() or c in "_." for c in self.name):
            raise ParameterError(f"channel name must be [A-Za-z0-9_.]+; got {self.name!r}")


def prefixed(prefix: str, channels: Iterable[Channel]) -> tuple[Channel, ...]:
    """The channels renamed ``prefix + name`` (e.g. ``ctrl_`` for a compensator's).

    Parameters
    ----------
    prefix
        Prepended to every name.
    channels
        The declarations.
    """
    return tuple(Channel(prefix + c.name, c.unit, c.description) for c in channels)


def json_schema(
    title: str, channels: Sequence[Channel], *, description: str = "", seq: bool = False
) -> dict[str, Any]:
    """The JSON schema of a message holding ``channels`` (every one a number, or ``null`` for a
    non-finite value), each described with its unit.

    Parameters
    ----------
    title
        Schema title, e.g. ``"rths.loop"``.
    channels
        The message's fields.
    description
        What one message is.
    seq
        Add the integer step counter ``seq``.
    """
    props: dict[str, Any] = {}
    if seq:
        props["seq"] = {"type": "integer", "description": "loop step k"}
    for c in channels:
        props[c.name] = {"type": ["number", "null"], "description": f"{c.description} [{c.unit}]"}
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": title,
        "description": description,
        "type": "object",
        "properties": props,
        "required": list(props),
    }


class RowBlock:
    """A block of rows, one per step: step counters, log times [ns] and the channels' values.

    Parameters
    ----------
    channels
        The columns.
    capacity
        Rows the block holds.

    Attributes
    ----------
    seq, t_ns : numpy.ndarray
        Step counter and log time [ns] of each row (int64, shape ``(capacity,)``).
    values : numpy.ndarray
        Shape ``(capacity, len(channels))``; row ``i`` is filled by the producer.
    count : int
        Rows filled so far.
    """

    __slots__ = ("channels", "count", "names", "seq", "t_ns", "values")

    def __init__(self, channels: Sequence[Channel], capacity: int) -> None:
        self.channels = tuple(channels)
        self.names = tuple(c.name for c in self.channels)
        if len(set(self.names)) != len(self.names):
            raise ParameterError(f"channel names must be unique; got {self.names!r}")
        self.seq: NDArray[np.int64] = np.zeros(capacity, dtype=np.int64)
        self.t_ns: NDArray[np.int64] = np.zeros(capacity, dtype=np.int64)
        self.values: NDArray[np.float64] = np.zeros((capacity, len(self.channels)))
        self.count = 0

    @property
    def full(self) -> bool:
        """Whether every row is filled."""
        return self.count == self.seq.size

    def column(self, name: str) -> NDArray[np.float64]:
        """The filled part of one column."""
        return self.values[: self.count, self.names.index(name)]

    def records(self) -> list[dict[str, float]]:
        """The filled rows as dicts ``{"seq": k, name: value, ...}`` (for tests and tools)."""
        out = []
        for k, row in zip(self.seq[: self.count].tolist(), self.values[: self.count].tolist()):
            record: dict[str, float] = {"seq": k}
            record.update(zip(self.names, row))
            out.append(record)
        return out
