"""Fault injection (issue 10, items 3-5): every way a run can end leaves a log the plain ``mcap``
reader reads, with the run's ``rths.summary`` wherever a process survives to write it, no
temporary file, and no specimen process behind.

Real processes: ``rths run`` in lockstep with its spawned ``rths specimen``, signalled while the
loop runs (the event: the live ``loop`` stream on zenoh).  The faults: SIGINT, SIGTERM and SIGHUP
to the coordinator (a clean stop: exit 128 + N); SIGKILL of the coordinator (no summary can be
written: ``rths recover`` makes the log whole); SIGKILL and SIGSTOP of the specimen (exit 3, one
line naming it).  A full disk is in ``tests/test_log_faults.py``.  Times are measured by
``tools/fault_figures.py``, not asserted here.
"""

from __future__ import annotations

import os
import signal

import pytest
from _faults import PATIENCE, Run, plain_facts, processes_of, wait_exited, writer_processes
from _scenarios import short

from rths.cli import main
from rths.log.reader import read_topic

pytestmark = pytest.mark.slow


def _no_leftovers(run: Run) -> None:
    """Only the scenario and the log are left in the run's folder, and no process of the run."""
    names = sorted(p.name for p in run.scenario.parent.iterdir())
    assert names == sorted([run.scenario.name, run.log.name]), names
    # the specimen exits on its own once the peer is gone
    assert wait_exited(processes_of(run.run_id), PATIENCE), processes_of(run.run_id)


@pytest.mark.parametrize(
    "sig", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP], ids=lambda s: s.name
)
def test_a_stop_signal_stops_the_run_cleanly(sig, tmp_path):
    run = Run(tmp_path, sig.name.lower())
    run.wait_running()
    assert run.specimen_pids()
    run.process.send_signal(sig)
    code = run.finish()
    assert code == 128 + sig, run.stderr
    assert run.err_lines == [f"rths run: stopped early: stopped by {sig.name}"], run.stderr
    assert "steps" in run.stdout  # the one-line summary
    facts = plain_facts(run.log)
    assert facts.finished
    summary = facts.metadata["rths.summary"]
    assert summary["stopped"] == f"stopped by {sig.name}"
    assert int(summary["steps"]) == facts.counts["rths/loop"] >= 200
    assert float(summary["j2"]) > 0.0  # metrics of what was run
    assert facts.metadata["rths.recording"]["complete"] == "true"
    assert [e["kind"] for e in facts.events][-2:] == ["stopped", "end"]
    assert not any(e["kind"] == "specimen" for e in facts.events)  # it exited 0, not killed
    assert processes_of(run.run_id) == []  # the coordinator stopped its specimen before exiting
    _no_leftovers(run)


#: Real time at 256 Hz with the longest watchdog a scenario may set (1 s, ``MAX_LAG_TIME``): a
#: 2-core machine shared by several test runs (load 10-15) trips a 25 ms watchdog at 1024 Hz and
#: even a 0.25 s one at 256 Hz now and then before the signal comes (which is the watchdog's job,
#: measured by tools/fault_figures.py); the stop path is the same at every rate.
RT_RATE, RT_MAX_LAG = 256.0, 256


@pytest.mark.parametrize(
    "sig", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP], ids=lambda s: s.name
)
def test_a_stop_signal_stops_a_realtime_run_with_a_ramp_down(sig, tmp_path):
    """The realtime clock: the same clean stop, and the specimen side ramps the actuator down
    (never a step larger than its rate limit ``max_velocity * dt``)."""
    text = short(60.0, **{r"^rate = 2048.0": f"rate = {RT_RATE}"}).replace(
        "[loop]\n", f"[loop]\nmax_lag = {RT_MAX_LAG}\n"
    )
    run = Run(tmp_path, f"rt_{sig.name.lower()}", 60.0, "--clock", "realtime", text=text)
    run.wait_running(steps=256)
    run.process.send_signal(sig)
    code = run.finish()
    assert code == 128 + sig, run.stderr
    assert run.err_lines == [f"rths run: stopped early: stopped by {sig.name}"], run.stderr
    facts = plain_facts(run.log)
    assert facts.finished
    summary = facts.metadata["rths.summary"]
    assert summary["stopped"] == f"stopped by {sig.name}"
    assert int(summary["steps"]) == facts.counts["rths/loop"] >= 256
    spec = facts.specimen_summary
    assert spec["ramp_down_steps"] >= 1 and spec["stop_reason"], spec
    # the round trip was warmed with probes before step 0; they moved nothing
    warm = [e for e in facts.events if e.get("kind") == "warm-up"]
    assert len(warm) == 1 and warm[0]["probes"] >= 1, facts.events
    assert spec["probes_answered"] >= 1 and spec["steps"] == facts.counts["rths/specimen"], spec
    limit = 0.5 / RT_RATE  # [loop] max_velocity (default 0.5 m/s) * dt
    assert spec["largest_command_step"] <= limit * (1 + 1e-9), spec
    assert processes_of(run.run_id) == []
    _no_leftovers(run)


def test_sigkill_of_the_coordinator_leaves_a_log_its_writer_process_finishes(tmp_path):
    """The coordinator's MCAP writer is a process of its own (lockstep and realtime): it sees its
    pipe end and finishes the file -- readable by the plain seeking reader, every block it got,
    an error event -- and ``rths recover`` adds the run summary the coordinator could not."""
    run = Run(tmp_path, "kill9")
    run.wait_running(steps=4096)  # > 1 s of lockstep: blocks have reached the writer
    (writer,) = writer_processes(run.process.pid)
    run.process.kill()
    run.finish()
    assert wait_exited([writer], PATIENCE), "the writer process did not finish the log"
    facts = plain_facts(run.log)
    assert facts.finished  # footer and summary section, no recovery needed
    on_disk = read_topic(run.log, "rths/loop")["sequence"]
    assert on_disk.size >= 1000 and list(on_disk) == list(range(on_disk.size))
    assert facts.counts["rths/loop"] == on_disk.size
    assert facts.metadata["rths.recording"]["rths/loop.written"] == str(on_disk.size)
    lost = facts.events[-1]
    assert lost["kind"] == "error" and lost["message"].startswith("coordinator process lost")
    fixed = tmp_path / "kill9.recovered.mcap"
    assert main(["recover", str(run.log)]) == 0
    recovered = plain_facts(fixed)
    assert recovered.finished and recovered.counts["rths/loop"] == on_disk.size
    assert recovered.metadata["rths.recovered"]["source_finished"] == "true"
    assert int(recovered.metadata["rths.summary"]["steps"]) == on_disk.size
    assert processes_of(run.run_id) == [] or _wait_gone(run)


def _wait_gone(run: Run) -> bool:
    gone = wait_exited(processes_of(run.run_id), PATIENCE)
    assert gone, "the orphaned specimen did not exit by itself"
    return True


@pytest.mark.parametrize("fault", ["SIGKILL", "SIGSTOP"])
def test_a_dead_or_hung_specimen_ends_the_run_with_a_whole_log(fault, tmp_path):
    run = Run(tmp_path, f"specimen_{fault.lower()}")
    run.wait_running()
    (pid,) = run.specimen_pids()
    os.kill(pid, getattr(signal, fault))
    code = run.finish()
    assert code == 3, run.stderr
    assert len(run.err_lines) == 1 and run.err_lines[0].startswith("rths run: error: ")
    assert "specimen" in run.err_lines[0]
    facts = plain_facts(run.log)
    assert facts.finished
    assert facts.metadata["rths.summary"]["stopped"].startswith("error: ")
    assert int(facts.metadata["rths.summary"]["steps"]) == facts.counts["rths/loop"] > 0
    assert any(e["kind"] == "error" and "specimen" in e["message"] for e in facts.events)
    assert processes_of(run.run_id) == []  # a hung specimen is terminated, not left behind
    _no_leftovers(run)
