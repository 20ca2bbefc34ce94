"""Pacing of the fixed-step loop: free-running (``lockstep``, ``fast``) or wall-clock
(``realtime``).

The loop asks its pacer to wait for the scheduled start of step ``k`` and tells it when the step's
work is done.  The real-time pacer keeps a fixed schedule ``t0 + k*dt`` on a monotonic clock (like
SimPy's ``RealtimeEnvironment``) and never hides a late step: it counts

* **overruns** -- steps whose work finished after the start of the next step was due;
* **jitter** -- lateness of each step's start behind its schedule (kept for percentiles).

A late step is not skipped: the following steps run back to back until the schedule is caught up,
so the number of steps and the simulated time are exact.  With ``strict=True`` the pacer raises
:class:`RealtimeOverrun` after ``max_consecutive_overruns`` consecutive overruns (cf. SimPy's
"Simulation too slow for real time").

The time source and the sleep function are injectable, so tests drive the pacer with a fake clock.

Two process-level settings keep a loop thread on time (:func:`realtime_thread`): the thread's
timer slack is lowered to 1 µs (Linux lets a sleep or a timed wait overshoot by 50 µs by default,
a fifth of a 4096 Hz step), and the garbage collector is kept out of the loop (:class:`QuietGC`:
everything built before the loop is frozen out of the collector, automatic collections are off
while the loop runs, and the young generation is collected in a step's idle time, when there is
room before the next deadline).  A 106 ms full collection in the middle of a run is what froze the
specimen's measurement for ~95 steps before these settings.
"""

from __future__ import annotations

import ctypes
import gc
import os
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from rths.core.errors import (
    RTHSError,
    check_nonnegative,
    check_positive,
    check_positive_int,
)

__all__ = [
    "SWITCH_INTERVAL",
    "FreeRunning",
    "Pacer",
    "QuietGC",
    "RealtimeOverrun",
    "TimingStats",
    "WallClock",
    "realtime_priority",
    "realtime_thread",
]


#: GIL switch interval [s] while a loop over zenoh runs (coordinator and specimen process).
#: CPython's default (5 ms) lets another thread keep the GIL for milliseconds while the loop
#: thread waits -- which showed up as 5 ms p99 jitter at 1 kHz in real time, and slows every
#: lockstep round trip; 50 µs bounds it.
SWITCH_INTERVAL = 50e-6

#: Default busy-wait margin before each deadline [µs] (see :class:`WallClock`): with the timer
#: slack at 1 µs (:func:`realtime_thread`) a sleep overshoots by ~10-60 µs on a busy VM.
DEFAULT_SPIN_US = 40.0

#: Young-generation size above which :class:`QuietGC` collects it in a step's idle time.
GC_YOUNG_THRESHOLD = 2000
#: Idle time [ns] a young collection needs before the next deadline.
GC_IDLE_NS = 100_000

_PR_SET_TIMERSLACK = 29


def realtime_thread(slack_ns: int = 1000) -> bool:
    """Lower the calling thread's timer slack (Linux ``prctl``), so sleeps and timed waits end
    within a few µs of their deadline; returns whether it was applied.

    Parameters
    ----------
    slack_ns
        The timer slack [ns] (Linux default: 50 000).
    """
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return int(libc.prctl(_PR_SET_TIMERSLACK, int(slack_ns), 0, 0, 0)) == 0
    except (OSError, AttributeError):
        return False


#: Environment variable that asks for the real-time scheduling class (a priority 1-99).
PRIORITY_ENV = "RTHS_RT_PRIORITY"


def realtime_priority(priority: int | None = None) -> int:
    """Put this process in Linux's real-time scheduling class ``SCHED_FIFO`` (opt-in).

    Threads started afterwards inherit it, so call it before the transport starts its threads.
    A ``SCHED_FIFO`` thread runs as soon as it is woken, ahead of every ordinary process: on a
    shared machine the loop's wake-ups no longer wait behind other people's jobs.  The kernel's
    real-time throttling (``sched_rt_runtime_us``, 95 % by default) keeps the machine usable.
    Needs ``CAP_SYS_NICE`` (root, or ``ulimit -r``); without it nothing changes.

    Parameters
    ----------
    priority
        1-99; None: the environment variable ``RTHS_RT_PRIORITY`` (unset: do nothing).

    Returns
    -------
    int
        The priority applied, 0 if none.
    """
    if priority is None:
        text = os.environ.get(PRIORITY_ENV, "").strip()
        if not text:
            return 0
        try:
            priority = int(text)
        except ValueError:
            return 0
    if not 1 <= priority <= 99 or not hasattr(os, "sched_setscheduler"):
        return 0
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except (OSError, PermissionError):
        return 0
    return priority


class QuietGC:
    """Keep the garbage collector out of a real-time loop (a context manager).

    On entry: one full collection, ``gc.freeze()`` (everything alive is moved to a permanent
    generation the collector never scans again) and ``gc.disable()``.  While inside, the loop
    calls :meth:`idle` with the time left before its next deadline; the young generation is
    collected there when it has grown and there is room.  On exit: automatic collection back on.
    Every collection that happens inside (idle or not) is counted with its duration, so the
    immunity is measured, not assumed.

    Attributes
    ----------
    collections : int
        Collections that ran while inside.
    longest : float
        Longest of them [s].
    """

    def __init__(self) -> None:
        self.collections = 0
        self.longest = 0.0
        self._started = 0
        self._was_enabled = True

    def _callback(self, phase: str, info: dict[str, Any]) -> None:
        if phase == "start":
            self._started = time.perf_counter_ns()
        elif self._started:
            self.collections += 1
            self.longest = max(self.longest, (time.perf_counter_ns() - self._started) * 1e-9)

    def __enter__(self) -> QuietGC:
        self._was_enabled = gc.isenabled()
        gc.collect()
        gc.freeze()
        gc.disable()
        gc.callbacks.append(self._callback)
        return self

    def idle(self, remaining_ns: int) -> None:
        """Collect the young generation if it has grown and there is room.

        Parameters
        ----------
        remaining_ns
            Time left before the loop's next deadline [ns].
        """
        if remaining_ns > GC_IDLE_NS and gc.get_count()[0] > GC_YOUNG_THRESHOLD:
            gc.collect(0)

    def __exit__(self, *exc: object) -> None:
        if self._callback in gc.callbacks:
            gc.callbacks.remove(self._callback)
        if self._was_enabled:
            gc.enable()


class RealtimeOverrun(RTHSError, RuntimeError):
    """Raised by a strict real-time pacer when the loop cannot keep up."""


@dataclass(frozen=True)
class TimingStats:
    """Timing figures of a run (all durations in seconds).

    Attributes
    ----------
    steps : int
        Steps executed.
    overruns : int
        Steps whose work ended after the next step was due.
    jitter_p50, jitter_p99, jitter_max : float
        Percentiles of the lateness of step starts behind the schedule [s] (0 when not paced).
    busy_mean, busy_max : float
        Mean and maximum work time per step [s] (from step start to ``done``).
    """

    steps: int
    overruns: int
    jitter_p50: float
    jitter_p99: float
    jitter_max: float
    busy_mean: float
    busy_max: float

    @property
    def overrun_fraction(self) -> float:
        """Overruns per step (0 when no step ran)."""
        return self.overruns / self.steps if self.steps else 0.0


class Pacer:
    """Base pacer: measures work time per step but never waits (used for ``lockstep``/``fast``).

    Parameters
    ----------
    dt : float
        Loop step [s].
    n_steps : int
        Number of steps of the run (sizes the timing arrays; no allocation happens in the loop).
    now_ns : callable
        Monotonic time source in integer nanoseconds (default ``time.monotonic_ns``, the clock
        the links and the specimen stamp with).
    """

    paced: bool = False

    def __init__(
        self, dt: float, n_steps: int, now_ns: Callable[[], int] = time.monotonic_ns
    ) -> None:
        self.dt_ns = round(check_positive(dt, "time step dt") * 1e9)
        self.n_steps = check_positive_int(n_steps, "number of steps")
        self._now = now_ns
        self._lateness = np.zeros(n_steps, dtype=np.int64)
        self._busy = np.zeros(n_steps, dtype=np.int64)
        self._step_start = 0
        self._t0 = 0
        self._count = 0
        self.overruns = 0

    #: Called by a paced wait with the time [ns] left before the deadline (e.g.
    #: :meth:`QuietGC.idle`); None: nothing.
    idle: Callable[[int], None] | None = None

    def start(self) -> None:
        """Fix the schedule origin (call just before step 0)."""
        self._t0 = self._now()

    def now_ns(self) -> int:
        """The pacer's clock [ns]."""
        return self._now()

    def deadline_ns(self, k: int) -> int:
        """Scheduled start of step ``k`` on the pacer's clock [ns] (never, when not paced).

        Parameters
        ----------
        k
            Step index.
        """
        return self._t0 + k * self.dt_ns if self.paced else 2**62

    def lateness_ns(self, k: int) -> int:
        """How late step ``k`` started behind its schedule [ns] (0 when not paced).

        Parameters
        ----------
        k
            Step index (already started).
        """
        return int(self._lateness[k])

    def wait(self, k: int) -> None:
        """Block until step ``k`` is due (never blocks here)."""
        self._step_start = self._now()

    def done(self, k: int) -> None:
        """Mark the end of step ``k``'s work."""
        end = self._now()
        self._busy[k] = end - self._step_start
        self._count = k + 1

    def account(self, k: int, count: int, start_ns: int) -> None:
        """Mark the end of steps ``k .. k + count - 1`` run together since ``start_ns`` (the
        compiled path; each gets the mean work time).

        Parameters
        ----------
        k, count
            First step and number of steps.
        start_ns
            When the first began, on the pacer's clock [ns].
        """
        self._busy[k : k + count] = (self._now() - start_ns) // count
        self._count = k + count

    def stats(self) -> TimingStats:
        """Timing figures for the steps run so far."""
        n = self._count
        late = self._lateness[:n] * 1e-9 if self.paced else np.zeros(max(n, 1))
        busy = self._busy[:n] * 1e-9 if n else np.zeros(1)
        return TimingStats(
            steps=n,
            overruns=self.overruns,
            jitter_p50=float(np.percentile(late, 50)) if n else 0.0,
            jitter_p99=float(np.percentile(late, 99)) if n else 0.0,
            jitter_max=float(late.max()) if n else 0.0,
            busy_mean=float(busy.mean()),
            busy_max=float(busy.max()),
        )


class FreeRunning(Pacer):
    """Runs steps back to back (``lockstep`` over zenoh, ``fast`` in process).

    Parameters
    ----------
    dt : float
        Loop step [s], > 0.
    n_steps : int
        Number of steps of the run, >= 1 (sizes the timing arrays).
    now_ns : callable
        Monotonic time source in integer nanoseconds (default ``time.monotonic_ns``).
    """


class WallClock(Pacer):
    """Fixed-step wall-clock schedule ``t0 + k*dt`` (the ``realtime`` clock).

    Waiting sleeps until ``spin`` before the deadline and busy-waits the rest, because ``sleep``
    overshoots by tens of microseconds on Linux while a loop step at 4096 Hz is 244 µs.

    Parameters
    ----------
    dt, n_steps, now_ns
        As for :class:`Pacer`.
    sleep : callable
        ``sleep(seconds)``; injectable for tests.
    spin : float
        Busy-wait margin before each deadline [s] (default 150 µs).
    strict : bool
        Raise :class:`RealtimeOverrun` after ``max_consecutive_overruns`` overruns in a row.
    max_consecutive_overruns : int
        See ``strict``.
    """

    paced = True

    def __init__(
        self,
        dt: float,
        n_steps: int,
        now_ns: Callable[[], int] = time.monotonic_ns,
        sleep: Callable[[float], None] = time.sleep,
        spin: float | None = None,
        strict: bool = False,
        max_consecutive_overruns: int = 100,
    ) -> None:
        super().__init__(dt, n_steps, now_ns)
        self._sleep = sleep
        if spin is None:  # RTHS_SPIN_US overrides the default (for tuning on a given machine)
            spin = float(os.environ.get("RTHS_SPIN_US", DEFAULT_SPIN_US)) * 1e-6
        self._spin_ns = round(check_nonnegative(spin, "spin") * 1e9)
        self.strict = strict
        self.max_consecutive_overruns = check_positive_int(
            max_consecutive_overruns, "max_consecutive_overruns"
        )
        self._consecutive = 0

    def wait(self, k: int) -> None:
        deadline = self._t0 + k * self.dt_ns
        remaining = deadline - self._now()
        if self.idle is not None:
            self.idle(remaining)
            remaining = deadline - self._now()
        if remaining > self._spin_ns:
            self._sleep((remaining - self._spin_ns) * 1e-9)
        now = self._now()
        while now < deadline:
            now = self._now()
        self._lateness[k] = now - deadline
        self._step_start = now

    def done(self, k: int) -> None:
        super().done(k)
        if self._step_start + self._busy[k] > self._t0 + (k + 1) * self.dt_ns:
            self.overruns += 1
            self._consecutive += 1
            if self.strict and self._consecutive >= self.max_consecutive_overruns:
                raise RealtimeOverrun(
                    f"simulation too slow for real time: {self._consecutive} consecutive overruns "
                    f"at step {k} (dt = {self.dt_ns / 1e3:.1f} µs, last step took "
                    f"{self._busy[k] / 1e3:.1f} µs)"
                )
        else:
            self._consecutive = 0
