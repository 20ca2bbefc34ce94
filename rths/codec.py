"""Fixed-layout binary messages of the loop's hot path (command out, measurement back).

Every loop step the coordinator sends one :class:`Command` and the specimen answers with one
:class:`Measurement`.  They travel as little-endian ``struct`` records of fixed size, so encoding
and decoding cost a microsecond or so and a truncated or foreign payload is detected by its length
alone.  Layouts (byte offsets)::

    Command      (24 bytes)  0 seq u64 | 8 t_ns i64 | 16 command f64
    Measurement  (40 bytes)  0 seq u64 | 8 t_ns i64 | 16 displacement f64 | 24 force f64
                             | 32 sample_ns i64

``seq`` is the loop step ``k``; ``t_ns`` is the simulated time of the step [ns] (``k * dt``);
``sample_ns`` is the specimen's monotonic clock [ns] when it sampled the measurement, so the
realtime clock can tell how old the newest sample is.

:class:`LogRecord` is the (slower, self-describing) JSON record another process publishes on
``rths/<run>/log/<name>`` for the coordinator's recorder, e.g. the specimen's internal state.
"""

from __future__ import annotations

import json
import struct
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

from rths.errors import DataError, ParameterError

__all__ = ["Command", "LogRecord", "Measurement"]

_COMMAND = struct.Struct("<Qqd")
_MEASUREMENT = struct.Struct("<Qqddq")


def _decode_error(kind: str, data: bytes, size: int) -> DataError:
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


@dataclass(frozen=True, slots=True)
class LogRecord:
    """One JSON log record: ``{"seq": int, "log_time_ns": int, "message": {...}}`` in UTF-8.

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

    def encode(self) -> bytes:
        """UTF-8 JSON bytes of the record."""
        return json.dumps(
            {"seq": self.seq, "log_time_ns": self.log_time_ns, "message": self.message},
            separators=(",", ":"),
        ).encode()

    @classmethod
    def decode(cls, data: bytes | bytearray | memoryview) -> LogRecord:
        """Parse bytes produced by :meth:`encode`.

        Raises
        ------
        DataError
            If ``data`` is not such a JSON object (the message names what is wrong).
        """
        try:
            obj = json.loads(bytes(data))
        except (UnicodeDecodeError, ValueError) as exc:
            raise DataError(f"log record is not JSON ({exc}); got {bytes(data)[:60]!r}") from None
        if not isinstance(obj, dict):
            raise DataError(f"log record must be a JSON object; got {obj!r:.60}")
        seq, log_time, message = obj.get("seq"), obj.get("log_time_ns"), obj.get("message")
        for name, value in (("seq", seq), ("log_time_ns", log_time)):
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise DataError(f"log record field {name!r} must be an integer >= 0; got {value!r}")
        if not isinstance(message, dict):
            raise DataError(f"log record field 'message' must be a JSON object; got {message!r:.60}")
        return cls(seq, log_time, message)
