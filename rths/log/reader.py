"""Reading RTHS MCAP logs back (report, check, replay, diagnose, recover).

The reader streams the file record by record with ``mcap.stream_reader.StreamReader``, so a log
whose writer died before the footer (a killed run) is still read up to its last complete chunk:
such a log is *unfinished* (:func:`is_complete` is False), and readers that return data from it
warn once (:class:`rths.core.errors.RTHSWarning`) and name ``rths recover``, which rewrites it as a
finished log.  A *corrupt* log -- not MCAP, a chunk that does not decompress or fails its CRC, an
unknown compression, a record that is not what its header says -- is a
:class:`rths.core.errors.DataError` that names the file and the byte offset.  Messages come in file
order, which for the recorder's topics is their order of production.
"""

from __future__ import annotations

import json
import math
import os
import struct
import warnings
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np
from mcap.exceptions import EndOfFile, McapError, RecordLengthLimitExceeded
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, Footer, Header, McapRecord, Message, Metadata
from mcap.stream_reader import StreamReader, breakup_chunk

from rths.core.errors import DataError, RTHSWarning

__all__ = [
    "LOOP_FIELDS",
    "LogScan",
    "is_complete",
    "iter_messages",
    "list_topics",
    "read_loop",
    "read_metadata",
    "read_topic",
]

#: Fields of ``rths/loop`` every consumer needs (the log contract, design.md section 4).
LOOP_FIELDS = ("t", "target", "command", "measured", "force")
#: Largest magnitude a logged SI value may have; beyond it a number is not a measurement.
MAX_MAGNITUDE = 1e12
_COMPRESSIONS = ("", "zstd", "lz4")
#: A record longer than this is corruption even at the end of the file (mcap's own limit).
_MAX_RECORD = 1 << 32
_Record = Channel | Message | Metadata | Footer
# records a writer cut mid-way leaves as the file's last one (anything else: corruption)
_DATA_OPCODES = {
    Opcode.CHUNK,
    Opcode.MESSAGE_INDEX,
    Opcode.METADATA,
    Opcode.MESSAGE,
    Opcode.CHANNEL,
    Opcode.SCHEMA,
    Opcode.ATTACHMENT,
    Opcode.DATA_END,
    Opcode.CHUNK_INDEX,
    Opcode.METADATA_INDEX,
    Opcode.STATISTICS,
    Opcode.SUMMARY_OFFSET,
    Opcode.FOOTER,
}


class _WholeReads:
    """File wrapper whose ``read(n)`` returns ``n`` bytes or nothing, and counts what it read.

    ``mcap``'s stream reader raises ``EndOfFile`` only on an empty read; a record cut in the
    middle would otherwise reach its parser short and fail with a confusing error.  An opcode
    byte of 0 (no MCAP record has it: the zeros of the disk space a killed recorder had
    reserved, :mod:`rths.log.writer.logfile`) ends the data too; only opcodes are read one byte at a
    time.
    """

    def __init__(self, stream: BinaryIO) -> None:
        self._stream = stream
        self.offset = 0

    def read(self, size: int = -1) -> bytes:
        data = self._stream.read(size)
        if 0 < size != len(data) or (size == 1 and data == b"\x00"):
            return b""
        self.offset += len(data)
        return data


class LogScan:
    """One pass over an MCAP log (see the module docstring).

    Iterate :meth:`records` for the Header, Schema, Channel, Message, Metadata and Footer records
    in file order (chunks broken up and checked); afterwards :attr:`complete` says whether the
    footer was reached and :attr:`stopped_at` where reading stopped [byte].

    Parameters
    ----------
    path
        The log.
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)
        self.complete = False
        self.stopped_at = 0
        self.size = 0
        self.chunks = 0
        self.bad_chunks = 0

    def _corrupt(self, offset: int, what: str) -> DataError:
        return DataError(
            f"'{self.path}' is a corrupt MCAP log: {what} at byte {offset} of {self.size}"
        )

    def records(self, *, skip_bad_chunks: bool = False) -> Iterator[McapRecord]:
        """The records, stopping quietly at a truncation.

        Parameters
        ----------
        skip_bad_chunks
            Skip a chunk that fails to decompress or to parse (and count it in
            :attr:`bad_chunks`) instead of raising; for :mod:`rths.log.recover`.

        Raises
        ------
        DataError
            If the file is missing, empty, not MCAP, or corrupt other than by truncation.
        """
        self.bad_chunks = 0
        try:
            stream = open(self.path, "rb")
        except OSError as exc:
            raise DataError(f"cannot open MCAP log '{self.path}': {exc.strerror}") from None
        with stream:
            self.size = os.fstat(stream.fileno()).st_size
            whole = _WholeReads(stream)
            reader = StreamReader(
                whole,  # type: ignore[arg-type]  # a binary stream: read
                emit_chunks=True,
                record_size_limit=max(self.size, 1),
            )
            started, start = False, 0
            records = reader.records
            while True:
                start = whole.offset
                try:
                    record = next(records)
                except StopIteration:
                    break
                except EndOfFile:
                    if not started:
                        raise DataError(
                            f"'{self.path}' is empty or not an MCAP log (no header)"
                        ) from None
                    break  # truncated: everything before the cut has been yielded
                except RecordLengthLimitExceeded:
                    stream.seek(start)
                    opcode, length = struct.unpack("<BQ", stream.read(9))
                    if not started or opcode not in _DATA_OPCODES or length > _MAX_RECORD:
                        raise self._corrupt(
                            start, f"a record (opcode {opcode:#x}) claiming {length} bytes"
                        ) from None
                    break  # the last record was cut short
                except (McapError, struct.error, ValueError) as exc:
                    if not started:
                        raise DataError(
                            f"'{self.path}' is not an MCAP log ({type(exc).__name__})"
                        ) from None
                    raise self._corrupt(start, f"an unreadable record ({exc!r})") from None
                started = started or isinstance(record, Header)
                if isinstance(record, Chunk):
                    try:
                        inner = _break_up(record)
                    except DataError as exc:
                        if _only_zeros_after(stream, whole.offset):
                            break  # cut mid-write, then the reserve's zeros: a truncation
                        if not skip_bad_chunks:
                            raise self._corrupt(start, f"a chunk that {exc}") from None
                        self.bad_chunks += 1
                        continue
                    self.chunks += 1
                    yield from inner
                    continue
                if isinstance(record, Footer):
                    self.complete = True
                yield record
            self.stopped_at = whole.offset


def _only_zeros_after(stream: BinaryIO, offset: int) -> bool:
    """Whether the file holds nothing but zero bytes from ``offset`` on (the reader's position
    is kept)."""
    here = stream.tell()
    try:
        stream.seek(offset)
        while block := stream.read(1 << 20):
            if block.count(0) != len(block):
                return False
        return True
    finally:
        stream.seek(here)


def _break_up(chunk: Chunk) -> list[McapRecord]:
    """The records of a chunk, its compression and CRC checked (DataError says what failed)."""
    if chunk.compression not in _COMPRESSIONS:
        raise DataError(f"has an unknown compression {chunk.compression!r}")
    try:
        return breakup_chunk(chunk, validate_crc=True)
    except Exception as exc:  # zstd/lz4 errors, CRC mismatch, short record: all corruption
        raise DataError(f"does not decompress or parse ({type(exc).__name__}: {exc})") from None


def _warn_unfinished(scan: LogScan) -> None:
    if not scan.complete:
        warnings.warn(
            RTHSWarning(
                f"'{scan.path}' is unfinished (the run was cut off): read up to byte "
                f"{scan.stopped_at} of {scan.size}; 'rths recover {scan.path}' rewrites it as a "
                "finished log"
            ),
            stacklevel=3,
        )


def _records(path: str | os.PathLike[str], *, warn: bool = False) -> Iterator[_Record]:
    """Channel, Message, Metadata and Footer records of ``path`` (see :class:`LogScan`)."""
    scan = LogScan(path)
    for record in scan.records():
        if isinstance(record, (Channel, Message, Metadata, Footer)):
            yield record
    if warn:
        _warn_unfinished(scan)


def iter_messages(
    path: str | os.PathLike[str], topics: Iterable[str]
) -> Iterator[tuple[str, int, bytes]]:
    """``(topic, log_time_ns, data)`` of every message on ``topics``, in file order, stopping
    at a truncation with a warning (see :class:`LogScan`).

    Parameters
    ----------
    path
        The log.
    topics
        Topic names to keep.
    """
    wanted, channels = set(topics), {}
    for record in _records(path, warn=True):
        if isinstance(record, Channel):
            channels[record.id] = record.topic
        elif isinstance(record, Message) and channels.get(record.channel_id) in wanted:
            yield channels[record.channel_id], record.log_time, record.data


def is_complete(path: str | os.PathLike[str]) -> bool:
    """True if the log ends with its footer (the writer finished); False if it was cut short.

    Parameters
    ----------
    path : str or os.PathLike
        The MCAP log.
    """
    return any(isinstance(r, Footer) for r in _records(path))


def list_topics(path: str | os.PathLike[str]) -> dict[str, int]:
    """``{topic: number of messages}`` in the log, in order of channel registration.

    Parameters
    ----------
    path : str or os.PathLike
        The MCAP log.
    """
    channels: dict[int, str] = {}
    counts: dict[str, int] = {}
    for record in _records(path):
        if isinstance(record, Channel):
            channels[record.id] = record.topic
            counts.setdefault(record.topic, 0)
        elif isinstance(record, Message) and record.channel_id in channels:
            counts[channels[record.channel_id]] += 1
    return counts


def read_metadata(path: str | os.PathLike[str]) -> dict[str, dict[str, str]]:
    """``{record name: {key: value}}`` of the log's metadata records (later names win).

    Parameters
    ----------
    path : str or os.PathLike
        The MCAP log.
    """
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
        MCAP log (finished, or unfinished with a warning).
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
    for record in _records(path, warn=True):
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
                raise DataError(
                    f"message on {topic!r} in '{path}' is not a JSON object: {str(row)[:80]}"
                )
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


def read_loop(
    path: str | os.PathLike[str], fields: Iterable[str] = LOOP_FIELDS, *, minimum: int = 1
) -> dict[str, np.ndarray]:
    """The ``rths/loop`` topic (:func:`read_topic`), checked against the log contract.

    Parameters
    ----------
    path
        MCAP log written by ``rths run``.
    fields
        Fields that must be present, numeric (float64), finite and at most
        :data:`MAX_MAGNITUDE` in magnitude; ``t`` must also increase strictly.
    minimum
        Fewest messages accepted.

    Raises
    ------
    DataError
        Naming the field and the first offending sample.
    """
    loop = read_topic(path, "rths/loop")
    n = loop["sequence"].size
    if n < minimum:
        raise DataError(f"'{path}': only {n} rths/loop messages; need at least {minimum}")
    for name in fields:
        if name not in loop:
            raise DataError(
                f"'{path}': topic rths/loop has no field {name!r}; is this a log written by "
                "'rths run'?"
            )
        column = loop[name]
        if column.dtype.kind not in "fi":
            bad = next(v for v in column if type(v) not in (int, float))
            raise DataError(f"'{path}': rths/loop field {name!r} holds a non-number: {bad!r}")
        values = loop[name] = column.astype(np.float64)
        wrong = ~np.isfinite(values) | (np.abs(values) > MAX_MAGNITUDE)
        if wrong.any():
            k = int(np.argmax(wrong))
            raise DataError(
                f"'{path}': rths/loop field {name!r} is {values[k]!r} at message {k} (null: "
                f"not finite); an RTHS log holds finite SI values below {MAX_MAGNITUDE:g}"
            )
    if "t" in loop and n > 1:
        steps = np.diff(loop["t"])
        if not np.all(steps > 0):
            k = int(np.argmax(steps <= 0))
            raise DataError(
                f"'{path}': rths/loop time t does not increase at message {k + 1} "
                f"(t = {loop['t'][k]!r} then {loop['t'][k + 1]!r} s)"
            )
    return loop
