"""Fixed-layout binary messages of the loop's hot path (command out, measurement back).

Every loop step the coordinator sends one :class:`Command` and the specimen answers with one
:class:`Measurement`.  They travel as little-endian ``struct`` records of fixed size, so encoding
and decoding cost a microsecond or so and a truncated or foreign payload is detected by its length
alone.  Layouts (byte offsets)::

    Command      (24 bytes)  0 seq u64 | 8 t_ns i64 | 16 command f64
    Measurement  (40 bytes)  0 seq u64 | 8 t_ns i64 | 16 displacement f64 | 24 force f64
                             | 32 sample_ns i64

``seq`` is the loop step ``k``; ``t_ns`` is the simulated time the step ends at [ns] (``(k + 1) *
dt``); ``sample_ns`` is the specimen's monotonic clock [ns] when it sampled the measurement, so the
realtime clock can tell how old the newest sample is.

In the ``realtime`` clock a measurement carries the specimen's log rows with it (a *reply*,
:func:`pack_reply`): the 40-byte measurement, then ``rows u16 | channels u16``, the rows' ``seq``
and ``t_ns`` (int64) and their values (float64, row-major) -- one message per step each way, no
side stream while the loop runs.  A plain 40-byte measurement is a reply without rows.

A command whose ``t_ns`` is :data:`PROBE_T_NS` (negative: no step ends before time zero) is a
*probe*: the specimen answers it at once with a measurement carrying the same ``seq`` and
``t_ns`` and zero values, and does not step the lab -- the actuator never sees it.  The
``realtime`` clock warms the round trip with probes before step 0
(:mod:`rths.session.warm_up`).

:class:`LogRecord` is the (slower, self-describing) JSON record another process publishes on
``rths/<run>/log/<name>`` for the coordinator's recorder, e.g. the specimen's summary.  A block of
per-step rows (:class:`rths.core.channels.RowBlock`, e.g. the emulated lab's truth) travels as one
binary frame (:func:`pack_block`): its channel declarations as JSON, then the step counters, log
times and values as little-endian arrays, so the specimen's loop never encodes JSON.
"""

from __future__ import annotations

import json
import struct
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from rths.core.channels import Channel, RowBlock
from rths.core.errors import DataError, ParameterError

__all__ = [
    "BLOCK_MAGIC",
    "PROBE_T_NS",
    "Command",
    "LogRecord",
    "Measurement",
    "pack_block",
    "pack_frames",
    "pack_reply",
    "unpack_block",
    "unpack_reply",
]

#: ``t_ns`` of a probe (see the module docstring): a round trip that moves nothing.
PROBE_T_NS = -1

_COMMAND = struct.Struct("<Qqd")
_MEASUREMENT = struct.Struct("<Qqddq")


def _decode_error(kind: str, data: bytes | bytearray | memoryview, size: int) -> DataError:
    return DataError(f"{kind} payload must be {size} bytes; got {len(data)} bytes")


def _encode_error(kind: str, message: object, exc: struct.error) -> ParameterError:
    return ParameterError(
        f"{kind} cannot be encoded ({exc}): seq must be an integer in [0, 2**64), times integers "
        f"in [-2**63, 2**63), values floats; got {message!r}"
    )


@dataclass(frozen=True, slots=True)
class Command:
    """The actuator command of one loop step.

    Attributes
    ----------
    seq
        Loop step index ``k`` (>= 0).
    t_ns
        Simulated time of the step [ns].
    command
        Actuator displacement command ``u_k`` [m], held over ``[t_k, t_k+1]``.
    """

    SIZE: ClassVar[int] = _COMMAND.size

    seq: int
    t_ns: int
    command: float

    @classmethod
    def probe(cls, seq: int) -> Command:
        """A probe with step number ``seq`` (see the module docstring).

        Parameters
        ----------
        seq
            Its number (>= 0), echoed in the answer.
        """
        return cls(seq, PROBE_T_NS, 0.0)

    @property
    def is_probe(self) -> bool:
        """Whether this is a probe (negative ``t_ns``), not a step's command."""
        return self.t_ns < 0

    def pack(self) -> bytes:
        """Encode as the 24-byte little-endian record described in the module docstring.

        Raises
        ------
        ParameterError
            If a field does not fit its slot (negative ``seq``, non-integer time, ...).
        """
        try:
            return _COMMAND.pack(self.seq, self.t_ns, self.command)
        except struct.error as exc:
            raise _encode_error("Command", self, exc) from None

    @classmethod
    def unpack(cls, data: bytes | bytearray | memoryview) -> Command:
        """Decode a record produced by :meth:`pack`.

        Raises
        ------
        DataError
            If ``data`` is not exactly :attr:`SIZE` bytes long.
        """
        if len(data) != _COMMAND.size:
            raise _decode_error("Command", data, _COMMAND.size)
        return cls(*_COMMAND.unpack(data))


@dataclass(frozen=True, slots=True)
class Measurement:
    """What the specimen reports back for one loop step.

    Attributes
    ----------
    seq
        Loop step index of the command this measurement answers (lockstep), or the specimen's
        own sample counter (realtime).
    t_ns
        Simulated time the measurement refers to [ns].
    displacement
        Measured displacement of the specimen end [m] (after the converters).
    force
        Measured restoring force of the specimen [N] (after the converters).
    sample_ns
        Specimen's monotonic clock when it sampled these values [ns].
    """

    SIZE: ClassVar[int] = _MEASUREMENT.size

    seq: int
    t_ns: int
    displacement: float
    force: float
    sample_ns: int

    @property
    def is_probe(self) -> bool:
        """Whether this answers a probe (negative ``t_ns``): it carries no measurement."""
        return self.t_ns < 0

    def pack(self) -> bytes:
        """Encode as the 40-byte little-endian record described in the module docstring.

        Raises
        ------
        ParameterError
            If a field does not fit its slot (negative ``seq``, non-integer time, ...).
        """
        try:
            return _MEASUREMENT.pack(
                self.seq, self.t_ns, self.displacement, self.force, self.sample_ns
            )
        except struct.error as exc:
            raise _encode_error("Measurement", self, exc) from None

    @classmethod
    def unpack(cls, data: bytes | bytearray | memoryview) -> Measurement:
        """Decode a record produced by :meth:`pack`.

        Raises
        ------
        DataError
            If ``data`` is not exactly :attr:`SIZE` bytes long.
        """
        if len(data) != _MEASUREMENT.size:
            raise _decode_error("Measurement", data, _MEASUREMENT.size)
        return cls(*_MEASUREMENT.unpack(data))


_ROWS_HEAD = struct.Struct("<HH")  # rows, channels


def pack_reply(measurement: Measurement, rows: RowBlock | None = None) -> bytes:
    """A measurement with the specimen's log rows riding on it (module docstring).

    Parameters
    ----------
    measurement
        The step's measurement.
    rows
        Rows to carry (``rows.count`` of them, at most 65 535); None or empty: none.
    """
    head = measurement.pack()
    if rows is None or not rows.count:
        return head
    n = rows.count
    return b"".join(
        (
            head,
            _ROWS_HEAD.pack(n, rows.values.shape[1]),
            rows.seq[:n].astype("<i8").tobytes(),
            rows.t_ns[:n].astype("<i8").tobytes(),
            np.ascontiguousarray(rows.values[:n], dtype="<f8").tobytes(),
        )
    )


Rows = tuple[np.ndarray, np.ndarray, np.ndarray]


def unpack_reply(data: bytes | bytearray | memoryview) -> tuple[Measurement, Rows | None]:
    """Decode a :func:`pack_reply` message: the measurement, and the rows' ``seq``, ``t_ns`` and
    values (shape ``(rows, channels)``; read-only views of ``data``) or None.

    Parameters
    ----------
    data
        The message.

    Raises
    ------
    DataError
        If ``data`` is neither a measurement nor a measurement with whole rows.
    """
    size = _MEASUREMENT.size
    if len(data) == size:
        return Measurement.unpack(data), None
    head = size + _ROWS_HEAD.size
    if len(data) < head:
        raise _decode_error("Measurement", data, size)
    n, m = _ROWS_HEAD.unpack_from(data, size)
    if len(data) != head + 16 * n + 8 * n * m:
        raise DataError(f"reply of {len(data)} bytes does not hold {n} rows of {m} channels")
    seq = np.frombuffer(data, "<i8", n, head)
    t_ns = np.frombuffer(data, "<i8", n, head + 8 * n)
    values = np.frombuffer(data, "<f8", n * m, head + 16 * n).reshape(n, m)
    return Measurement.unpack(bytes(data[:size])), (seq, t_ns, values)


_LOG_HEADER = struct.Struct("<QQ")


@dataclass(frozen=True, slots=True)
class LogRecord:
    """One log record of a side stream: a 16-byte header, then the message as UTF-8 JSON.

    Wire format: ``struct "<QQ"`` (``seq``, ``log_time_ns``) followed by the JSON object of the
    message.  The recorder writes the JSON bytes into the MCAP log as they are (no parse, no
    re-encode: cheap enough to record at loop rate next to a real-time loop); a monitor skips 16
    bytes and parses the rest.

    Attributes
    ----------
    seq
        Counter of the publishing stream (>= 0, +1 per record); the recorder counts gaps in it.
    log_time_ns
        Simulated time the record refers to [ns] (>= 0).
    message
        JSON-serialisable mapping of named values (SI units).
    """

    seq: int
    log_time_ns: int
    message: Mapping[str, Any]

    HEADER: ClassVar[int] = _LOG_HEADER.size

    def encode(self) -> bytes:
        """Header and compact JSON of the message."""
        try:
            header = _LOG_HEADER.pack(self.seq, self.log_time_ns)
        except struct.error as exc:
            raise ParameterError(
                f"log record seq and log_time_ns must be integers >= 0; got {self.seq!r}, "
                f"{self.log_time_ns!r} ({exc})"
            ) from None
        return header + json.dumps(self.message, separators=(",", ":")).encode()

    @staticmethod
    def split(data: bytes | bytearray | memoryview) -> tuple[int, int, bytes]:
        """``(seq, log_time_ns, message JSON bytes)`` without parsing the JSON.

        Raises
        ------
        DataError
            If ``data`` is shorter than the header or the body does not look like a JSON object.
        """
        raw = bytes(data)
        if len(raw) < _LOG_HEADER.size + 2 or raw[_LOG_HEADER.size] != 0x7B or raw[-1] != 0x7D:
            raise DataError(
                f"log record must be a 16-byte header and a JSON object; got {raw[:40]!r}"
            )
        seq, log_time = _LOG_HEADER.unpack_from(raw)
        return seq, log_time, raw[_LOG_HEADER.size :]

    @classmethod
    def decode(cls, data: bytes | bytearray | memoryview) -> LogRecord:
        """Parse bytes produced by :meth:`encode`.

        Raises
        ------
        DataError
            If ``data`` is not such a record (the message names what is wrong).
        """
        seq, log_time, body = cls.split(data)
        try:
            message = json.loads(body)
        except (UnicodeDecodeError, ValueError) as exc:
            raise DataError(f"log record message is not JSON ({exc}); got {body[:60]!r}") from None
        if not isinstance(message, dict):
            raise DataError(f"log record message must be a JSON object; got {message!r:.60}")
        return cls(seq, log_time, message)


#: First bytes of a :func:`pack_block` frame (never the start of a LogRecord's JSON header).
BLOCK_MAGIC = b"RTHSBLK1"
_U32 = struct.Struct("<I")


def pack_block(block: RowBlock) -> bytes:
    """One binary frame for the filled rows of ``block``: magic, the channels (JSON), the row
    count, then ``seq`` (int64), ``t_ns`` (int64) and the values (float64, row-major).

    Parameters
    ----------
    block
        The rows (``block.count`` of them are packed).
    """
    n = block.count
    head = json.dumps([[c.name, c.unit, c.description] for c in block.channels]).encode()
    return b"".join(
        (
            BLOCK_MAGIC,
            _U32.pack(len(head)),
            head,
            _U32.pack(n),
            block.seq[:n].astype("<i8").tobytes(),
            block.t_ns[:n].astype("<i8").tobytes(),
            np.ascontiguousarray(block.values[:n], dtype="<f8").tobytes(),
        )
    )


def pack_frames(block: RowBlock, max_bytes: int) -> list[bytes]:
    """The filled rows of ``block`` as :func:`pack_block` frames of at most ``max_bytes`` each
    (consecutive rows; one row per frame if a row alone is larger).  Each frame is a block of
    its own, with its rows' ``seq`` and ``t_ns``, so a receiver needs no reassembly.

    Parameters
    ----------
    block
        The rows.
    max_bytes
        Largest frame [bytes], > 0 (e.g. what one batch of zenoh's low-latency transport holds).
    """
    n = block.count
    whole = pack_block(block)
    if len(whole) <= max_bytes or n <= 1:
        return [whole]
    row_bytes = 16 + 8 * len(block.channels)
    rows = max(1, (max_bytes - (len(whole) - n * row_bytes)) // row_bytes)
    frames = []
    for start in range(0, n, rows):
        stop = min(start + rows, n)
        part = RowBlock(block.channels, stop - start)
        part.seq[:] = block.seq[start:stop]
        part.t_ns[:] = block.t_ns[start:stop]
        part.values[:] = block.values[start:stop]
        part.count = stop - start
        frames.append(pack_block(part))
    return frames


def unpack_block(data: bytes | bytearray | memoryview) -> RowBlock:
    """Decode a :func:`pack_block` frame.

    Parameters
    ----------
    data
        The frame.

    Raises
    ------
    DataError
        If ``data`` is not such a frame (the message says what is wrong).
    """
    raw = bytes(data)
    try:
        if not raw.startswith(BLOCK_MAGIC):
            raise ValueError("no block magic")
        at = len(BLOCK_MAGIC)
        (size,) = _U32.unpack_from(raw, at)
        at += 4
        columns = [Channel(str(n), str(u), str(d)) for n, u, d in json.loads(raw[at : at + size])]
        at += size
        (n,) = _U32.unpack_from(raw, at)
        at += 4
        m = len(columns)
        if len(raw) != at + 16 * n + 8 * n * m:
            raise ValueError(f"{len(raw)} bytes for {n} rows of {m} channels")
        block = RowBlock(columns, n)
        block.seq[:] = np.frombuffer(raw, "<i8", n, at)
        block.t_ns[:] = np.frombuffer(raw, "<i8", n, at + 8 * n)
        block.values[:] = np.frombuffer(raw, "<f8", n * m, at + 16 * n).reshape(n, m)
        block.count = n
        return block
    except (ValueError, TypeError, struct.error, ParameterError) as exc:
        raise DataError(f"row block frame is malformed ({exc}); got {raw[:40]!r}") from None
