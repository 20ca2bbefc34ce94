"""Coordinator end of the synchronous real-time link (the ``realtime`` clock; private, import it
from :mod:`rths.wire.transport`): command ``k`` out, measurement ``k`` awaited until the step's
deadline.  The specimen end is :class:`rths.wire.links.LockstepServer`.
"""

from __future__ import annotations

import queue
import time
from collections.abc import Callable
from typing import Any

import zenoh

from rths.core.errors import TransportError, check_nonnegative
from rths.wire.auth import RunSecret
from rths.wire.codec import Command, Measurement, Rows, unpack_reply
from rths.wire.inbox import declare_hot_publisher
from rths.wire.links import COMMAND_DOMAIN, MEASUREMENT_DOMAIN, HotKeys, opened, sealed

__all__ = ["SyncClient"]


class SyncClient:
    """Coordinator end of the synchronous real-time link (the ``realtime`` clock).

    Each step the loop sends command ``k`` and waits for measurement ``k`` until the step's
    deadline, as a lab's controller board does: the specimen process steps once per command and
    answers at once (it is the :class:`LockstepServer`).  A measurement that is not there by the
    deadline is a *miss*: :meth:`exchange` returns None and the loop goes on with the newest
    sample it has (:attr:`newest`); the late measurement is dropped when it arrives.

    The receive side is a direct zenoh callback feeding a :class:`queue.SimpleQueue`, because
    waiting for the deadline needs a wait with a precise timeout (``SimpleQueue.get`` with a
    timeout sleeps in the kernel to the microsecond, with the thread's timer slack lowered by
    :func:`rths.runtime.clocks.realtime_thread`); a FIFO channel's ``recv`` cannot time out.

    Parameters
    ----------
    session, keys
        Open session and the run's keys.
    secret
        The run's secret (commands sealed, measurements opened); None for plain records.
    clock
        Monotonic clock [ns] the deadlines refer to.
    poll
        None (default): the callback and timed wait above.  A period [s]: instead, a FIFO
        channel filled without the GIL, polled with ``try_recv`` and short sleeps until the
        deadline; 0: polled without sleeping (a busy wait that only yields the GIL).  Compared
        in ``tools/bench_zenoh.py``.
    """

    def __init__(
        self,
        session: zenoh.Session,
        keys: HotKeys,
        secret: RunSecret | None = None,
        clock: Callable[[], int] = time.monotonic_ns,
        poll: float | None = None,
    ) -> None:
        self.sealer, _ = sealed(secret, COMMAND_DOMAIN)
        #: Called with the rows (``seq``, ``t_ns``, values) each reply carries
        #: (:func:`rths.wire.codec.unpack_reply`), on the thread that reads the reply; None:
        #: rows are dropped.
        self.on_rows: Callable[[Rows], None] | None = None

        def decode(data: bytes) -> Measurement:
            measurement, rows = unpack_reply(data)
            if rows is not None and self.on_rows is not None:
                self.on_rows(rows)
            return measurement

        self.opener, self._decode = opened(secret, MEASUREMENT_DOMAIN, decode)
        self._clock = clock
        self._queue: queue.SimpleQueue[bytes] = queue.SimpleQueue()
        self._poll = None if poll is None else check_nonnegative(poll, "poll period")
        self._subscriber: Any
        if self._poll is not None:
            self._subscriber = session.declare_subscriber(
                keys.measurement, zenoh.handlers.FifoChannel(1024)
            )
        else:
            put = self._queue.put

            def on_sample(sample: zenoh.Sample) -> None:  # on zenoh's thread: one enqueue
                put(sample.payload.to_bytes())

            self._subscriber = session.declare_subscriber(
                keys.measurement, zenoh.handlers.Callback(on_sample, indirect=False)
            )
        self.publisher = declare_hot_publisher(session, keys.command)
        self.newest: Measurement | None = None  #: the newest measurement received
        self.late = 0  #: measurements that arrived after their step's deadline (dropped)
        self.dropped = 0  #: frames refused by the opener (forged, replayed)

    def send(self, command: Command) -> None:
        """Publish a command without waiting."""
        payload = command.pack()
        self.publisher.put(payload if self.sealer is None else self.sealer.seal(payload))

    def exchange(self, command: Command, deadline_ns: int) -> Measurement | None:
        """Send ``command``; wait until ``deadline_ns`` for the measurement with its ``seq``.

        Parameters
        ----------
        command
            The step's command.
        deadline_ns
            Until when to wait, on the client's clock [ns].

        Returns
        -------
        Measurement or None
            The answer, or None if it did not come in time (a deadline miss).
        """
        self.send(command)
        seq, get, decode = command.seq, self._get, self._decode
        while True:
            raw = get(deadline_ns)
            if raw is None:
                return None
            m = decode(raw)
            if m is None:
                self.dropped += 1
                continue
            if m.is_probe:  # a warm-up probe answered after its deadline: no measurement
                self.late += 1
                continue
            if self.newest is None or m.seq > self.newest.seq:
                self.newest = m
            if m.seq == seq:
                return m
            if m.seq < seq:
                self.late += 1
            else:
                raise TransportError(
                    f"measurement seq={m.seq} is ahead of the command seq={seq}: specimen out "
                    "of step"
                )

    def probe(self, seq: int, deadline_ns: int) -> bool:
        """Send probe ``seq`` (:meth:`rths.wire.codec.Command.probe`: the specimen answers at
        once and moves nothing); wait until ``deadline_ns`` for its answer.

        Parameters
        ----------
        seq
            The probe's number (>= 0); answers to earlier probes are counted late and skipped.
        deadline_ns
            Until when to wait, on the client's clock [ns].

        Returns
        -------
        bool
            Whether the answer came in time.
        """
        self.send(Command.probe(seq))
        while True:
            raw = self._get(deadline_ns)
            if raw is None:
                return False
            m = self._decode(raw)
            if m is None:
                self.dropped += 1
            elif m.is_probe and m.seq == seq:
                return True
            else:  # an earlier probe's answer (no step has been sent yet)
                self.late += 1

    def drain(self, deadline_ns: int) -> int:
        """Read the replies still on their way until none arrives by ``deadline_ns`` (their
        rows reach :attr:`on_rows`); return how many were read.

        Parameters
        ----------
        deadline_ns
            Until when to wait for each, on the client's clock [ns].
        """
        read = 0
        while (raw := self._get(deadline_ns)) is not None:
            if self._decode(raw) is None:
                self.dropped += 1
            else:
                self.late += 1
            read += 1
        return read

    def _get(self, deadline_ns: int) -> bytes | None:
        clock = self._clock
        if self._poll is None:
            left = deadline_ns - clock()
            try:
                return self._queue.get(timeout=left * 1e-9) if left > 0 else self._queue.get(False)
            except queue.Empty:
                return None
        try_recv, pause = self._subscriber.try_recv, self._poll
        while True:
            sample = try_recv()
            if sample is not None:
                return bytes(sample.payload.to_bytes())
            left = deadline_ns - clock()
            if left <= 0:
                return None
            time.sleep(min(pause, left * 1e-9))

    def close(self) -> None:
        """Undeclare the subscriber and the publisher."""
        self._subscriber.undeclare()
        self.publisher.undeclare()

    def __enter__(self) -> SyncClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
