"""Hot-path links of :mod:`rths.transport` (private; import them from there).

Receive sides (:class:`Inbox`, :class:`Mailbox`) and the coordinator/specimen ends of the lockstep
and realtime links.  The choices (reliable + express + BLOCK publishers, a FifoChannel with a
timeout watchdog for lockstep, an arrival-stamping callback for realtime) and their measured cost
are documented in :mod:`rths.transport`.
"""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Generic, Protocol, TypeVar

import zenoh

from rths.codec import Command, Measurement
from rths.errors import DataError, TransportError, check_positive

__all__ = [
    "Inbox",
    "Latest",
    "LockstepClient",
    "LockstepServer",
    "Mailbox",
    "RealtimeClient",
    "RealtimeServer",
    "declare_hot_publisher",
]

T = TypeVar("T")
_ALARM = b"\x00rths-inbox-timeout:"
_CLOSING = 2**64 - 1  # alarm id that tells a waiting get() the inbox is closing
_ALARM_SIZE = len(_ALARM) + 8  # 28 bytes: never the size of a Command (24) or Measurement (40)


class _HotKeys(Protocol):
    """The two keys a link needs (:class:`rths.transport.RunKeys` provides them)."""

    @property
    def command(self) -> str: ...

    @property
    def measurement(self) -> str: ...



def declare_hot_publisher(session: zenoh.Session, key: str) -> zenoh.Publisher:
    """Publisher for the per-step messages: reliable, express, blocking, REAL_TIME priority."""
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
    """

    def __init__(
        self,
        session: zenoh.Session,
        key: str,
        decode: Callable[[bytes], T],
        capacity: int = 1024,
        tick: float = 0.01,
    ) -> None:
        self.key = key
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
        with self._receiving:  # close() must not undeclare while recv() runs
            if self._closed.is_set():
                raise TransportError(f"inbox on key '{self.key}' is closed")
            payload = self._receive(timeout)
        try:
            return self._decode(payload)
        except DataError as exc:
            raise DataError(f"on key '{self.key}': {exc}") from None

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
    """The newest message of a :class:`Mailbox`, when it arrived and how old it is [ns]."""

    message: T
    received_ns: int
    age_ns: int


class Mailbox(Generic[T]):
    """Only the newest message on ``key`` (realtime receive side); reading never blocks.

    ``clock`` is the monotonic clock [ns] used to stamp arrivals (inject a fake one in tests).
    Malformed payloads are counted in :attr:`rejected` and the previous message is kept.
    """

    def __init__(
        self,
        session: zenoh.Session,
        key: str,
        decode: Callable[[bytes], T],
        clock: Callable[[], int] = time.monotonic_ns,
    ) -> None:
        self.key = key
        self.received = 0
        self.rejected = 0
        self._decode = decode
        self._clock = clock
        self._latest: tuple[T, int] | None = None
        self._subscriber = session.declare_subscriber(
            key, zenoh.handlers.Callback(self._on_sample, indirect=False)
        )

    def _on_sample(self, sample: zenoh.Sample) -> None:
        try:
            message = self._decode(sample.payload.to_bytes())
        except DataError:
            self.rejected += 1
            return
        self._latest = (message, self._clock())  # one reference store: atomic for readers
        self.received += 1

    def latest(self) -> Latest[T] | None:
        """The newest message and its age, or None before the first one."""
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


class _Link:
    """A hot publisher and a receiver, closed together."""

    publisher: zenoh.Publisher
    _receiver: Inbox[Any] | Mailbox[Any]

    def close(self) -> None:
        """Undeclare the subscriber and the publisher."""
        self._receiver.close()
        self.publisher.undeclare()

    def __enter__(self) -> Any:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class LockstepClient(_Link):
    """Coordinator end of the lockstep link: send command ``k``, wait for measurement ``k``.

    Parameters
    ----------
    session
        Open zenoh session.
    keys
        The run's keys.
    timeout
        Default wait for a measurement [s].
    """

    def __init__(self, session: zenoh.Session, keys: _HotKeys, timeout: float = 1.0) -> None:
        self.timeout = check_positive(timeout, "lockstep timeout")
        self.stale = 0  #: measurements for older steps that were discarded
        self._receiver: Inbox[Measurement] = Inbox(session, keys.measurement, Measurement.unpack)
        self.publisher = declare_hot_publisher(session, keys.command)

    def send(self, command: Command) -> None:
        """Publish a command without waiting."""
        self.publisher.put(command.pack())

    def receive(self, seq: int, timeout: float | None = None) -> Measurement:
        """Wait for the measurement answering command ``seq``; older ones are discarded.

        Raises
        ------
        TransportError
            If it does not arrive within ``timeout`` [s] (default :attr:`timeout`), or a
            measurement for a later step arrives (the specimen is out of step).
        """
        wait = self.timeout if timeout is None else timeout
        deadline = time.monotonic() + wait
        while True:
            try:
                m = self._receiver.get(max(deadline - time.monotonic(), 0.0))
            except queue.Empty:
                raise TransportError(
                    f"no measurement for step seq={seq} on key '{self._receiver.key}' "
                    f"within {wait:g} s"
                ) from None
            if m.seq == seq:
                return m
            if m.seq > seq:
                raise TransportError(
                    f"measurement seq={m.seq} on key '{self._receiver.key}' is ahead of the "
                    f"command seq={seq}: specimen out of step"
                )
            self.stale += 1

    def exchange(self, command: Command, timeout: float | None = None) -> Measurement:
        """Send ``command`` and return the measurement with the same ``seq`` (see :meth:`receive`)."""
        self.publisher.put(command.pack())
        return self.receive(command.seq, timeout)


class LockstepServer(_Link):
    """Specimen end of the lockstep link: take each command in order, publish its measurement."""

    def __init__(self, session: zenoh.Session, keys: _HotKeys) -> None:
        self._receiver: Inbox[Command] = Inbox(session, keys.command, Command.unpack)
        self.publisher = declare_hot_publisher(session, keys.measurement)

    def receive(self, timeout: float | None) -> Command | None:
        """The next command, or None if none arrived within ``timeout`` [s]."""
        try:
            return self._receiver.get(timeout)
        except queue.Empty:
            return None

    def reply(self, measurement: Measurement) -> None:
        """Publish the measurement for the command just taken."""
        self.publisher.put(measurement.pack())

    def serve(
        self,
        respond: Callable[[Command], Measurement],
        stop: threading.Event,
        poll: float = 0.05,
    ) -> int:
        """Answer commands with ``respond`` until ``stop`` is set; return how many were served.

        ``poll`` [s] bounds how long a stop request can go unnoticed while no command arrives.
        """
        check_positive(poll, "poll interval")
        served = 0
        while not stop.is_set():
            command = self.receive(poll)
            if command is not None:
                self.publisher.put(respond(command).pack())
                served += 1
        return served


class RealtimeClient(_Link):
    """Coordinator end for the realtime clock: publish commands, read the newest measurement."""

    def __init__(
        self, session: zenoh.Session, keys: _HotKeys, clock: Callable[[], int] = time.monotonic_ns
    ) -> None:
        self._receiver: Mailbox[Measurement] = Mailbox(
            session, keys.measurement, Measurement.unpack, clock
        )
        self.publisher = declare_hot_publisher(session, keys.command)

    def send(self, command: Command) -> None:
        """Publish a command without waiting."""
        self.publisher.put(command.pack())

    def latest(self) -> Latest[Measurement] | None:
        """The newest measurement and its age [ns], or None before the first one."""
        return self._receiver.latest()

    @property
    def received(self) -> int:
        """Measurements received so far."""
        return self._receiver.received


class RealtimeServer(_Link):
    """Specimen end for the realtime clock: read the newest command, publish measurements."""

    def __init__(
        self, session: zenoh.Session, keys: _HotKeys, clock: Callable[[], int] = time.monotonic_ns
    ) -> None:
        self._receiver: Mailbox[Command] = Mailbox(session, keys.command, Command.unpack, clock)
        self.publisher = declare_hot_publisher(session, keys.measurement)

    def latest(self) -> Latest[Command] | None:
        """The newest command and its age [ns], or None before the first one."""
        return self._receiver.latest()

    def publish(self, measurement: Measurement) -> None:
        """Publish a measurement."""
        self.publisher.put(measurement.pack())


