"""Side streams of a run (private; import from :mod:`rths.wire.transport`): JSON log records another
process publishes (:class:`LogPublisher`, :class:`BackgroundPublisher`) and the coordinator's
:class:`LogBridge` that feeds them into the MCAP recorder.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any, Protocol

import zenoh

from rths.core.channels import RowBlock
from rths.core.errors import DataError
from rths.wire.auth import Opener, RunSecret
from rths.wire.codec import BLOCK_MAGIC, LogRecord, pack_frames, unpack_block
from rths.wire.keys import RunKeys

#: Largest frame of rows [bytes] a side stream sends: a larger block goes out in several frames
#: (:func:`rths.wire.codec.pack_frames`).  Zenoh's low-latency transport drops a message larger
#: than one batch without a word (48 000 bytes passed, 56 000 did not); the loop's 256-row live
#: copy is 92 kB.
MAX_FRAME_BYTES = 32_000

__all__ = ["BackgroundPublisher", "BlockPublisher", "LogBridge", "LogPublisher", "RecordSink"]


class LogPublisher:
    """Publish :class:`rths.wire.codec.LogRecord` s on ``rths/<run>/log/<name>`` for the recorder.

    Parameters
    ----------
    session, keys
        Open session and the run's keys.
    name
        Stream name, e.g. ``"specimen"`` (recorded as MCAP topic ``rths/specimen``).
    secret : rths.wire.auth.RunSecret or None
        The run's secret: each payload is sealed (domain: the key), so the recorder can tell
        it from a forged one.  None (default): plain payloads.

    For slower, self-describing side streams of another process (e.g. the specimen's internal
    state); the coordinator's :class:`rths.log.recorder.LogBridge` records them as MCAP topic
    ``rths/<name>``.  Reliable with congestion control BLOCK: a record is never dropped by the
    transport, and the recorder counts gaps in ``seq`` anyway.
    """

    def __init__(
        self, session: zenoh.Session, keys: RunKeys, name: str, secret: RunSecret | None = None
    ) -> None:
        self.key = keys.log(name)
        self.seq = 0  #: seq of the next record
        self._sealer = None if secret is None else secret.sealer(self.key)
        self._publisher = session.declare_publisher(
            self.key,
            congestion_control=zenoh.CongestionControl.BLOCK,
            reliability=zenoh.Reliability.RELIABLE,
        )

    def put(self, log_time_ns: int, message: Mapping[str, Any]) -> None:
        """Publish one record; ``seq`` counts up from 0.

        Parameters
        ----------
        log_time_ns
            Simulated time [ns] the record refers to.
        message
            JSON-serialisable mapping of named values in SI units.
        """
        payload = LogRecord(self.seq, log_time_ns, message).encode()
        self._publisher.put(payload if self._sealer is None else self._sealer.seal(payload))
        self.seq += 1

    def close(self) -> None:
        """Undeclare the publisher."""
        self._publisher.undeclare()

    def __enter__(self) -> LogPublisher:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class BackgroundPublisher:
    """Publish log records from a background thread, so the caller only enqueues (~1 µs).

    JSON encoding and the zenoh put (which can block for ~100 µs under congestion control
    BLOCK) happen off the caller's thread -- the real-time loop or the specimen's step.

    Parameters
    ----------
    session
        Open zenoh session.
    key
        Key expression to publish on.
    reliable
        True: reliable with congestion control BLOCK (the recorder sees every record; the
        queue absorbs congestion).  False: best effort, dropped under congestion (live copies
        for monitors).
    secret
        The run's secret: each payload is sealed (domain: the key), so the recorder can tell
        it from a forged one.  None: plain payloads.
    """

    def __init__(
        self,
        session: zenoh.Session,
        key: str,
        *,
        reliable: bool = True,
        secret: RunSecret | None = None,
    ) -> None:
        import queue
        import threading

        self.key = key
        self._sealer = None if secret is None else secret.sealer(key)
        self._reliable = reliable
        self.seq = 0  #: seq of the next record
        congestion = zenoh.CongestionControl.BLOCK if reliable else zenoh.CongestionControl.DROP
        self._publisher = session.declare_publisher(
            key,
            congestion_control=congestion,
            reliability=zenoh.Reliability.RELIABLE if reliable else zenoh.Reliability.BEST_EFFORT,
        )
        self._queue: queue.SimpleQueue[Any] = queue.SimpleQueue()
        self._thread = threading.Thread(target=self._run, name=f"publish {key}", daemon=True)
        self._thread.start()

    def put(self, log_time_ns: int, message: Mapping[str, Any]) -> None:
        """Queue one record (``seq`` counts up from 0); ``message`` must not change afterwards."""
        self._queue.put((self.seq, log_time_ns, message))
        self.seq += 1

    def _run(self) -> None:
        """Drain the queue every 5 ms (polling: the producer's put never wakes this thread)."""
        import queue
        import time

        get, put = self._queue.get_nowait, self._publisher.put
        while True:
            time.sleep(0.005)
            while True:
                try:
                    item = get()
                except queue.Empty:
                    break
                if item is None:
                    return
                if not self._reliable and not self._watched():
                    continue  # a live copy nobody watches: neither encoded nor sent
                for payload in self._encode(item):
                    put(payload)

    def _watched(self) -> bool:
        """Whether a subscriber matches the publisher now."""
        return bool(self._publisher.matching_status.matching)  # type: ignore[attr-defined]

    def _encode(self, item: Any) -> list[bytes]:
        if isinstance(item, RowBlock):  # frames that fit one batch of any zenoh transport
            payloads = pack_frames(item, MAX_FRAME_BYTES)
        else:
            payloads = [LogRecord(*item).encode()]
        if self._sealer is None:
            return payloads
        return [self._sealer.seal(p) for p in payloads]

    def close(self) -> None:
        """Publish what is queued, then undeclare the publisher."""
        self._queue.put(None)
        self._thread.join()
        self._publisher.undeclare()

    def __enter__(self) -> BackgroundPublisher:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class BlockPublisher(BackgroundPublisher):
    """Publish :class:`rths.core.channels.RowBlock` s (binary frames, :func:`pack_block`) from a
    background thread: the producer hands over a full block and returns.

    Parameters
    ----------
    session : zenoh.Session
        Open zenoh session.
    key : str
        Key expression to publish on.
    reliable : bool
        True (default): reliable with congestion control BLOCK; False: best effort, dropped
        under congestion and not sent at all while no subscriber matches (live copies for
        monitors).
    secret : rths.wire.auth.RunSecret or None
        The run's secret: each frame is sealed (domain: the key).  None (default): plain.
    """

    def put_block(self, block: RowBlock) -> None:
        """Queue a filled block; it must not change afterwards."""
        self._queue.put(block)

    def __enter__(self) -> BlockPublisher:
        return self


class RecordSink(Protocol):
    """What :class:`LogBridge` feeds: :class:`rths.log.recorder.Recorder` satisfies it."""

    def put_record(self, topic: str, payload: bytes) -> None:
        """Queue an encoded :class:`rths.wire.codec.LogRecord` for ``topic`` without blocking."""

    def put_block(self, topic: str, block: RowBlock) -> None:
        """Queue a block of rows for ``topic`` without blocking."""


class LogBridge:
    """Record the JSON log streams other processes publish on ``rths/<run>/log/**``.

    A thread drains a zenoh FIFO channel every 5 ms into ``Recorder.put_record`` (an enqueue);
    the record for key ``rths/<run>/log/<name>`` lands on MCAP topic ``rths/<name>``.

    Parameters
    ----------
    session
        Open zenoh session (the coordinator's).
    keys
        The run's :class:`rths.wire.transport.RunKeys`.
    recorder
        A started :class:`rths.log.recorder.Recorder` (anything with its ``put_record`` and
        ``put_block``).
    secret
        The run's secret: a payload is recorded only if it verifies (one opener per key);
        forged and replayed ones are dropped and counted (:meth:`refused`).  None: plain.
    """

    def __init__(
        self,
        session: zenoh.Session,
        keys: RunKeys,
        recorder: RecordSink,
        secret: RunSecret | None = None,
    ) -> None:
        import threading

        self._keys = keys
        self._recorder = recorder
        self._secret = secret
        self._openers: dict[str, Opener] = {}
        self.received = 0  #: payloads received
        self.dropped = 0  #: payloads the recorder refused (closed or failed) -- lost, but counted
        # A FIFO channel filled by zenoh's threads without the GIL, drained every 5 ms by one
        # thread: no Python callback per record competes with a real-time loop for the GIL.
        self._subscriber = session.declare_subscriber(
            keys.log_all, zenoh.handlers.FifoChannel(1 << 16)
        )
        self._stop = threading.Event()
        self._drained = threading.Condition()
        self._thread = threading.Thread(target=self._run, name="log bridge", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(0.005):
            self._drain()
            with self._drained:
                self._drained.notify_all()
        self._drain()
        with self._drained:
            self._drained.notify_all()

    def wait_for(self, condition: Callable[[LogBridge], bool], timeout: float | None) -> bool:
        """Block until ``condition(self)`` holds after a drain of the channel (the counters
        :attr:`received` and :attr:`dropped` are up to date then), or ``timeout`` [s] passes.

        Parameters
        ----------
        condition
            Predicate on this bridge, e.g. ``lambda b: b.received >= 100``.
        timeout
            Longest wait [s]; None waits as long as it takes.

        Returns
        -------
        bool
            The condition's last value.
        """
        with self._drained:
            return self._drained.wait_for(lambda: condition(self), timeout)

    def _drain(self) -> None:
        try_recv = self._subscriber.try_recv
        while (sample := try_recv()) is not None:
            self.received += 1
            key = str(sample.key_expr)
            payload: bytes | None = sample.payload.to_bytes()
            if self._secret is not None:
                opener = self._openers.get(key)
                if opener is None:
                    opener = self._openers[key] = self._secret.opener(key)
                payload = opener.open(payload)  # type: ignore[arg-type]
                if payload is None:
                    continue  # forged or replayed: counted by the opener, never recorded
            try:
                topic = self._keys.topic_of(key)
                if payload.startswith(BLOCK_MAGIC):  # type: ignore[union-attr]
                    self._recorder.put_block(topic, unpack_block(payload))  # type: ignore[arg-type]
                else:
                    self._recorder.put_record(topic, payload)  # type: ignore[arg-type]
            except DataError:  # closed/failed recorder or a malformed block: counted
                self.dropped += 1

    def refused(self) -> dict[str, dict[str, int]]:
        """Per key: payloads accepted, and dropped as forged or replayed."""
        return {key: o.counts() for key, o in self._openers.items()}

    def close(self) -> None:
        """Record what has arrived, then undeclare the subscriber."""
        self._stop.set()
        self._thread.join()
        self._subscriber.undeclare()

    def __enter__(self) -> LogBridge:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
