"""Stopping a run early -- on a signal, or because its log is in danger -- the way a lab stops.

SIGINT (Ctrl-C), SIGTERM (``kill``, a scheduler ending a job) and SIGHUP (the terminal closed)
all take the same path: the loop is asked to stop after its current step, and the run then ends
as every run ends -- the specimen process is told to stop, the summary is computed and written,
the log is finished.  The recorder asks for the same stop when the disk is nearly full
(:class:`rths.log.recorder.Recorder`'s ``on_fault``).

:class:`StopRequest` holds the request.  While a loop is attached, a request stops it gracefully;
before the loop exists (building, waiting for the specimen) a request made later is honoured as
soon as the loop is attached, and a *signal* raises :class:`rths.core.errors.Interrupted` at once
instead -- nothing is moving yet, and a wait for a specimen that never comes should not outlast
Ctrl-C.  A second signal while a graceful stop is under way raises it too (for a stop that hangs).
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType
from typing import Protocol

from rths.core.errors import Interrupted

__all__ = ["STOP_SIGNALS", "StopRequest"]

#: The signals that stop a run cleanly.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


class _Stoppable(Protocol):
    def stop(self, reason: str = ...) -> None: ...


class StopRequest:
    """A run's stop request, from a signal handler or another thread (module docstring).

    Attributes
    ----------
    reason
        Why the run was asked to stop (``""``: it was not).
    signum
        The signal that asked, or None.
    fault
        True when the request came from a fault (the log in danger) rather than a signal.
    """

    def __init__(self) -> None:
        self.reason = ""
        self.signum: int | None = None
        self.fault = False
        self._loop: _Stoppable | None = None
        self._lock = threading.Lock()

    def attach(self, loop: _Stoppable) -> None:
        """The loop to stop from now on; a request made earlier stops it at once.

        Parameters
        ----------
        loop
            Anything with ``stop(reason)`` (a :class:`rths.runtime.loop.Loop`).
        """
        with self._lock:
            self._loop = loop
            pending = self.reason
        if pending:
            loop.stop(pending)

    def detach(self) -> None:
        """The loop has ended: later signals interrupt whatever runs (teardown included)."""
        with self._lock:
            self._loop = None

    def request(self, reason: str, *, fault: bool = False) -> None:
        """Ask for a stop (thread-safe): the attached loop stops after its current step.

        Parameters
        ----------
        reason
            What the run's result and summary will say (``stopped``); the first request wins.
        fault
            The request comes from a fault (the log in danger), not from a signal.
        """
        with self._lock:
            if self.reason:
                return
            self.reason, self.fault = reason, fault
            loop = self._loop
        if loop is not None:
            loop.stop(reason)

    def handle(self, signum: int, frame: FrameType | None = None) -> None:
        """Signal handler: a graceful stop if a loop is attached and none is under way, else
        :class:`Interrupted`.

        Parameters
        ----------
        signum
            The signal received.
        frame
            The interrupted frame (unused; the :func:`signal.signal` protocol).
        """
        name = signal.Signals(signum).name
        with self._lock:
            graceful = self._loop is not None and self.signum is None
            if self.signum is None:
                self.signum = signum
        if not graceful:
            raise Interrupted(signum)
        self.request(f"stopped by {name}")

    @contextmanager
    def installed(self) -> Iterator[StopRequest]:
        """Route :data:`STOP_SIGNALS` to :meth:`handle` inside the block (main thread only;
        elsewhere it does nothing), restoring the previous handlers after it."""
        if threading.current_thread() is not threading.main_thread():
            yield self
            return
        previous = {s: signal.signal(s, self.handle) for s in STOP_SIGNALS}
        try:
            yield self
        finally:
            for s, handler in previous.items():
                signal.signal(s, handler)
