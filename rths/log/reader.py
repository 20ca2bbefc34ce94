"""Reading RTHS MCAP logs back (report, check, replay, diagnose).

The reader streams the file record by record with ``mcap.stream_reader.StreamReader``, so a log
whose writer died before the footer (a crashed run) is still read up to its last complete chunk;
:func:`is_complete` tells whether the footer was reached.  Messages come in file order, which for
the recorder's topics is their order of production.
"""

from __future__ import annotations

import json
import math
import os
import struct
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np
from mcap.exceptions import EndOfFile, McapError
from mcap.records import Channel, Footer, Header, Message, Metadata
from mcap.stream_reader import StreamReader

from rths.core.errors import DataError

__all__ = ["iter_messages", "is_complete", "list_topics", "read_metadata", "read_topic"]

_Record = Channel | Message | Metadata | Footer


class _WholeReads:
    """File wrapper whose ``read(n)`` returns ``n`` bytes or nothing.

    ``mcap``'s stream reader raises ``EndOfFile`` only on an empty read; a record cut in the
    middle would otherwise reach its parser short and fail with a confusing error.
    """

    def __init__(self, stream: BinaryIO) -> None:
        self._stream = stream

    def read(self, size: int = -1) -> bytes:
        data = self._stream.read(size)
        return b"" if 0 < size != len(data) else data


def _records(path: str | os.PathLike[str]) -> Iterator[_Record]:
    """Channel, Message, Metadata and Footer records of ``path``, stopping quietly at a truncation.

    Raises
    ------
    DataError
        If the file is missing, not MCAP, or corrupt other than by truncation.
    """
    p = Path(path)
    try:
        stream = open(p, "rb")
    except OSError as exc:
        raise DataError(f"cannot open MCAP log '{p}': {exc.strerror}") from None
    started = False
    try:
        for record in StreamReader(_WholeReads(stream)).records:  # type: ignore[arg-type]
            if isinstance(record, (Channel, Message, Metadata, Footer)):
                yield record
            started = started or isinstance(record, Header)
    except EndOfFile:
        if not started:
            raise DataError(f"'{p}' is empty or not an MCAP log (no header)") from None
        return  # truncated: everything before the cut has been yielded
    except (McapError, struct.error, ValueError) as exc:
        raise DataError(f"'{p}' is not a readable MCAP log: {exc!r}") from None
    finally:
        stream.close()


def iter_messages(
    path: str | os.PathLike[str], topics: Iterable[str]
) -> Iterator[tuple[str, int, bytes]]:
    """``(topic, log_time_ns, data)`` of every message on ``topics``, in file order, stopping
    quietly at a truncation (see :func:`_records`)."""
    wanted, channels = set(topics), {}
    for record in _records(path):
        if isinstance(record, Channel):
            channels[record.id] = record.topic
        elif isinstance(record, Message) and channels.get(record.channel_id) in wanted:
            yield channels[record.channel_id], record.log_time, record.data


def is_complete(path: str | os.PathLike[str]) -> bool:
    """True if the log ends with its footer (the writer finished); False if it was cut short."""
    return any(isinstance(r, Footer) for r in _records(path))


def list_topics(path: str | os.PathLike[str]) -> dict[str, int]:
    """``{topic: number of messages}`` in the log, in order of channel registration."""
    channels: dict[int, str] = {}
    counts: dict[str, int] = {}
    for record in _records(path):
        if isinstance(record, Channel):
            channels[record.id] = record.topic
            counts.setdefault(record.topic, 0)
        elif isinstance(record, Message):
            counts[channels[record.channel_id]] += 1
    return counts


def read_metadata(path: str | os.PathLike[str]) -> dict[str, dict[str, str]]:
    """``{record name: {key: value}}`` of the log's metadata records (later names win)."""
    return {r.name: dict(r.metadata) for r in _records(path) if isinstance(r, Metadata)}


def _column(values: list[Any]) -> np.ndarray:
    """Integers → int64, numbers (``None`` → NaN) → float64, booleans → bool, else object."""
    if all(type(v) is int for v in values):
        return np.asarray(values, dtype=np.int64)
    if all(type(v) is bool for v in values):
        return np.asarray(values, dtype=bool)
    if all(v is None or type(v) in (int, float) for v in values):
        return np.asarray([math.nan if v is None else v for v in values], dtype=np.float64)
    column = np.empty(len(values), dtype=object)
    column[:] = values
    return column


def read_topic(path: str | os.PathLike[str], topic: str) -> dict[str, np.ndarray]:
    """All messages of ``topic`` as columns.

    Parameters
    ----------
    path
        MCAP log (finished or truncated).
    topic
        Topic name, e.g. ``"rths/loop"``.

    Returns
    -------
    dict
        One array per message field, shape ``(n,)`` (fields missing from some messages are NaN
        or None there), plus ``"log_time_ns"``, ``"publish_time_ns"`` (int64, [ns]) and
        ``"sequence"`` (int64, ``Message.sequence``).

    Raises
    ------
    DataError
        If the file cannot be read or has no channel ``topic`` (the message lists the topics).
    """
    channels: dict[int, str] = {}
    rows: list[dict[str, Any]] = []
    log_time: list[int] = []
    publish_time: list[int] = []
    sequence: list[int] = []
    wanted: set[int] = set()
    for record in _records(path):
        if isinstance(record, Channel):
            channels[record.id] = record.topic
            if record.topic == topic:
                wanted.add(record.id)
        elif isinstance(record, Message) and record.channel_id in wanted:
            try:
                row = json.loads(record.data)
            except ValueError as exc:
                raise DataError(f"message on {topic!r} in '{path}' is not JSON: {exc}") from None
            if not isinstance(row, dict):
                raise DataError(f"message on {topic!r} in '{path}' is not a JSON object: {row!r}")
            rows.append(row)
            log_time.append(record.log_time)
            publish_time.append(record.publish_time)
            sequence.append(record.sequence)
    if not wanted:
        raise DataError(
            f"topic {topic!r} not found in '{path}'; topics: {sorted(set(channels.values()))}"
        )
    fields: dict[str, None] = {}
    for row in rows:
        fields.update(dict.fromkeys(row))
    columns = {name: _column([row.get(name) for row in rows]) for name in fields}
    columns["log_time_ns"] = np.asarray(log_time, dtype=np.int64)
    columns["publish_time_ns"] = np.asarray(publish_time, dtype=np.int64)
    columns["sequence"] = np.asarray(sequence, dtype=np.int64)
    return columns
