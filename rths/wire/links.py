"""Coordinator and specimen ends of the lockstep link, and the free-running realtime links
(private; import them from :mod:`rths.wire.transport`).  Each pairs a hot publisher with a
receive side from :mod:`rths.wire.inbox`.  The synchronous realtime link's coordinator end is
:mod:`rths.wire.sync_link`; its specimen end is the :class:`LockstepServer`.
"""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Callable
from typing import Any, Protocol

import zenoh

from rths.core.channels import RowBlock
from rths.core.errors import TransportError, check_positive
from rths.wire.auth import Opener, RunSecret, Sealer
from rths.wire.codec import Command, Measurement, pack_reply, unpack_reply
from rths.wire.inbox import Inbox, Latest, Mailbox, declare_hot_publisher

__all__ = [
    "COMMAND_DOMAIN",
    "MEASUREMENT_DOMAIN",
    "CallbackServer",
    "LockstepClient",
    "LockstepServer",
    "RealtimeClient",
    "RealtimeServer",
]

#: HMAC domains of the hot path (:mod:`rths.wire.auth`).
COMMAND_DOMAIN = "command"
MEASUREMENT_DOMAIN = "measurement"


def sealed(secret: RunSecret | None, domain: str) -> tuple[Sealer | None, Opener | None]:
    """The sealer of ``domain`` under ``secret`` (None, None without a secret)."""
    return (None, None) if secret is None else (secret.sealer(domain), None)


def opened(
    secret: RunSecret | None, domain: str, decode: Callable[[bytes], Any]
) -> tuple[Opener | None, Callable[[bytes], Any]]:
    """The opener of ``domain`` under ``secret`` and ``decode`` behind it (None and ``decode``
    as is without a secret)."""
    if secret is None:
        return None, decode
    opener = secret.opener(domain)
    return opener, opener.decoder(decode)


def _measurement_of(data: bytes) -> Measurement:
    """The measurement of a reply (:func:`rths.wire.codec.unpack_reply`), its rows dropped."""
    return unpack_reply(data)[0]


class HotKeys(Protocol):
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
    secret
        The run's secret: commands are sealed and measurements opened with it
        (:mod:`rths.wire.auth`); None sends and accepts plain records (tests, benchmarks).
    """

    def __init__(
        self,
        session: zenoh.Session,
        keys: HotKeys,
        timeout: float = 1.0,
        secret: RunSecret | None = None,
    ) -> None:
        self.timeout = check_positive(timeout, "lockstep timeout")
        self.stale = 0  #: measurements for older steps that were discarded
        self.sealer, _ = sealed(secret, COMMAND_DOMAIN)
        # a reply may carry rows of the specimen's log (a realtime specimen): not kept here
        self.opener, decode = opened(secret, MEASUREMENT_DOMAIN, _measurement_of)
        self._receiver: Inbox[Measurement] = Inbox(session, keys.measurement, decode)
        self.publisher = declare_hot_publisher(session, keys.command)

    def send(self, command: Command) -> None:
        """Publish a command without waiting."""
        payload = command.pack()
        self.publisher.put(payload if self.sealer is None else self.sealer.seal(payload))

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
        self.send(command)
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
    secret
        The run's secret (commands opened, measurements sealed); None for plain records.
    tick
        Resolution [s] of :meth:`receive`'s timeout (the command watchdog's).
    """

    def __init__(
        self,
        session: zenoh.Session,
        keys: HotKeys,
        secret: RunSecret | None = None,
        tick: float = 0.01,
    ) -> None:
        self.sealer, _ = sealed(secret, MEASUREMENT_DOMAIN)
        self.opener, decode = opened(secret, COMMAND_DOMAIN, Command.unpack)
        self._receiver: Inbox[Command] = Inbox(session, keys.command, decode, tick=tick)
        self.publisher = declare_hot_publisher(session, keys.measurement)

    def pending(self) -> Command | None:
        """A command already waiting, without blocking (None if there is none)."""
        return self.receive(0.0)

    def receive(self, timeout: float | None) -> Command | None:
        """The next command, or None if none arrived within ``timeout`` [s]."""
        try:
            return self._receiver.get(timeout)
        except queue.Empty:
            return None

    def reply(self, measurement: Measurement, rows: RowBlock | None = None) -> None:
        """Publish the measurement for the command just taken, with ``rows`` of the specimen's
        log riding on it (:func:`rths.wire.codec.pack_reply`; the ``realtime`` clock) or not."""
        payload = pack_reply(measurement, rows)
        self.publisher.put(payload if self.sealer is None else self.sealer.seal(payload))

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
                self.reply(respond(command))
                served += 1
        return served


class CallbackServer:
    """Specimen end that answers each command inside zenoh's subscriber callback.

    Each command is opened, decoded and handed to ``respond`` on zenoh's receiving thread;
    ``respond`` steps the specimen and publishes the measurement with :meth:`reply` from there
    at once.  No hand-over to another thread, so a round trip costs the specimen process one
    wake-up instead of two (the fastest receive path in ``tools/bench_zenoh.py``, mechanism
    ``reply-in-cb``).  Callbacks of one subscriber run one at a time, in arrival order.  An
    exception in ``respond`` or a malformed payload is kept in :attr:`error` (and ``on_error``
    is called), never lost in zenoh's thread; later commands are then dropped.  ``rths specimen``
    does not use it (publishing while zenoh's thread holds the interpreter lock is a deadlock
    hazard; see :mod:`rths.session.specimen`): it is the ``sync-cb`` mechanism of
    ``tools/bench_zenoh.py``.

    Parameters
    ----------
    session, keys
        Open session and the run's keys.
    respond
        ``respond(command)``, run on zenoh's thread with the GIL held: keep it short.
    secret
        The run's secret (commands opened, measurements sealed); None for plain records.
    on_error
        Called (on zenoh's thread) with the exception that ended serving; None: nothing.
    """

    def __init__(
        self,
        session: zenoh.Session,
        keys: HotKeys,
        respond: Callable[[Command], None],
        secret: RunSecret | None = None,
        on_error: Callable[[BaseException], None] | None = None,
    ) -> None:
        self.sealer, _ = sealed(secret, MEASUREMENT_DOMAIN)
        self.opener, decode = opened(secret, COMMAND_DOMAIN, Command.unpack)
        self.dropped = 0  #: frames the opener refused (forged, replayed)
        self.error: BaseException | None = None  #: what ended serving, if anything did
        self.publisher = declare_hot_publisher(session, keys.measurement)
        self._seal = None if self.sealer is None else self.sealer.seal
        self._put = self.publisher.put

        def on_sample(sample: zenoh.Sample) -> None:  # zenoh's thread, GIL held
            if self.error is not None:
                return
            try:
                command = decode(sample.payload.to_bytes())
                if command is None:
                    self.dropped += 1
                    return
                respond(command)
            except BaseException as exc:  # kept for the serving thread; zenoh would only print
                self.error = exc
                if on_error is not None:
                    on_error(exc)

        self._subscriber = session.declare_subscriber(
            keys.command, zenoh.handlers.Callback(on_sample, indirect=False)
        )

    def reply(self, measurement: Measurement) -> None:
        """Publish the measurement for the command being answered.

        Parameters
        ----------
        measurement
            The specimen's answer (same ``seq`` as the command).
        """
        payload = measurement.pack()
        self._put(payload if self._seal is None else self._seal(payload))

    def close(self) -> None:
        """Undeclare the subscriber and the publisher (``respond`` should refuse work by then:
        a callback already running may still finish)."""
        self._subscriber.undeclare()
        self.publisher.undeclare()

    def __enter__(self) -> CallbackServer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


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
        self, session: zenoh.Session, keys: HotKeys, clock: Callable[[], int] = time.monotonic_ns
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
        self, session: zenoh.Session, keys: HotKeys, clock: Callable[[], int] = time.monotonic_ns
    ) -> None:
        self._receiver: Mailbox[Command] = Mailbox(session, keys.command, Command.unpack, clock)
        self.publisher = declare_hot_publisher(session, keys.measurement)

    def latest(self) -> Latest[Command] | None:
        """The newest command and its age [ns], or None before the first one."""
        return self._receiver.latest()

    def publish(self, measurement: Measurement) -> None:
        """Publish a measurement."""
        self.publisher.put(measurement.pack())
