"""MCAP recording off the loop thread (design.md §4).

The loop thread only calls :meth:`Recorder.put` / :meth:`Recorder.put_block`, which put a tuple on a
:class:`queue.SimpleQueue` and return: no JSON encoding, no compression, no I/O.  A writer
(:class:`rths.log.writer.mcap_writer.WriterThread`) encodes each message as JSON, writes it to an
MCAP file with the ``mcap`` package (one ``jsonschema`` schema per topic, chunks zstd-compressed at
level 1, ``log_time`` = simulated time [ns]), counts per topic the messages written and the gaps in
their sequence numbers, and finishes the file -- footer and summary -- when the recorder is closed,
also when the ``with`` body raises. The writer runs as a thread of this process
(``writer="thread"``, the default: the ``fast`` clock, tests) or in a process of its own at ordinary
priority (``writer="process"``, :mod:`rths.log.writer.writer_process`: the ``realtime`` and
``lockstep`` clocks), where it neither holds this process's GIL nor competes with the loop for the
CPU; that process also finishes the file if this one is killed.

Log contract (read it with ``mcap.reader.make_reader``, no project code needed):

* every message is UTF-8 JSON; its channel's schema (encoding ``jsonschema``) documents the
  required fields with their units (further fields, e.g. ``ctrl_*`` and ``sub_*`` on
  ``rths/loop``, are allowed and described in the README's log contract); ``Message.sequence`` is
  the producer's step counter (mod 2**32); ``log_time`` and ``publish_time`` are simulated time [ns]
  unless the producer passed another ``publish_time``;
* ``rths/loop`` (:data:`LOOP_SCHEMA`) carries one record per loop step; ``rths/events``
  (:data:`EVENTS_SCHEMA`) carries run events, including ``gap`` events the recorder writes itself
  when a sequence number is skipped and an ``error`` event when the run ends by an exception;
* non-finite floats are written as ``null`` (JSON has no NaN) and counted;
* run metadata are MCAP metadata records (name → string map) written first; a record named
  ``rths.recording`` with the per-topic counts is written last.

:class:`rths.wire.transport.LogBridge` feeds the :class:`rths.wire.codec.LogRecord` s that another
process publishes on ``rths/<run>/log/**`` into :meth:`Recorder.put_record`; they are decoded by
the writer too.  This module does not import zenoh.
"""

from __future__ import annotations

import errno
import json
import operator
import os
import queue
import threading
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, Literal

from rths import __version__
from rths.core.channels import RowBlock
from rths.core.errors import (
    DataError,
    ParameterError,
    check_positive,
    check_positive_int,
)
from rths.log.schemas import (
    EVENTS_SCHEMA,
    EVENTS_TOPIC,
    LOOP_SCHEMA,
    LOOP_TOPIC,
    block_schema,
    check_metadata,
    object_schema,
)
from rths.log.writer.logfile import RESERVE
from rths.log.writer.mcap_writer import POLL, STOP, WriterThread
from rths.log.writer.summary import RecordingFailed, RecordingSummary, TopicStats
from rths.log.writer.writer_process import WriterProcess

__all__ = [
    "EVENTS_SCHEMA",
    "EVENTS_TOPIC",
    "LOOP_SCHEMA",
    "LOOP_TOPIC",
    "RESERVE",
    "Recorder",
    "RecordingFailed",
    "RecordingSummary",
    "TopicStats",
    "block_schema",
    "object_schema",
]

_Compression = Literal["zstd", "lz4", "none"]
_Writer = Literal["thread", "process"]


class Recorder:
    """Write an MCAP log from a background thread; the loop only enqueues.

    Parameters
    ----------
    path
        Output file (created or overwritten; its directory must exist).
    topics
        ``{topic: JSON schema}`` registered up front (default: ``rths/loop``).  ``rths/events``
        is always registered.  More can be added with :meth:`add_topic`.
    metadata
        Run metadata, ``{record name: {key: value}}``, all strings (scenario text, package
        version, units, scale factors, ...).  The package version is added to a record
        ``rths`` unless given.
    compression
        Chunk compression: ``"zstd"`` (default), ``"lz4"`` or ``"none"``.
    chunk_size
        Uncompressed bytes per chunk [B].
    flush_interval
        Wall time [s] after which the writer finishes the current chunk and flushes the file,
        bounding what a crashed process loses.
    reserve
        Disk space [B] kept allocated past the data (:mod:`rths.log.writer.logfile`); 0: none.
    on_fault
        Called once, from the writer thread (or, with ``writer="process"``, the thread that
        reads the writer process's reports), with a message when the log is in danger: the disk
        is nearly full (the reserve can no longer be renewed), a write failed, or the writer
        process died.  A run stops on it, so that its log stays whole.
    writer
        ``"thread"`` (default): the writer is a thread of this process.  ``"process"``: it runs
        in a process of its own at ordinary priority, nice +10
        (:mod:`rths.log.writer.writer_process`); for real-time runs.

    Examples
    --------
    >>> with Recorder("run.mcap", metadata={"scenario": {"text": toml}}) as rec:  # doctest: +SKIP
    ...     for k in range(n):
    ...         rec.put(LOOP_TOPIC, k, t_ns, {"t": t, "target": r, ...})
    >>> rec.summary.complete  # doctest: +SKIP
    True
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        topics: Mapping[str, Mapping[str, Any]] | None = None,
        metadata: Mapping[str, Mapping[str, str]] | None = None,
        compression: _Compression = "zstd",
        chunk_size: int = 1 << 20,
        flush_interval: float = 1.0,
        reserve: int = RESERVE,
        on_fault: Callable[[str], None] | None = None,
        writer: _Writer = "thread",
    ) -> None:
        self.path = Path(path)
        if writer not in ("thread", "process"):
            raise ParameterError(f"writer must be 'thread' or 'process'; got {writer!r}")
        self._mode = writer
        self._on_fault = on_fault
        if compression not in ("zstd", "lz4", "none"):
            raise ParameterError(
                f"compression must be 'zstd', 'lz4' or 'none'; got {compression!r}"
            )
        metadata = check_metadata(metadata or {})
        metadata.setdefault("rths", {"version": __version__})
        self._config = {  # what the writer needs (WriterThread.open)
            "reserve": int(reserve),
            "metadata": metadata,
            "compression": compression,
            "chunk_size": check_positive_int(chunk_size, "chunk_size"),
            "flush_interval": check_positive(flush_interval, "flush_interval"),
            "compiled": writer == "thread",  # numba: in process (the loop has it), not in a child
        }
        self._schemas: dict[str, bytes] = {}
        self._queue: queue.SimpleQueue[Any] = queue.SimpleQueue()
        self._last_time_ns = 0
        self._writer: WriterThread | WriterProcess | None = None
        self.summary: RecordingSummary | None = None
        self.add_topic(EVENTS_TOPIC, EVENTS_SCHEMA)
        for topic, schema in (topics if topics is not None else {LOOP_TOPIC: LOOP_SCHEMA}).items():
            self.add_topic(topic, schema)

    # ------------------------------------------------------------------ lifecycle

    def start(self) -> Recorder:
        """Create the file and start the writer (``with`` does this).

        Raises
        ------
        DataError
            If the file cannot be created (a bad path).
        RecordingFailed
            If the disk has no room for the log's reserve.
        """
        if self._writer is not None:
            raise DataError(f"recorder for '{self.path}' was already started")
        try:
            if self._mode == "process":
                writer: WriterThread | WriterProcess = WriterProcess(
                    self.path, self._queue, self._config, self._on_fault
                )
            else:
                writer = WriterThread.open(self.path, self._queue, self._config, self._on_fault)
            writer.start()
        except OSError as exc:
            if exc.errno in (errno.ENOSPC, errno.EDQUOT):
                raise RecordingFailed(f"cannot create MCAP log '{self.path}': {exc}") from None
            raise DataError(f"cannot create MCAP log '{self.path}': {exc}") from None
        self._writer = writer
        return self

    @property
    def writer_started_in(self) -> float | None:
        """Wall time [s] the writer process took to start and open the file (None: a thread)."""
        return self._writer.started_in if isinstance(self._writer, WriterProcess) else None

    @property
    def writer_pid(self) -> int | None:
        """Process id of the writer process (None: a thread, or not started)."""
        return self._writer.pid if isinstance(self._writer, WriterProcess) else None

    def close(self) -> RecordingSummary:
        """Finish the file (footer, summary) and return what was written.

        Blocks until the writer has written everything queued (with ``writer="process"``: until
        that process has ended).  Idempotent.

        Raises
        ------
        RecordingFailed
            If a write failed: the file ends readably after the last whole write.
        """
        if self.summary is not None:
            return self.summary
        writer = self._writer
        if writer is None:
            raise DataError(f"recorder for '{self.path}' was never started")
        self._queue.put(STOP)
        writer.join()
        self.summary = RecordingSummary(
            self.path, writer.stats(), writer.events, writer.max_backlog, writer.lost, writer.fault
        )
        if writer.error is not None:
            raise RecordingFailed(
                f"recording to '{self.path}' failed: {writer.error!r}; the log is readable up "
                f"to the failure ({writer.lost} messages not written)"
            ) from writer.error
        return self.summary

    @property
    def fault(self) -> str | None:
        """What endangered the log (disk nearly full, a failed write), or None."""
        return None if self._writer is None else self._writer.fault

    def __enter__(self) -> Recorder:
        return self.start()

    def __exit__(self, exc_type: object, exc: BaseException | None, tb: object) -> None:
        if exc is not None and self._writer is not None and self.summary is None:
            self.event(self._last_time_ns, "error", f"run ended by {exc!r}")
        try:
            self.close()
        except RecordingFailed as failure:
            if exc is None:
                raise
            exc.add_note(str(failure))  # keep the body's exception; mention the log's

    # ------------------------------------------------------------------ producer side

    def add_topic(self, topic: str, schema: Mapping[str, Any]) -> None:
        """Register ``topic`` with its JSON ``schema`` (before or during the run).

        Raises
        ------
        ParameterError
            If the topic is empty, the schema not JSON-serialisable, or the topic already
            registered with a different schema.
        """
        if not isinstance(topic, str) or not topic:
            raise ParameterError(f"topic must be a non-empty string; got {topic!r}")
        try:
            data = json.dumps(schema, sort_keys=True).encode()
        except (TypeError, ValueError) as exc:
            raise ParameterError(f"schema of topic {topic!r} is not JSON ({exc})") from None
        known = self._schemas.get(topic)
        if known == data:
            return
        if known is not None:
            raise ParameterError(f"topic {topic!r} is already registered with another schema")
        self._schemas[topic] = data
        self._queue.put(("s", topic, data))

    def put(
        self,
        topic: str,
        seq: int,
        log_time_ns: int,
        message: Mapping[str, Any],
        publish_time_ns: int | None = None,
    ) -> None:
        """Queue one message; never blocks and does no I/O.

        Parameters
        ----------
        topic
            A registered topic.
        seq
            Step counter of the topic, from 0, +1 per message; gaps are counted.
        log_time_ns
            Simulated time [ns] (>= 0).
        message
            Mapping of named values in SI units; encoded to JSON by the writer, so do
            not mutate it afterwards.
        publish_time_ns
            Defaults to ``log_time_ns``.

        Raises
        ------
        ParameterError
            If the topic is not registered or a time/sequence is not a non-negative integer.
        DataError
            If the recorder is not started or already closed.  After a failed write messages
            are still accepted, and counted as lost.
        """
        if topic not in self._schemas or topic == EVENTS_TOPIC:
            known = sorted(set(self._schemas) - {EVENTS_TOPIC})
            raise ParameterError(
                f"topic {topic!r} is not registered for put() (events go through event()); "
                f"known: {known}"
            )
        try:
            seq, log_time_ns = operator.index(seq), operator.index(log_time_ns)
            publish = log_time_ns if publish_time_ns is None else operator.index(publish_time_ns)
        except TypeError:
            raise ParameterError(
                f"seq and times must be integers; got seq={seq!r}, log_time_ns={log_time_ns!r}, "
                f"publish_time_ns={publish_time_ns!r}"
            ) from None
        if seq < 0 or log_time_ns < 0 or publish < 0:
            raise ParameterError(
                f"seq and times must be >= 0; got seq={seq}, log_time_ns={log_time_ns}, "
                f"publish_time_ns={publish}"
            )
        self._check_alive()
        self._last_time_ns = log_time_ns
        self._queue.put(("m", topic, seq, log_time_ns, publish, message))

    def put_block(self, topic: str, block: RowBlock) -> None:
        """Queue a block of rows (one message per row); never blocks and does no I/O.

        Each row becomes one JSON message ``{"seq": k, <channel>: value, ...}`` with
        ``Message.sequence = seq`` and ``log_time = t_ns``, encoded by the writer.  A
        topic not registered yet is registered with the schema generated from the block's
        channel declarations (:func:`rths.core.channels.json_schema`).

        Parameters
        ----------
        topic
            MCAP topic.
        block
            Filled rows (``block.count`` of them); must not change afterwards.

        Raises
        ------
        DataError
            If the recorder is not started or already closed.
        """
        if topic == EVENTS_TOPIC:
            raise ParameterError("events go through event(), not put_block()")
        if topic not in self._schemas:
            self.add_topic(topic, block_schema(topic, block))
        self._check_alive()
        if block.count:
            self._last_time_ns = int(block.t_ns[block.count - 1])
        self._queue.put(("b", topic, block))

    def add_metadata(self, name: str, data: Mapping[str, str]) -> None:
        """Queue one more MCAP metadata record (e.g. the run's summary, known only at the end).

        Raises
        ------
        ParameterError
            If ``name`` is empty or ``data`` is not a mapping of strings to strings.
        """
        checked = check_metadata({name: data})
        self._check_alive()
        self._queue.put(("md", name, checked[name]))

    def put_record(self, topic: str, payload: bytes) -> None:
        """Queue an encoded :class:`rths.wire.codec.LogRecord` from another process.

        Parameters
        ----------
        topic
            MCAP topic; an unregistered one gets an open schema (any JSON object).
        payload
            :meth:`rths.wire.codec.LogRecord.encode` bytes, decoded by the writer; a bad
            payload is counted as ``rejected`` and logged as an event.
        """
        self._check_alive()
        self._queue.put(("r", topic, payload))

    def throttle(self, max_queued: int) -> None:
        """Wait while more than ``max_queued`` items wait for the writer thread.

        For a producer that outruns the writer (the ``fast`` clock's compiled loop): what is
        queued when a nearly full disk stops the run must still fit the log's disk reserve
        (:data:`rths.log.writer.logfile.RESERVE`).  Polls every
        :data:`rths.log.writer.mcap_writer.POLL` seconds, as the writer does; returns at once
        with a writer process, a writer that has ended or once the log is in danger (the run is
        being stopped then).

        Parameters
        ----------
        max_queued
            Items (a row block is one) the writer may have waiting.
        """
        writer = self._writer
        if not isinstance(writer, WriterThread):
            return
        while self._queue.qsize() > max_queued and writer.is_alive() and writer.fault is None:
            time.sleep(POLL)

    def wait_flushed(self, timeout: float | None = None) -> bool:
        """Block until everything queued so far is flushed to the file by the writer's own
        periodic flush (no flush is forced), or the file is finished.

        Parameters
        ----------
        timeout
            Longest wait [s]; None waits as long as it takes.

        Returns
        -------
        bool
            True once flushed, False on timeout.
        """
        self._check_alive()
        flushed = threading.Event()
        self._queue.put(("w", flushed))
        return flushed.wait(timeout)

    def event(self, log_time_ns: int, kind: str, message: str, **details: Any) -> None:
        """Queue an event on ``rths/events``.

        Parameters
        ----------
        log_time_ns
            Simulated time [ns] of the event.
        kind
            Short machine-readable kind, e.g. ``"overrun"``, ``"stop"``.
        message
            Human-readable description.
        **details
            Further JSON-serialisable fields (SI units).
        """
        self._check_alive()
        self._queue.put(("e", int(log_time_ns), {"kind": kind, "message": message, **details}))

    def _check_alive(self) -> None:
        if self._writer is None or self.summary is not None:
            state = "closed" if self.summary is not None else "not started"
            raise DataError(f"recorder for '{self.path}' is {state}")
