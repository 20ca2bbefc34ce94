"""Coordinator and specimen ends of the lockstep and realtime links (private; import them from
:mod:`rths.wire.transport`).  Each pairs a hot publisher with a receive side from
:mod:`rths.wire.inbox`.
"""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Callable
from typing import Any, Protocol

import zenoh

from rths.core.errors import TransportError, check_positive
from rths.wire.codec import Command, Measurement
from rths.wire.inbox import Inbox, Latest, Mailbox, declare_hot_publisher

__all__ = ["LockstepClient", "LockstepServer", "RealtimeClient", "RealtimeServer"]


class _HotKeys(Protocol):
    """The two keys a link needs (:class:`rths.wire.transport.RunKeys` provides them)."""

    @property
    def command(self) -> str: ...

    @property
    def measurement(self) -> str: ...


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
        """Send ``command``; return the measurement with the same ``seq`` (:meth:`receive`)."""
        self.publisher.put(command.pack())
        return self.receive(command.seq, timeout)

    def abort(self) -> None:
        """Wake a waiting :meth:`receive` at once (it raises :class:`TransportError`) and refuse
        later ones: the peer is known to be gone.  Thread-safe; the publisher stays until
        :meth:`close`."""
        self._receiver.close()


class LockstepServer(_Link):
    """Specimen end of the lockstep link: take each command in order, publish its measurement.

    Parameters
    ----------
    session, keys
        Open session and the run's keys.
    """

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
        """Answer commands until ``stop`` is set; return how many were served.

        Parameters
        ----------
        respond
            The specimen's step: command in, measurement (same ``seq``) out.
        stop
            Set by another thread (e.g. :attr:`rths.wire.transport.Presence.stop`) to end serving.
        poll
            Longest time [s] a stop request goes unnoticed while no command arrives.
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
    """Coordinator end for the realtime clock: publish commands, read the newest measurement.

    Parameters
    ----------
    session, keys
        Open session and the run's keys.
    clock
        Monotonic clock [ns] that stamps arrivals (see :class:`Mailbox`).
    """

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
    """Specimen end for the realtime clock: read the newest command, publish measurements.

    Parameters
    ----------
    session, keys
        Open session and the run's keys.
    clock
        Monotonic clock [ns] that stamps arrivals (see :class:`Mailbox`).
    """

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
