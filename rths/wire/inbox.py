"""Receive sides of the hot path (private; import them from :mod:`rths.wire.transport`).

:class:`Inbox` delivers every message of a key in order (lockstep); :class:`Mailbox` keeps only the
newest one and its age (realtime).  :func:`declare_hot_publisher` is their sending counterpart.
The choices and their measured cost are documented in :mod:`rths.wire.transport`.
"""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Generic, TypeVar

import zenoh

from rths.core.errors import DataError, TransportError, check_positive

__all__ = ["Inbox", "Latest", "Mailbox", "declare_hot_publisher"]

T = TypeVar("T")
_ALARM = b"\x00rths-inbox-timeout:"
_CLOSING = 2**64 - 1  # alarm id that tells a waiting get() the inbox is closing
_ALARM_SIZE = len(_ALARM) + 8  # 28 bytes: never the size of a Command (24) or Measurement (40)


def declare_hot_publisher(session: zenoh.Session, key: str) -> zenoh.Publisher:
    """Publisher for the per-step messages: reliable, express, blocking, REAL_TIME priority.

    Parameters
    ----------
    session
        Open zenoh session.
    key
        Key expression to publish on.
    """
    return session.declare_publisher(
        key,
        congestion_control=zenoh.CongestionControl.BLOCK,
        priority=zenoh.Priority.REAL_TIME,
        express=True,
        reliability=zenoh.Reliability.RELIABLE,
    )


def _alarm_id(payload: bytes) -> int | None:
    """The wait id of an :class:`Inbox` alarm sample, or None for an ordinary payload."""
    if len(payload) != _ALARM_SIZE or not payload.startswith(_ALARM):
        return None
    return int.from_bytes(payload[-8:], "little")


class Inbox(Generic[T]):
    """Every message published on ``key``, decoded, in arrival order (lockstep receive side).

    Samples wait in a zenoh ``FifoChannel`` (filled by zenoh's thread without taking the GIL)
    and are decoded on the caller's thread by :meth:`get`, which blocks in ``recv()``.  That
    call cannot time out, so a watchdog thread checks every ``tick`` [s] whether a wait has
    passed its deadline and then wakes it with a session-local *alarm* sample on the same key;
    timeouts are therefore honoured to within ``tick``.  A payload that fails to decode raises
    :class:`DataError` from :meth:`get`: a malformed sample is never skipped silently.

    Parameters
    ----------
    session
        Open zenoh session.
    key
        Key expression to receive from.
    decode
        ``bytes -> message``; raises :class:`DataError` on a malformed payload, or returns
        None for a payload to drop (an :class:`rths.wire.auth.Opener` refusing a forged or
        replayed frame); dropped payloads are counted in :attr:`dropped`.
    capacity
        Messages the channel holds before zenoh's receive thread blocks (lockstep needs 1).
    tick
        Watchdog period [s]: the resolution of :meth:`get`'s timeout.
    """

    def __init__(
        self,
        session: zenoh.Session,
        key: str,
        decode: Callable[[bytes], T | None],
        capacity: int = 1024,
        tick: float = 0.01,
    ) -> None:
        self.key = key
        self.dropped = 0  #: payloads the decoder refused (returned None for), e.g. forged
        self._decode = decode
        self._tick = check_positive(tick, "watchdog tick")
        self._subscriber = session.declare_subscriber(key, zenoh.handlers.FifoChannel(capacity))
        self._alarm = session.declare_publisher(
            key,
            congestion_control=zenoh.CongestionControl.BLOCK,
            express=True,
            allowed_destination=zenoh.Locality.SESSION_LOCAL,
        )
        self._wait = (0, 0)  # (deadline [ns] on time.monotonic_ns, wait id); 0 = not waiting
        self._wait_id = 0
        self._closed = threading.Event()
        self._receiving = threading.Lock()
        self._watchdog = threading.Thread(target=self._watch, name=f"rths-inbox {key}", daemon=True)
        self._watchdog.start()

    def _watch(self) -> None:
        alarmed = 0
        while not self._closed.wait(self._tick):
            deadline, wait_id = self._wait
            if deadline and wait_id != alarmed and time.monotonic_ns() >= deadline:
                alarmed = wait_id
                self._alarm.put(_ALARM + wait_id.to_bytes(8, "little"))

    def get(self, timeout: float | None) -> T:
        """The next message; wait at most ``timeout`` [s] (forever if None).

        Raises
        ------
        queue.Empty
            If nothing arrived in time (callers turn it into a :class:`TransportError`).
        DataError
            If the next payload could not be decoded.
        """
        deadline = None if timeout is None else time.monotonic_ns() + int(timeout * 1e9)
        while True:
            with self._receiving:  # close() must not undeclare while recv() runs
                if self._closed.is_set():
                    raise TransportError(f"inbox on key '{self.key}' is closed")
                left = None if deadline is None else (deadline - time.monotonic_ns()) * 1e-9
                payload = self._receive(left)
            try:
                message = self._decode(payload)
            except DataError as exc:
                raise DataError(f"on key '{self.key}': {exc}") from None
            if message is not None:
                return message
            self.dropped += 1  # a frame the decoder refused (forged, replayed): counted, skipped

    def _receive(self, timeout: float | None) -> bytes:
        while (sample := self._subscriber.try_recv()) is not None:
            payload = sample.payload.to_bytes()
            if _alarm_id(payload) is None:
                return payload  # already there: no wait, no watchdog involved
        if timeout is not None and timeout <= 0.0:
            raise queue.Empty
        self._wait_id += 1
        wait_id = self._wait_id
        if timeout is not None:
            self._wait = (time.monotonic_ns() + max(int(timeout * 1e9), 1), wait_id)
        try:
            while True:
                payload = self._subscriber.recv().payload.to_bytes()
                alarm_id = _alarm_id(payload)
                if alarm_id is None:
                    return payload
                if alarm_id == wait_id:
                    raise queue.Empty
                if alarm_id == _CLOSING:
                    raise TransportError(f"inbox on key '{self.key}' was closed while waiting")
                # else: the alarm of an earlier wait that was answered just in time
        finally:
            self._wait = (0, 0)

    def close(self) -> None:
        """Wake a waiting :meth:`get`, stop the watchdog, undeclare subscriber and publisher."""
        if self._closed.is_set():
            return
        self._closed.set()
        self._watchdog.join()
        if self._receiving.locked():
            self._alarm.put(_ALARM + _CLOSING.to_bytes(8, "little"))
        with self._receiving:
            self._alarm.undeclare()
            self._subscriber.undeclare()

    def __enter__(self) -> Inbox[T]:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


@dataclass(frozen=True, slots=True)
class Latest(Generic[T]):
    """The newest message of a :class:`Mailbox`, when it arrived and how old it is [ns].

    Attributes
    ----------
    message : T
        The decoded message.
    received_ns : int
        When it was drained from the zenoh channel [ns], on the mailbox's clock (default
        :func:`time.monotonic_ns`).
    age_ns : int
        Time since ``received_ns`` when :meth:`Mailbox.latest` returned it [ns], >= 0.
    """

    message: T
    received_ns: int
    age_ns: int


class Mailbox(Generic[T]):
    """Only the newest message on ``key`` (realtime receive side); reading never blocks.

    Samples wait in a zenoh ``FifoChannel`` (filled by zenoh's thread without taking the GIL);
    :meth:`latest` drains it with ``try_recv`` on the caller's thread and keeps the newest.  No
    Python callback runs per message, so a real-time loop never hands the GIL to a receiving
    thread (each such hand-off cost the loop tens of microseconds).  Arrivals are stamped when
    drained; malformed payloads are counted in :attr:`rejected` and skipped.

    Parameters
    ----------
    session
        Open zenoh session.
    key
        Key expression to receive from.
    decode
        ``bytes -> message``; raises :class:`DataError` on a malformed payload.
    clock
        Monotonic clock [ns] that stamps arrivals (inject a fake one in tests).
    capacity
        Samples the channel holds between two reads (zenoh blocks its thread when full).
    """

    def __init__(
        self,
        session: zenoh.Session,
        key: str,
        decode: Callable[[bytes], T],
        clock: Callable[[], int] = time.monotonic_ns,
        capacity: int = 1 << 14,
    ) -> None:
        self.key = key
        self.rejected = 0
        self._received = 0
        self._decode = decode
        self._clock = clock
        self._latest: tuple[T, int] | None = None
        self._subscriber = session.declare_subscriber(key, zenoh.handlers.FifoChannel(capacity))

    def _drain(self) -> None:
        try_recv, decode = self._subscriber.try_recv, self._decode
        newest: T | None = None
        while (sample := try_recv()) is not None:
            try:
                newest = decode(sample.payload.to_bytes())
            except DataError:
                self.rejected += 1
                continue
            self._received += 1
        if newest is not None:
            self._latest = (newest, self._clock())

    @property
    def received(self) -> int:
        """Well-formed messages received so far."""
        self._drain()
        return self._received

    def latest(self) -> Latest[T] | None:
        """The newest message and its age, or None before the first one."""
        self._drain()
        slot = self._latest
        if slot is None:
            return None
        return Latest(slot[0], slot[1], self._clock() - slot[1])

    def close(self) -> None:
        """Undeclare the subscriber."""
        self._subscriber.undeclare()

    def __enter__(self) -> Mailbox[T]:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
