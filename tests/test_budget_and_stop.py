"""The pre-flight budget of a run (rths.session.budget) and the stop request the signals go
through (rths.session.stopping), with injected costs, memory, disk and loops."""

from __future__ import annotations

import signal
from collections import namedtuple

import pytest
from _scenarios import short

import rths.session.budget as budget
from rths.config.scenario import parse_scenario
from rths.core.errors import ConfigError, Interrupted
from rths.log.recorder import RESERVE
from rths.session.stopping import StopRequest

SCN = parse_scenario(short(10.0), "s.toml")  # 20480 steps at 2048 Hz


def test_the_budget_is_steps_times_the_measured_cost():
    b = budget.check_budget(SCN, "lockstep", 100e-6, runs=3)
    per_step = 100e-6 + budget.OVERHEAD["lockstep"]
    assert b.steps == 3 * 20480
    assert b.wall == pytest.approx(3 * 20480 * per_step)
    assert b.memory == 20480 * budget.MEMORY_PER_STEP and b.log == 0.0
    assert budget.check_budget(SCN, "realtime", 1.0).wall == pytest.approx(10.0)  # the clock's


def test_a_run_beyond_a_day_of_wall_time_is_refused_naming_the_run_table():
    cost = budget.MAX_WALL / 20480 - budget.OVERHEAD["fast"]
    budget.check_budget(SCN, "fast", 0.99 * cost)
    with pytest.raises(ConfigError, match=r"s\.toml: \[run\] duration 10 s at rate 2048 Hz .* h"):
        budget.check_budget(SCN, "fast", 1.01 * cost)


def test_memory_and_disk_beyond_the_machine_are_refused(tmp_path, monkeypatch):
    held = 20480 * budget.MEMORY_PER_STEP  # at most half of what is available
    monkeypatch.setattr(budget, "_available_memory", lambda: 1.01 * held / budget.MEMORY_FRACTION)
    budget.check_budget(SCN, "fast", 0.0)
    monkeypatch.setattr(budget, "_available_memory", lambda: 0.99 * held / budget.MEMORY_FRACTION)
    with pytest.raises(ConfigError, match="would hold .* in memory"):
        budget.check_budget(SCN, "fast", 0.0)
    monkeypatch.setattr(budget, "_available_memory", lambda: float("inf"))
    usage = namedtuple("usage", "total used free")
    need = 20480 * budget.LOG_PER_STEP + RESERVE
    monkeypatch.setattr(budget.shutil, "disk_usage", lambda p: usage(0, 0, need))
    assert budget.check_budget(SCN, "fast", 0.0, log_dir=tmp_path).log == need
    monkeypatch.setattr(budget.shutil, "disk_usage", lambda p: usage(0, 0, need - 1))
    with pytest.raises(ConfigError, match=f"log of about .* into '{tmp_path}'"):
        budget.check_budget(SCN, "fast", 0.0, log_dir=tmp_path)


class _Loop:
    def __init__(self) -> None:
        self.reasons: list[str] = []

    def stop(self, reason: str = "") -> None:
        self.reasons.append(reason)


def test_a_signal_stops_an_attached_loop_once_then_interrupts():
    stop, loop = StopRequest(), _Loop()
    stop.attach(loop)
    stop.handle(signal.SIGTERM)
    assert loop.reasons == ["stopped by SIGTERM"] and stop.signum == signal.SIGTERM
    assert not stop.fault
    with pytest.raises(Interrupted) as info:  # a second signal: the stop may be hanging
        stop.handle(signal.SIGINT)
    assert info.value.signum == signal.SIGINT and str(info.value) == "SIGINT"


def test_a_signal_before_the_loop_interrupts_at_once():
    stop = StopRequest()
    with pytest.raises(Interrupted, match="SIGHUP"):
        stop.handle(signal.SIGHUP)


def test_a_fault_before_the_loop_stops_it_as_soon_as_it_is_attached():
    stop, loop = StopRequest(), _Loop()
    stop.request("recording: disk nearly full", fault=True)
    stop.request("a second reason is ignored")
    stop.attach(loop)
    assert loop.reasons == ["recording: disk nearly full"] and stop.fault
    stop.detach()
    stop.request("after detach: nobody to stop")
    assert loop.reasons == ["recording: disk nearly full"]


def test_handlers_are_installed_only_inside_the_block():
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    stop = StopRequest()
    with stop.installed():
        assert all(signal.getsignal(s) == stop.handle for s in before)
    assert {s: signal.getsignal(s) for s in before} == before
