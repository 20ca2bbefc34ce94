"""The writer process itself (``python -m rths.log.writer.writer_child FD_IN FD_OUT``; private).

Started by :class:`rths.log.writer.writer_process.WriterProcess`, which describes the protocol. It
lowers its own scheduling to ``SCHED_OTHER`` at nice +:data:`NICE` before any thread exists (threads
inherit it), ignores SIGINT, SIGTERM and SIGHUP (a Ctrl-C, a closed terminal or a service manager's
stop reach the whole process group: the coordinator stops the run and closes the recorder; this
process ends when its pipe does), opens the file and feeds what arrives on ``FD_IN`` to a
:class:`rths.log.writer.mcap_writer.WriterThread`; it reports on ``FD_OUT``. When ``FD_IN`` ends
without a stop -- the coordinator is gone -- it logs an ``error`` event and finishes the file.
Imports: the log writer, numpy and ``mcap`` only (no zenoh, no plants), so it starts fast (~0.2 s,
most of it numpy).
"""

from __future__ import annotations

import contextlib
import errno
import os
import pickle
import queue
import signal
import struct
import sys
import threading
from collections.abc import Callable
from multiprocessing.connection import Connection
from typing import Any

from rths.core.errors import DataError

__all__ = ["NICE", "main"]

#: Niceness added in the writer process (it must never compete with the real-time loop).
NICE = 10
_LOST = "coordinator process lost: the pipe from the recorder closed without a stop"


class _Rows:
    """The part of a :class:`rths.core.channels.RowBlock` the writer reads."""

    __slots__ = ("count", "names", "seq", "t_ns", "values")

    def __init__(self, names: tuple[str, ...], values: Any, seq: Any, t_ns: Any) -> None:
        self.names, self.values, self.seq, self.t_ns = names, values, seq, t_ns
        self.count = len(seq)


class _Waiter:
    """Stands for the coordinator's flush waiter: ``set()`` tells the coordinator."""

    __slots__ = ("ident", "reply")

    def __init__(self, ident: int, reply: Callable[[tuple[Any, ...]], None]) -> None:
        self.ident, self.reply = ident, reply

    def set(self) -> None:
        self.reply(("w", self.ident))


def _receive_batch(source: Connection) -> list[Any]:
    """One batch as :meth:`rths.log.writer.writer_process.WriterProcess` frames it."""
    head = source.recv_bytes()
    (count,) = struct.unpack_from("<I", head)
    buffers = [source.recv_bytes() for _ in range(count)]
    return list(pickle.loads(memoryview(head)[4:], buffers=buffers))


def _lower_priority() -> None:
    """Ordinary scheduling at nice +:data:`NICE` (threads started later inherit it)."""
    with contextlib.suppress(AttributeError, OSError):
        if os.sched_getscheduler(0) != os.SCHED_OTHER:
            os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    with contextlib.suppress(OSError):
        os.nice(NICE)


def main(fd_in: int, fd_out: int) -> int:
    """Run the writer process: open the file, write what arrives until a stop or the end of
    the pipe, finish the file and report the counts (module docstring).

    Parameters
    ----------
    fd_in
        Read end of the pipe from the coordinator (the file's settings first, then batches).
    fd_out
        Write end of the pipe to the coordinator (reports).

    Returns
    -------
    int
        Exit status: 0 once the file is finished, 1 if it could not be created.
    """
    _lower_priority()
    for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):  # the coordinator's to act on
        signal.signal(signum, signal.SIG_IGN)
    from rths.log.writer.mcap_writer import STOP, WriterThread

    source, sink = Connection(fd_in, writable=False), Connection(fd_out, readable=False)
    lock = threading.Lock()

    def reply(message: tuple[Any, ...]) -> None:
        with lock, contextlib.suppress(OSError):  # a lost coordinator reads nothing
            sink.send_bytes(pickle.dumps(message, protocol=5))

    config = pickle.loads(source.recv_bytes())
    inbox: queue.SimpleQueue[Any] = queue.SimpleQueue()
    try:
        writer = WriterThread.open(
            config.pop("path"),
            inbox,
            config,
            on_fault=lambda message: reply(("fault", message)),
        )
    except OSError as exc:
        reply(("start_failed", exc.errno or errno.EIO, exc.strerror or str(exc)))
        return 1
    reply(("started",))  # before the writer's first write can report a fault
    writer.start()
    last_ns = 0
    while True:
        try:
            batch = _receive_batch(source)
        except (EOFError, OSError):
            inbox.put(("e", last_ns, {"kind": "error", "message": _LOST}))
            inbox.put(STOP)
            break
        if batch[-1] == ("stop",):
            batch.pop()
            batch.append(STOP)
        for item in batch:
            if item is not STOP:
                tag = item[0]
                if tag == "b":
                    rows = _Rows(*item[2:])
                    item = ("b", item[1], rows)
                    last_ns = int(rows.t_ns[-1]) if rows.count else last_ns
                elif tag == "w":
                    item = ("w", _Waiter(item[1], reply))
                elif tag in ("m", "x"):
                    last_ns = item[3]
                elif tag == "e":
                    last_ns = max(last_ns, item[1])
            inbox.put(item)
        if batch and batch[-1] is STOP:
            break
    writer.join()
    try:
        error = pickle.loads(pickle.dumps(writer.error))
    except Exception:
        error = DataError(repr(writer.error))
    counts = {
        "stats": writer.stats(),
        "events": writer.events,
        "lost": writer.lost,
        "max_backlog": writer.max_backlog,
        "fault": writer.fault,
        "error": error,
    }
    reply(("done", counts))
    sink.close()
    return 0


if __name__ == "__main__":
    sys.exit(main(int(sys.argv[1]), int(sys.argv[2])))
