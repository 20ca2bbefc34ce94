"""Pacers driven by an injected fake clock: the schedule, overrun counting and jitter are exact."""

import pytest

from rths.core.errors import ParameterError
from rths.runtime.clocks import FreeRunning, RealtimeOverrun, WallClock


class FakeClock:
    """Monotonic fake time [ns]: each read advances by ``tick`` (so busy-waits terminate);
    ``sleep`` advances by the requested time plus a fixed ``overshoot`` (like Linux sleep)."""

    def __init__(self, tick: int = 1_000, overshoot: int = 30_000) -> None:
        self.t = 0
        self.tick = tick
        self.overshoot = overshoot
        self.sleeps: list[float] = []

    def now(self) -> int:
        self.t += self.tick
        return self.t

    def sleep(self, seconds: float) -> None:
        self.sleeps.append(seconds)
        self.t += round(seconds * 1e9) + self.overshoot

    def work(self, ns: int) -> None:
        self.t += ns


DT = 1 / 4096
DT_NS = round(DT * 1e9)


def run(pacer: WallClock, clock: FakeClock, work_ns: list[int]) -> None:
    pacer.start()
    for k, w in enumerate(work_ns):
        pacer.wait(k)
        clock.work(w)
        pacer.done(k)


def test_steps_start_on_schedule_within_one_tick():
    clock = FakeClock()
    pacer = WallClock(DT, 50, now_ns=clock.now, sleep=clock.sleep)
    run(pacer, clock, [50_000] * 50)
    s = pacer.stats()
    assert s.steps == 50 and s.overruns == 0
    # wait() reads the clock at most twice after the deadline passes, so a start is at most
    # two ticks (2 µs) late
    assert s.jitter_max <= 2e-6 + 1e-12
    # sleeps leave the spin margin: 150 µs of spinning absorbs the 30 µs sleep overshoot
    assert all(x > 0 for x in clock.sleeps)


def test_overruns_are_counted_and_schedule_is_kept():
    clock = FakeClock()
    pacer = WallClock(DT, 10, now_ns=clock.now, sleep=clock.sleep)
    work = [50_000] * 10
    work[3] = DT_NS + 100_000  # one step longer than a period
    run(pacer, clock, work)
    s = pacer.stats()
    assert s.overruns == 1
    # the step after the overrun starts late by (work - dt) plus the step-3 start offset,
    # and the schedule is caught up afterwards (steps are not skipped)
    assert s.jitter_max == pytest.approx(100_000e-9, abs=5e-6)
    assert s.steps == 10
    assert s.busy_max == pytest.approx((DT_NS + 100_000) * 1e-9, abs=3e-6)


def test_strict_raises_after_consecutive_overruns():
    clock = FakeClock()
    pacer = WallClock(
        DT, 10, now_ns=clock.now, sleep=clock.sleep, strict=True, max_consecutive_overruns=3
    )
    with pytest.raises(RealtimeOverrun, match="3 consecutive overruns"):
        run(pacer, clock, [2 * DT_NS] * 10)


def test_free_running_never_waits_and_reports_zero_jitter():
    clock = FakeClock()
    pacer = FreeRunning(DT, 5, now_ns=clock.now)
    pacer.start()
    for k in range(5):
        pacer.wait(k)
        clock.work(10 * DT_NS)  # far slower than real time: irrelevant when not paced
        pacer.done(k)
    s = pacer.stats()
    assert s.overruns == 0 and s.jitter_max == 0.0 and s.steps == 5
    assert s.overrun_fraction == 0.0


@pytest.mark.parametrize("dt, n, match", [(0.0, 10, "time step dt"), (DT, 0, "number of steps")])
def test_validation(dt, n, match):
    with pytest.raises(ParameterError, match=match):
        WallClock(dt, n)


def test_validation_max_consecutive():
    with pytest.raises(ParameterError, match="max_consecutive_overruns"):
        WallClock(DT, 10, max_consecutive_overruns=0)
