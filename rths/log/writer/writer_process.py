"""The MCAP writer in its own OS process, at ordinary priority (private to the recorder).

Why: in the ``realtime`` clock the loop thread shares the coordinator's GIL and, on a small
machine, its CPUs with the recorder's writer.  Encoding a 256-row block as JSON and handing its
rows to ``mcap`` holds the GIL for ~2 ms, and compressing a chunk takes ~3 ms of CPU; with the
writer in the loop's process the ~10 steps after every block missed their deadline.  Lowering only
the writer thread's priority inverts priorities on the GIL.  In a process of its own the writer has
its own GIL, and it runs in ``SCHED_OTHER`` at nice +10 (an inherited ``SCHED_FIFO`` is reset), so
the kernel preempts it whenever the loop, the specimen or zenoh have work.

Coordinator side (:class:`WriterProcess`): the producers keep filling the recorder's
:class:`queue.SimpleQueue` exactly as for the in-process
:class:`rths.log.writer.mcap_writer.WriterThread` (``put_block`` only enqueues). A *sender* thread
takes what is queued, pickles it (protocol 5; a :class:`rths.core.channels.RowBlock` goes as its
names and its ``values``/``seq``/``t_ns`` arrays, sent out of band: the arrays' memory is written to
the pipe as it is, no copy, with the GIL released) and writes it to a pipe. A *reader* thread blocks
on a second pipe for what the child reports: a fault (``on_fault`` is called at once), a flush
(:meth:`rths.log.recorder.Recorder.wait_flushed`) and, at the end, the counts.

Child side (:mod:`rths.log.writer.writer_child`): a fresh interpreter (fork + exec, never a bare
fork of a process with zenoh's threads, and without multiprocessing's re-import of the parent's
``__main__``) that imports only the log writer, numpy and ``mcap``. It feeds the same
:class:`~rths.log.writer.mcap_writer.WriterThread` as the in-process mode, so the file is byte for
byte the same kind of log. Should the coordinator die (SIGKILL, a crash), the child sees the end of
its pipe, writes an ``error`` event "coordinator lost", and finishes the file (footer, summary,
``rths.recording``) with everything it had received. It ignores SIGINT, SIGTERM and SIGHUP: they
reach the coordinator too, which stops the run and closes the recorder.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import pickle
import queue
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Mapping
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

from rths.core.errors import DataError
from rths.log.writer.mcap_writer import STOP, messages_in
from rths.log.writer.summary import TopicStats

__all__ = ["WriterProcess"]

#: Most items the sender ships in one write (a row block is one item).
BATCH = 32
_PIPE_SIZE = 1 << 20  # bytes of pipe buffer asked for: a few blocks without blocking the sender


def _wire(item: tuple[Any, ...]) -> tuple[Any, ...]:
    """A queued item in the form that crosses the pipe (blocks as their filled arrays)."""
    if item[0] == "b":
        block, n = item[2], item[2].count
        return ("b", item[1], block.names, block.values[:n], block.seq[:n], block.t_ns[:n])
    return item


def _fallback(item: tuple[Any, ...]) -> tuple[Any, ...]:
    """An item that could not be pickled, in a form that can: a message becomes a rejection, an
    event's fields their ``str``."""
    if item[0] == "m":
        return ("x", item[1], item[2], item[3], "message cannot be sent to the writer process")
    if item[0] == "e":
        return (
            "e",
            item[1],
            {k: v if isinstance(v, str | int | float) else str(v) for k, v in item[2].items()},
        )
    return item


class WriterProcess:
    """Coordinator side of the writer process; the recorder's writer when ``writer="process"``.

    It offers what :class:`rths.log.recorder.Recorder` uses of a
    :class:`~rths.log.writer.mcap_writer.WriterThread`: :meth:`start`, :meth:`join` (after
    :data:`~rths.log.writer.mcap_writer.STOP` is queued), :meth:`stats` and the attributes
    ``error``, ``fault``, ``lost``, ``max_backlog``, ``events``.

    Parameters
    ----------
    path
        The MCAP file to write.
    inbox
        The recorder's queue (items as in :mod:`rths.log.writer.mcap_writer`).
    config
        ``reserve``, ``metadata``, ``compression``, ``chunk_size``, ``flush_interval`` of the
        :class:`~rths.log.writer.mcap_writer.WriterThread` the child runs.
    on_fault
        Called once, from the reader thread, when the child reports the log in danger, or when
        the child ends without finishing.
    """

    def __init__(
        self,
        path: Path,
        inbox: queue.SimpleQueue[Any],
        config: Mapping[str, Any],
        on_fault: Callable[[str], None] | None = None,
    ) -> None:
        self.path = path
        self.error: BaseException | None = None
        self.fault: str | None = None
        self.lost = 0
        self.max_backlog = 0
        self.events = 0
        self.started_in = 0.0  #: wall time [s] from launching the child to its file being open
        self._inbox, self._config, self._on_fault = inbox, dict(config), on_fault
        self._stats: dict[str, TopicStats] = {}
        self._waiters: dict[int, threading.Event] = {}
        self._waiter_ids = 0
        self._lock = threading.Lock()
        self._proc: subprocess.Popen[bytes] | None = None
        self._threads: list[threading.Thread] = []

    def start(self) -> None:
        """Launch the child, wait until it has created the file, start the sender and reader.

        Raises
        ------
        OSError
            What creating the file raised in the child (``errno`` kept: ENOSPC is a full disk).
        DataError
            If the child could not be started or ended before opening the file.
        """
        from_parent, to_child = os.pipe()  # (read end, write end)
        from_child, to_parent = os.pipe()
        with contextlib.suppress(OSError):
            fcntl.fcntl(from_parent, fcntl.F_SETPIPE_SZ, _PIPE_SIZE)
        begin = time.perf_counter()
        try:
            self._proc = subprocess.Popen(
                [
                    sys.executable,
                    "-m",
                    "rths.log.writer.writer_child",
                    str(from_parent),
                    str(to_parent),
                ],
                pass_fds=(from_parent, to_parent),
                stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL,
            )
        except OSError as exc:
            for fd in (to_child, from_parent, from_child, to_parent):
                os.close(fd)
            raise DataError(f"cannot start the writer process for '{self.path}': {exc}") from None
        os.close(from_parent)
        os.close(to_parent)
        self._out, self._in = (
            Connection(to_child, readable=False),
            Connection(from_child, writable=False),
        )
        self._out.send_bytes(pickle.dumps({"path": str(self.path), **self._config}, protocol=5))
        try:
            reply = pickle.loads(self._in.recv_bytes())
        except (EOFError, OSError):
            code = self._proc.wait()
            self._out.close()
            self._in.close()
            raise DataError(
                f"the writer process for '{self.path}' ended (exit code {code}) "
                "before opening the file"
            ) from None
        if reply[0] == "start_failed":
            self._proc.wait()
            self._out.close()
            self._in.close()
            raise OSError(reply[1], reply[2])
        self.started_in = time.perf_counter() - begin
        self._threads = [
            threading.Thread(target=self._send, name="rths-recorder-send", daemon=True),
            threading.Thread(target=self._receive, name="rths-recorder-reply", daemon=True),
        ]
        for thread in self._threads:
            thread.start()

    @property
    def pid(self) -> int | None:
        """The writer process's id (None before :meth:`start`)."""
        return None if self._proc is None else self._proc.pid

    def join(self) -> None:
        """Wait until the child has finished the file and reported its counts."""
        for thread in self._threads:
            thread.join()
        if self._proc is not None:
            code = self._proc.wait()
            if code and self.error is None:
                self.error = DataError(f"the writer process ended with exit code {code}")

    def stats(self) -> dict[str, TopicStats]:
        """Counts per topic, as the child reported them at the end."""
        return dict(self._stats)

    # ------------------------------------------------------------------ sender thread

    def _send(self) -> None:
        """Ship the queue to the child until STOP; after the pipe broke, count what is lost."""
        inbox, broken = self._inbox, False
        while True:
            items = [inbox.get()]  # blocks, holding no lock: the loop only enqueues
            while len(items) < BATCH and items[-1] is not STOP:
                try:
                    items.append(inbox.get_nowait())
                except queue.Empty:
                    break
            self.max_backlog = max(self.max_backlog, len(items) + inbox.qsize())
            stop = items[-1] is STOP
            batch = [self._ship(item) for item in items if item is not STOP]
            if stop:
                batch.append(("stop",))
            if not broken:
                try:
                    self._send_batch(batch)
                except OSError:
                    broken = True
            if broken:
                self.lost += sum(messages_in(item) for item in items if item is not STOP)
                self._wake_waiters()
            if stop:
                self._out.close()
                return

    def _ship(self, item: tuple[Any, ...]) -> tuple[Any, ...]:
        if item[0] != "w":
            return _wire(item)
        with self._lock:
            self._waiter_ids += 1
            self._waiters[self._waiter_ids] = item[1]
        return ("w", self._waiter_ids)

    def _send_batch(self, batch: list[tuple[Any, ...]]) -> None:
        """Frame: ``<u32 buffers>`` + the pickle, then each array's bytes as they are."""
        buffers: list[pickle.PickleBuffer] = []
        try:
            data = pickle.dumps(batch, protocol=5, buffer_callback=buffers.append)
        except Exception:  # one item of the batch is not picklable: send a stand-in for it
            buffers.clear()
            items = []
            for item in batch:
                try:
                    pickle.dumps(item, protocol=5)
                except Exception:
                    item = _fallback(item)
                items.append(item)
            data = pickle.dumps(items, protocol=5, buffer_callback=buffers.append)
        self._out.send_bytes(struct.pack("<I", len(buffers)) + data)
        for buffer in buffers:  # no copy: the write reads the block's arrays, GIL released
            self._out.send_bytes(buffer.raw())

    # ------------------------------------------------------------------ reader thread

    def _receive(self) -> None:
        """Act on the child's reports until its pipe ends."""
        done = False
        while True:
            try:
                reply = pickle.loads(self._in.recv_bytes())
            except (EOFError, OSError):
                break
            if reply[0] == "fault":
                self._notify(reply[1])
            elif reply[0] == "w":
                with self._lock:
                    waiter = self._waiters.pop(reply[1], None)
                if waiter is not None:
                    waiter.set()
            elif reply[0] == "done":
                done = True
                counts = reply[1]
                self._stats = counts["stats"]
                self.events, self.lost = counts["events"], self.lost + counts["lost"]
                self.max_backlog = max(self.max_backlog, counts["max_backlog"])
                self.fault = self.fault or counts["fault"]
                self.error = counts["error"]
        self._in.close()
        if not done:
            code = self._proc.wait() if self._proc is not None else None
            self.error = DataError(
                f"the writer process ended (exit code {code}) before finishing the log"
            )
            self._notify(f"recording to '{self.path}' failed: {self.error}")
        self._wake_waiters()

    def _notify(self, message: str) -> None:
        if self.fault is not None:
            return
        self.fault = message
        if self._on_fault is not None:
            with contextlib.suppress(Exception):  # the callback's problem must not cost the log
                self._on_fault(message)

    def _wake_waiters(self) -> None:
        with self._lock:
            waiters, self._waiters = list(self._waiters.values()), {}
        for waiter in waiters:
            waiter.set()
