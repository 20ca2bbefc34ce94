"""Oracles for the recorder's writer process (rths.log.writer.writer_process).

The writer process must write the same log as the in-process writer thread (cross-check of the two
modes on the same input, read back with the plain ``mcap`` reader), report a failed write through
``on_fault`` while the run is still going, run at ordinary priority, and finish the file by itself
when the coordinator is killed.  Waits are on events and process exits, never on time.
"""

from __future__ import annotations

import os
import select
import signal
import subprocess
import sys
import textwrap
import threading
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from rths.core.channels import Channel, RowBlock
from rths.core.errors import DataError, ParameterError
from rths.log.recorder import EVENTS_TOPIC, LOOP_TOPIC, Recorder, RecordingFailed
from rths.log.writer.writer_child import NICE
from rths.wire.codec import LogRecord

PATIENCE = 30.0  # upper bound for a process to start or end; reached only if the code is broken
CHANNELS = [Channel(f"c{i}", "m", f"channel {i}") for i in range(45)]


def block(first: int, rows: int = 256, rng: np.random.Generator | None = None) -> RowBlock:
    """A filled block of rows ``first ... first + rows - 1`` (values with long binary forms)."""
    out = RowBlock(CHANNELS, rows)
    gen = rng or np.random.default_rng(first)
    out.values[:] = gen.standard_normal((rows, len(CHANNELS))) * 1e-3
    out.seq[:] = np.arange(first, first + rows)
    out.t_ns[:] = (out.seq + 1) * 488_281
    out.count = rows
    return out


def feed(rec: Recorder) -> None:
    """The same mixed input for both writers: blocks (one with a gap, one with NaN), messages,
    records from another process (one bad), events and late metadata."""
    rec.event(0, "start", "run x", rate=np.float64(2048.0))
    for b in range(6):
        if b == 4:
            continue  # a missing block: 256 sequence numbers skipped
        rows = block(b * 256)
        if b == 2:
            rows.values[7, 3] = np.nan
        rec.put_block("rths/rows", rows)
    rec.put(
        LOOP_TOPIC,
        0,
        10,
        {"t": 0.5, "target": 1e-3, "command": 0.0, "measured": 0.0, "force": float("inf")},
    )
    rec.put(
        LOOP_TOPIC,
        1,
        20,
        {"t": 1.0, "target": np.float64(2e-3), "command": 0.0, "measured": 0.0, "force": 0.0},
    )
    rec.put_record("rths/side", LogRecord(0, 10, {"a": 1.25, "b": "x"}).encode())
    rec.put_record("rths/side", b"garbage")
    rec.put(LOOP_TOPIC, 2, 30, {"t": 1.5, "target": object()})  # not JSON: rejected
    rec.add_metadata("rths.summary", {"stopped": "end"})


def plain(path: Path) -> tuple[list, dict, bool]:
    with open(path, "rb") as f:
        reader = make_reader(f)
        finished = reader.get_summary() is not None
        messages = [
            (c.topic, m.sequence, m.log_time, m.data)
            for _, c, m in reader.iter_messages(log_time_order=False)
        ]
    with open(path, "rb") as f:
        metadata = {m.name: m.metadata for m in make_reader(f).iter_metadata()}
    return messages, metadata, finished


def test_the_writer_process_writes_what_the_writer_thread_writes(tmp_path: Path) -> None:
    logs = {}
    for mode in ("thread", "process"):
        path = tmp_path / f"{mode}.mcap"
        with Recorder(path, topics={LOOP_TOPIC: {"type": "object"}}, writer=mode) as rec:
            feed(rec)
        if mode == "process":
            assert 0 < rec.writer_started_in  # type: ignore[operator]
        logs[mode] = (plain(path), rec.summary)
    (thread_msgs, thread_meta, thread_done), thread_sum = logs["thread"]
    (proc_msgs, proc_meta, proc_done), proc_sum = logs["process"]
    assert thread_done and proc_done
    assert proc_msgs == thread_msgs  # byte for byte, in the same order
    assert len([m for m in proc_msgs if m[0] == "rths/rows"]) == 5 * 256
    assert thread_sum is not None and proc_sum is not None
    assert proc_sum.topics == thread_sum.topics
    assert (proc_sum.events, proc_sum.lost, proc_sum.fault) == (thread_sum.events, 0, None)
    rows = proc_sum.topics["rths/rows"]
    assert (rows.missing, rows.nonfinite) == (256, 1)
    assert (proc_sum.topics["rths/side"].rejected, proc_sum.topics[LOOP_TOPIC].rejected) == (1, 1)
    for meta in (proc_meta, thread_meta):
        del meta["rths.recording"]["max_backlog"]  # how the queue happened to fill
    assert proc_meta == thread_meta and proc_meta["rths.summary"] == {"stopped": "end"}


@pytest.mark.skipif(not os.access("/dev/full", os.W_OK), reason="no writable /dev/full")
def test_a_failed_write_reaches_on_fault_during_the_run_and_the_summary_at_close() -> None:
    """/dev/full fails every write with ENOSPC, as a full disk does."""
    faults: list[str] = []
    told = threading.Event()

    def on_fault(message: str) -> None:
        faults.append(message)
        told.set()

    rec = Recorder("/dev/full", reserve=0, writer="process", on_fault=on_fault).start()
    rec.put_block("rths/rows", block(0))
    assert told.wait(PATIENCE)  # before close: the run can still be stopped
    assert rec.fault == faults[0] and "No space left on device" in faults[0]
    assert rec.wait_flushed(PATIENCE)  # nothing more reaches the disk: no one is kept waiting
    rec.put_block("rths/rows", block(256))
    with pytest.raises(RecordingFailed, match=r"failed: OSError\(28.*messages not written"):
        rec.close()
    assert rec.summary is not None and rec.summary.lost == 512 and faults == [rec.summary.fault]


def test_bad_input_to_the_writer_process_is_refused_in_one_line(tmp_path: Path) -> None:
    with pytest.raises(DataError, match=r"cannot create MCAP log .*nowhere.*No such file"):
        Recorder(tmp_path / "nowhere" / "x.mcap", writer="process").start()
    with pytest.raises(ParameterError, match="writer must be 'thread' or 'process'; got 'fork'"):
        Recorder(tmp_path / "x.mcap", writer="fork")  # type: ignore[arg-type]
    assert Recorder(tmp_path / "y.mcap").start().writer_started_in is None


def test_the_writer_process_runs_at_ordinary_priority_even_under_sched_fifo(tmp_path: Path):
    """A coordinator in SCHED_FIFO (RTHS_RT_PRIORITY) must not hand it to the writer."""
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(1))
    except (OSError, AttributeError):
        fifo = False
    else:
        fifo = True
    try:
        rec = Recorder(tmp_path / "prio.mcap", writer="process").start()
    finally:
        if fifo:
            os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    try:
        pid = rec.writer_pid
        assert pid is not None and os.sched_getscheduler(pid) == os.SCHED_OTHER
        assert os.getpriority(os.PRIO_PROCESS, pid) == min(19, os.nice(0) + NICE)
    finally:
        rec.close()


KILLED = textwrap.dedent(
    """
    import os, signal, sys
    sys.path.insert(0, sys.argv[2])
    from test_writer_process import block
    from rths.log.recorder import Recorder
    rec = Recorder(sys.argv[1], topics={}, writer="process", flush_interval=0.01).start()
    rec.event(0, "start", "about to be killed")
    for b in range(8):
        rec.put_block("rths/rows", block(b * 256))
    assert rec.wait_flushed(60)  # these 8 blocks have reached the writer process
    for b in range(8, 12):
        rec.put_block("rths/rows", block(b * 256))  # shipped or not when the kill comes
    print(rec.writer_pid, flush=True)
    os.kill(os.getpid(), signal.SIGKILL)
    """
)


def test_a_killed_coordinator_leaves_a_finished_log(tmp_path: Path) -> None:
    path = tmp_path / "killed.mcap"
    coordinator = subprocess.Popen(
        [sys.executable, "-c", KILLED, str(path), str(Path(__file__).parent)],
        stdout=subprocess.PIPE,
        text=True,
    )
    writer_pid = int(coordinator.stdout.readline())  # type: ignore[union-attr]
    assert coordinator.wait(PATIENCE) == -signal.SIGKILL
    try:
        pidfd = os.pidfd_open(writer_pid)
    except ProcessLookupError:
        pass  # already gone
    else:
        ready, _, _ = select.select([pidfd], [], [], PATIENCE)  # readable once it has exited
        os.close(pidfd)
        assert ready, "the writer process did not end after its coordinator was killed"
    messages, metadata, finished = plain(path)
    assert finished  # footer and summary section: the plain reader needs no recovery
    seqs = [seq for topic, seq, _, _ in messages if topic == "rths/rows"]
    assert len(seqs) % 256 == 0 and 8 * 256 <= len(seqs) <= 12 * 256
    assert seqs == list(range(len(seqs)))  # every shipped block, whole and in order
    expected = [block(b * 256) for b in range(len(seqs) // 256)]
    first = [m for m in messages if m[0] == "rths/rows"][257][3]
    assert first.startswith(b'{"seq":257,"c0":') and str(expected[1].values[1, 0]).encode() in first
    events = [data for topic, _, _, data in messages if topic == EVENTS_TOPIC]
    assert b'"kind":"start"' in events[0]
    assert b'"kind":"error"' in events[-1] and b"coordinator process lost" in events[-1]
    assert metadata["rths.recording"]["rths/rows.written"] == str(len(seqs))
    assert metadata["rths.recording"]["complete"] == "true"


def test_the_file_is_finished_when_the_body_raises(tmp_path: Path) -> None:
    path = tmp_path / "raised.mcap"
    with pytest.raises(ZeroDivisionError), Recorder(path, topics={}, writer="process") as rec:
        rec.put_block("rths/rows", block(0))
        _ = 1 / 0
    messages, metadata, finished = plain(path)
    assert finished and metadata["rths.recording"]["rths/rows.written"] == "256"
    assert b"run ended by ZeroDivisionError" in messages[-1][3]
    assert rec.writer_pid is not None and rec.summary is not None and rec.summary.complete
