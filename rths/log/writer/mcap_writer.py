"""The writer thread behind :class:`rths.log.recorder.Recorder` (private).

It owns the ``mcap`` writer and the output stream; everything it does -- JSON encoding, gap
counting, chunk compression, flushing -- happens here, never on the loop thread. It runs in the
recorder's process (``writer="thread"``) or in a writer process of its own (``writer="process"``,
:mod:`rths.log.writer.writer_process`), where the same items arrive over a pipe. It consumes tagged
tuples from a :class:`queue.SimpleQueue`:

* ``("s", topic, schema_json_bytes)`` -- register a topic;
* ``("m", topic, seq, log_time_ns, publish_time_ns, message)`` -- a message from this process;
* ``("r", topic, payload)`` -- a :class:`rths.wire.codec.LogRecord` from another process;
* ``("b", topic, row_block)`` -- a :class:`rths.core.channels.RowBlock`, one message per row;
* ``("e", log_time_ns, event_dict)`` -- an event (sequence numbers assigned here);
* ``("x", topic, seq, log_time_ns, reason)`` -- a message that could not reach this writer
  (counted as rejected, with an event);
* ``("w", threading.Event)`` -- set once everything queued before it is flushed to the file
  (by the next periodic flush; at once if nothing is pending; at the end of the file);
* :data:`STOP` -- finish the file and end.

When something endangers the log -- the disk space reserve can no longer be renewed (the disk is
nearly full) or a write failed -- the thread calls ``on_fault(message)`` once, so the run can be
stopped while the log is whole. After a failure it keeps draining the queue until :data:`STOP`
(producers never block or fail), counts the messages it could not write as ``lost`` and ends the
file readably (:meth:`rths.log.writer.logfile.LogFile.close_salvaged`) with the metadata queued
meanwhile -- the run's summary among them.
"""

from __future__ import annotations

import json
import queue
import shutil
import threading
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
from mcap.writer import CompressionType

from rths import __version__
from rths.core.errors import DataError
from rths.log.schemas import EVENTS_TOPIC
from rths.log.writer.block_writer import BlockWriter
from rths.log.writer.logfile import LogFile
from rths.log.writer.rowjson import (
    LENIENT,
    STRICT,
    block_json,
    block_messages,
    finite,
    open_schema,
)
from rths.log.writer.summary import COUNTS, TopicStats
from rths.wire.codec import LogRecord

__all__ = ["POLL", "STOP", "ZSTD_LEVEL", "WriterThread", "messages_in"]

STOP = object()

#: Seconds between two drains of the writer's queue.
POLL = 0.005
#: zstd level of the chunks: on the seed scenario's rows level 1 compresses a 1 MiB chunk in
#: ~60 % of the time level 3 (``mcap``'s) takes, and ~5 % smaller.
ZSTD_LEVEL = 1
_COMPRESSION = {
    "zstd": CompressionType.ZSTD,
    "lz4": CompressionType.LZ4,
    "none": CompressionType.NONE,
}


def messages_in(item: tuple[Any, ...]) -> int:
    """How many messages a queued item carries (events and metadata: none).

    Parameters
    ----------
    item
        A queued item (module docstring).
    """
    if item[0] in ("m", "r"):
        return 1
    if item[0] == "b":
        return int(item[2].count)
    return 0


class _Topic:
    """Channel id and counters of one topic (writer thread only)."""

    __slots__ = ("channel_id", *COUNTS)

    def __init__(self, channel_id: int) -> None:
        self.channel_id = channel_id
        self.written = self.missing = self.reordered = self.nonfinite = self.rejected = 0
        self.first_seq = self.last_seq = -1


class WriterThread(threading.Thread):
    """Background thread that drains ``inbox`` into an MCAP file (see the module docstring).

    After :data:`STOP` it writes the ``rths.recording`` metadata record and finishes the file
    (footer and summary), also if something failed on the way; the first failure is kept in
    :attr:`error` and the counts in :meth:`stats`.

    Parameters
    ----------
    stream
        The output file (:class:`rths.log.writer.logfile.LogFile`).
    inbox
        The queue the producers fill (module docstring).
    metadata
        Metadata records written first.
    compression
        ``"zstd"``, ``"lz4"`` or ``"none"``.
    chunk_size
        Uncompressed bytes per chunk [B].
    flush_interval
        Wall time [s] between two flushes of the current chunk.
    on_fault
        Called once with a message when the log is in danger (module docstring).
    compiled
        Pack row blocks into records with the compiled kernel of
        :mod:`rths.log.writer.rowpack` (imports numba; the same bytes as the interpreted path).
    """

    def __init__(
        self,
        stream: LogFile,
        inbox: queue.SimpleQueue[Any],
        metadata: Mapping[str, Mapping[str, str]],
        compression: str,
        chunk_size: int,
        flush_interval: float,
        on_fault: Callable[[str], None] | None = None,
        compiled: bool = False,
    ) -> None:
        super().__init__(name="rths-recorder", daemon=True)
        self.error: BaseException | None = None
        self.fault: str | None = None
        self.lost = 0
        self.max_backlog = 0
        self.events = 0
        self._on_fault = on_fault
        self._late_metadata: dict[str, dict[str, str]] = {}
        self._rows_done = 0
        self._stream = stream
        self._inbox = inbox
        self._metadata = metadata
        self._writer = BlockWriter(
            stream,  # a binary stream: write, tell, flush
            chunk_size=chunk_size,
            compression=_COMPRESSION[compression],
            zstd_level=ZSTD_LEVEL,
        )
        self._flush_interval = flush_interval
        self._topics: dict[str, _Topic] = {}
        self._templates: dict[tuple[str, ...], bytes] = {}
        self._packer: Any = None
        if compiled:
            from rths.log.writer.rowpack import RowPacker  # numba: only where it is wanted

            self._packer = RowPacker()
        self._dirty = False
        self._last_flush = time.monotonic()
        self._flush_waiters: list[threading.Event] = []

    @classmethod
    def open(
        cls,
        path: str | Path,
        inbox: queue.SimpleQueue[Any],
        config: Mapping[str, Any],
        on_fault: Callable[[str], None] | None = None,
    ) -> WriterThread:
        """Create the file (:class:`rths.log.writer.logfile.LogFile`) and its writer; ``config``
        holds ``reserve`` [B] and the other parameters of the class by name.

        Raises
        ------
        OSError
            If the file cannot be created or its reserve not allocated.
        """
        stream = LogFile(path, config["reserve"])
        return cls(
            stream,
            inbox,
            config["metadata"],
            config["compression"],
            config["chunk_size"],
            config["flush_interval"],
            on_fault,
            bool(config.get("compiled", False)),
        )

    def stats(self) -> dict[str, TopicStats]:
        """Counts per topic so far (``rths/events`` excluded)."""
        return {
            name: TopicStats(**{c: getattr(t, c) for c in COUNTS})
            for name, t in self._topics.items()
            if name != EVENTS_TOPIC
        }

    def run(self) -> None:
        """Write the header and metadata, drain the queue until :data:`STOP`, finish the file."""
        try:
            self._writer.start(profile="", library=f"rths {__version__}")
            for name, data in self._metadata.items():
                self._writer.add_metadata(name, dict(data))
            self._drain()
        except BaseException as exc:  # kept and re-raised by Recorder on the caller's thread
            self.error = exc
            self._notify(f"recording to '{self._stream.path}' failed: {exc!r}")
            self._drain_failed()
        finally:
            self._finish()
            self._wake_flush_waiters()

    def _notify(self, message: str) -> None:
        """Tell the run (once) that the log is in danger."""
        if self.fault is not None:
            return
        self.fault = message
        if self._on_fault is not None:
            try:
                self._on_fault(message)
            except Exception:  # the callback's problem must not cost the log
                pass

    def _drain_failed(self) -> None:
        """After a failure: consume the queue until :data:`STOP`, keep metadata, count the rest."""
        while True:
            time.sleep(POLL)
            while True:
                try:
                    item = self._inbox.get_nowait()
                except queue.Empty:
                    break
                if item is STOP:
                    return
                if item[0] == "md":
                    self._late_metadata[item[1]] = dict(item[2])
                elif item[0] == "w":
                    item[1].set()  # nothing more will reach the disk: do not keep it waiting
                else:
                    self.lost += messages_in(item)

    def _finish(self) -> None:
        summary = {"complete": "true", "max_backlog": str(self.max_backlog)}
        for name, stats in self.stats().items():
            summary.update({f"{name}.{c}": str(getattr(stats, c)) for c in COUNTS})
            if not stats.complete:
                summary["complete"] = "false"
        if self.error is not None:
            summary.update(complete="false", failed=repr(self.error), lost=str(self.lost))
        if self.fault is not None:
            summary["fault"] = self.fault
        if self._stream.error is None:
            try:
                for name, data in self._late_metadata.items():
                    self._writer.add_metadata(name, data)
                self._writer.add_metadata("rths.recording", summary)
                self._writer.finish()
            except BaseException as exc:
                self.error = self.error or exc
            else:
                try:
                    self._stream.close_finished()
                except OSError as exc:
                    self.error = self.error or exc
                return
        self._stream.close_salvaged({**self._late_metadata, "rths.recording": summary})

    def _drain(self) -> None:
        """Poll the queue every :data:`POLL` seconds and write everything waiting.

        Polling, rather than blocking in ``get``, means a producer's ``put`` never wakes this
        thread: a real-time loop thread does not hand the GIL over once per message.
        """
        get, interval = self._inbox.get_nowait, self._flush_interval
        while True:
            time.sleep(POLL)
            handled = 0
            while True:
                if handled % 256 == 0:  # the largest backlog seen, sampled while draining
                    self.max_backlog = max(self.max_backlog, self._inbox.qsize())
                try:
                    item = get()
                except queue.Empty:
                    break
                if item is STOP:
                    return
                try:
                    self._handle(item)
                except BaseException:
                    self.lost += messages_in(item) - self._rows_done  # those not written
                    raise
                handled += 1
                # after every item, not only when the queue is empty: a producer that keeps it
                # full (the fast clock) must still be stopped while the reserve holds
                self._renew()
            if self._dirty and time.monotonic() - self._last_flush >= interval:
                self._writer.flush()
                self._dirty = False
                self._last_flush = time.monotonic()
                self._wake_flush_waiters()
            self._renew()

    def _wake_flush_waiters(self) -> None:
        """Tell :meth:`Recorder.wait_flushed` callers their messages are on disk."""
        for waiter in self._flush_waiters:
            waiter.set()
        self._flush_waiters.clear()

    def _renew(self) -> None:
        """Keep the disk-space reserve ahead of the data; ask for a stop when it cannot be."""
        if not self._stream.renew() and self.fault is None:
            free = shutil.disk_usage(self._stream.path.parent).free
            self._notify(f"disk nearly full: {free / 2**20:.1f} MiB free for '{self._stream.path}'")

    def _handle(self, item: tuple[Any, ...]) -> None:
        self._rows_done = 0  # rows of a block written so far (for the lost count on failure)
        tag = item[0]
        if tag == "m":
            _, topic, seq, log_time, publish_time, message = item
            self._write(topic, seq, log_time, publish_time, message)
        elif tag == "b":
            self._block(item[1], item[2])
        elif tag == "r":
            self._record(item[1], item[2])
        elif tag == "e":
            self._event(item[1], item[2])
        elif tag == "s":
            self._register(item[1], item[2])
        elif tag == "w":  # a flush waiter: woken by the next periodic flush (or now, if clean)
            self._flush_waiters.append(item[1])
            if not self._dirty:
                self._wake_flush_waiters()
        elif tag == "md":
            self._writer.add_metadata(item[1], dict(item[2]))
        elif tag == "x":  # a message that could not be handed to this writer: rejected
            _, topic, seq, log_time, reason = item
            self._topics[topic].rejected += 1
            self._event(log_time, {"kind": "rejected", "message": f"{topic} seq {seq}: {reason}"})

    def _register(self, topic: str, schema: bytes) -> _Topic:
        schema_id = self._writer.register_schema(name=topic, encoding="jsonschema", data=schema)
        channel_id = self._writer.register_channel(
            topic=topic, message_encoding="json", schema_id=schema_id
        )
        entry = self._topics[topic] = _Topic(channel_id)
        return entry

    def _write(
        self, topic: str, seq: int, log_time: int, publish_time: int, message: Mapping[str, Any]
    ) -> None:
        entry = self._topics[topic]
        try:
            data = STRICT.encode(message)
        except ValueError:
            data = LENIENT.encode(finite(message))
            entry.nonfinite += 1
        except TypeError as exc:
            entry.rejected += 1
            self._event(log_time, {"kind": "rejected", "message": f"{topic} seq {seq}: {exc}"})
            return
        self._add(topic, seq, log_time, publish_time, data.encode())

    def _add(self, topic: str, seq: int, log_time: int, publish_time: int, data: bytes) -> None:
        """Write encoded JSON ``data`` and keep the counts (sequence gaps, reordering)."""
        entry = self._topics[topic]
        self._writer.add_message(entry.channel_id, log_time, data, publish_time, seq & 0xFFFFFFFF)
        self._dirty = True
        entry.written += 1
        last = entry.last_seq
        if last < 0:
            entry.first_seq = seq
        if seq > last + 1:
            entry.missing += seq - last - 1
            self._event(
                log_time,
                {
                    "kind": "gap",
                    "message": f"{topic}: expected seq {last + 1}, got {seq}",
                    "topic": topic,
                    "missing": seq - last - 1,
                },
            )
        elif seq <= last:
            entry.reordered += 1
            self._event(
                log_time,
                {
                    "kind": "reordered",
                    "message": f"{topic}: seq {seq} after {last}",
                    "topic": topic,
                },
            )
        entry.last_seq = max(last, seq)

    def _block(self, topic: str, block: Any) -> None:
        """Write the rows of a :class:`rths.core.channels.RowBlock` (:func:`block_messages`).

        A block that continues its topic's sequence without a gap goes to the file in one
        :meth:`BlockWriter.add_messages` call; any other takes the per-row path, which writes a
        gap or reordering event among the rows.  Both write the same file.
        """
        entry = self._topics[topic]
        self._rows_done = 0
        n = block.count
        seq = block.seq[:n]
        if n and seq[0] == entry.last_seq + 1 and (n == 1 or bool((np.diff(seq) == 1).all())):
            times = block.t_ns[:n]
            packed = None if self._packer is None else self._packer.pack(block, entry.channel_id)
            if packed is None:
                data, nonfinite = block_json(block, self._templates)
                self._writer.add_messages(entry.channel_id, seq & 0xFFFFFFFF, times, times, data)
            else:
                self._writer.add_records(entry.channel_id, times, packed[0], packed[1])
                nonfinite = packed[2]
            self._rows_done = n
            self._dirty = True
            if entry.last_seq < 0:
                entry.first_seq = int(seq[0])
            entry.last_seq = int(seq[-1])
            entry.written += n
            entry.nonfinite += nonfinite
            return
        self._block_rows(topic, block)

    def _block_rows(self, topic: str, block: Any) -> None:
        """Write the rows of a block one message at a time (the reference path)."""
        entry = self._topics[topic]
        self._rows_done = 0
        for k, t, data, ok in block_messages(block, self._templates):
            if not ok:
                entry.nonfinite += 1
            self._add(topic, k, t, t, data)
            self._rows_done += 1

    def _record(self, topic: str, payload: bytes) -> None:
        """Write a record from another process; its JSON is written as received unless it
        carries a non-finite number (JSON has none), which takes the decode/clean path."""
        try:
            seq, log_time, body = LogRecord.split(payload)
            if b"NaN" not in body and b"Infinity" not in body:
                if topic not in self._topics:
                    self._register(topic, open_schema(topic))
                self._add(topic, seq, log_time, log_time, body)
                return
            record = LogRecord.decode(payload)
        except DataError as exc:
            entry = self._topics.get(topic) or self._register(topic, open_schema(topic))
            entry.rejected += 1
            self._event(0, {"kind": "rejected", "message": f"{topic}: {exc}", "topic": topic})
            return
        if topic not in self._topics:
            self._register(topic, open_schema(topic))
        self._write(topic, record.seq, record.log_time_ns, record.log_time_ns, record.message)

    def _event(self, log_time: int, event: Mapping[str, Any]) -> None:
        entry = self._topics[EVENTS_TOPIC]
        data = json.dumps(finite(event), separators=(",", ":"), default=str).encode()
        self._writer.add_message(entry.channel_id, log_time, data, log_time, self.events)
        entry.written += 1
        self.events += 1
        self._dirty = True
