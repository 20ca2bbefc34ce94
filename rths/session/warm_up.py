"""Warm the ``realtime`` clock's round trip before step 0.

The first round trips of a run are slow: code paths, zenoh's routes, caches and the kernel's
scheduling of the two processes' threads are all cold.  Started cold, the synchronous loop
missed the measurements of its first steps in most runs at 2048 Hz -- in some, every one of the
first ~25 steps -- and the measurement watchdog stopped the run within 0.1 s.  So before the
loop's schedule starts, the coordinator sends *probes* (:meth:`rths.wire.codec.Command.probe`:
the specimen answers at once and does not step its lab, so the actuator never moves) on the
step's own schedule, and waits for each answer until the next step is due, as the loop will.
It stops when :data:`ON_TIME_RUN` answers in a row came in time, or after :data:`LONGEST`
seconds; either way the loop then starts and its watchdog judges the run.  What the warm-up saw
goes into the log as a ``warm-up`` event (:class:`WarmUp`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any, Protocol

import numpy as np

from rths.runtime.clocks import WallClock

__all__ = ["LONGEST", "ON_TIME_RUN", "WarmUp", "warm_up"]

#: Answers in a row that must come in time (within a step) to end the warm-up.
ON_TIME_RUN = 128
#: Longest warm-up [s] (then the loop starts anyway).
LONGEST = 0.5


class _Prober(Protocol):
    def probe(self, seq: int, deadline_ns: int) -> bool: ...


@dataclass(frozen=True)
class WarmUp:
    """What the warm-up saw.

    Attributes
    ----------
    probes : int
        Probes sent.
    on_time : int
        Answers that came within their step.
    settled : bool
        Whether it ended on :data:`ON_TIME_RUN` answers in a row (else on :data:`LONGEST`).
    round_trip_p50_us, round_trip_max_us : float
        Median and longest round trip of the probes answered in time [µs].
    """

    probes: int
    on_time: int
    settled: bool
    round_trip_p50_us: float
    round_trip_max_us: float

    def describe(self) -> str:
        """One line for the run's log."""
        how = (
            f"settled after {self.probes} probes"
            if self.settled
            else f"not settled after {self.probes} probes ({LONGEST:g} s)"
        )
        return (
            f"round trip warmed before step 0: {how}, {self.on_time} answered within a step; "
            f"round trip p50 {self.round_trip_p50_us:.0f} µs, max {self.round_trip_max_us:.0f} µs"
        )

    def as_dict(self) -> dict[str, Any]:
        """The figures as a dict (event details)."""
        return asdict(self)


def warm_up(
    client: _Prober,
    dt: float,
    on_time_run: int = ON_TIME_RUN,
    longest: float = LONGEST,
    now_ns: Callable[[], int] = time.monotonic_ns,
    sleep: Callable[[float], None] = time.sleep,
    reserve_ns: int = 0,
) -> WarmUp:
    """Send probes on the step schedule until ``on_time_run`` answers in a row came within
    their step, or for ``longest`` seconds.

    Parameters
    ----------
    client
        The coordinator's end of the link (:meth:`rths.wire.sync_link.SyncClient.probe`).
    dt
        The loop's step [s].
    on_time_run
        Answers in a row within a step that end it.
    longest
        Longest warm-up [s] (at least ``on_time_run`` steps).
    now_ns
        The monotonic clock the deadlines refer to [ns].
    sleep
        ``sleep(seconds)`` of the pacer (injectable for tests, with ``now_ns``).
    reserve_ns
        Time [ns] kept free before each deadline, as the loop keeps it (the wait for an answer
        ends that much before the next step is due).

    Returns
    -------
    WarmUp
        What it saw.
    """
    n = max(on_time_run, round(longest / dt))
    pacer = WallClock(dt, n, now_ns=now_ns, sleep=sleep)
    pacer.start()
    trips = np.zeros(n, dtype=np.int64)
    on_time = run = 0
    k = 0
    for k in range(n):
        pacer.wait(k)
        sent = now_ns()
        if client.probe(k, pacer.deadline_ns(k + 1) - reserve_ns):
            trips[on_time] = now_ns() - sent
            on_time += 1
            run += 1
        else:
            run = 0
        pacer.done(k)
        if run >= on_time_run:
            break
    answered = trips[:on_time] * 1e-3
    return WarmUp(
        probes=k + 1,
        on_time=on_time,
        settled=run >= on_time_run,
        round_trip_p50_us=float(np.median(answered)) if on_time else 0.0,
        round_trip_max_us=float(answered.max()) if on_time else 0.0,
    )
