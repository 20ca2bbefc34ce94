"""Logs that survive any stop (issue 10, item 3), in process: a full disk -- the recorder's
reserve that can no longer be renewed, a write that fails, a real tiny tmpfs filled by another
process --, an exception in the loop, and ``rths recover`` on cut, zero-padded and corrupt logs.

The full-disk oracle is the plain ``mcap`` reader: whatever happens, the file it reads holds
every message written before the fault (their sequence numbers are a gap-free prefix) and the
run's summary metadata.
"""

from __future__ import annotations

import errno
import json
import os
import shutil
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest
from _cli import run_cli
from _faults import PATIENCE, plain_facts
from _scenarios import short
from mcap.reader import make_reader
from mcap.stream_reader import StreamReader

from rths.config.scenario import parse_scenario
from rths.log.reader import LOOP_FIELDS, read_topic
from rths.log.recorder import LOOP_TOPIC, Recorder, RecordingFailed
from rths.log.writer import logfile
from rths.log.writer.logfile import LogFile
from rths.session.runner import RunOptions, run_scenario

CORPUS_CUT = Path(__file__).resolve().parent / "bad_inputs" / "mcap_cut"
DT_NS = 500_000


def _row(k: int) -> dict[str, float]:
    t = (k + 1) * DT_NS * 1e-9
    return {"t": t, "target": np.sin(t), "command": np.sin(t), "measured": np.sin(t), "force": 1.0}


def _linear_messages(path: Path) -> list[int]:
    """Sequence numbers of rths/loop read linearly with the plain mcap stream reader."""
    channels, seqs = {}, []
    with open(path, "rb") as f:
        for record in StreamReader(f).records:
            name = type(record).__name__
            if name == "Channel":
                channels[record.id] = record.topic
            elif name == "Message" and channels.get(record.channel_id) == LOOP_TOPIC:
                seqs.append(record.sequence)
    return seqs


def test_a_write_that_fails_leaves_every_earlier_chunk_and_the_summary(tmp_path, monkeypatch):
    """No reserve (a file system without fallocate): the 30th write finds room for half of
    itself only and fails with ENOSPC -- the disk is full from then on.  The file is cut back to
    the last whole write, which frees that half, and ends there with the metadata queued
    meanwhile: readable by the plain reader."""
    real = LogFile.os_write
    calls, quota = [0], [None]

    def failing(fd: int, data) -> int:
        calls[0] += 1
        pos = os.lseek(fd, 0, os.SEEK_CUR)
        if calls[0] == 30:
            quota[0] = pos + len(data) // 2
        if quota[0] is not None and pos + len(data) > quota[0]:
            real(fd, bytes(data)[: max(quota[0] - pos, 0)])
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(fd, data)

    monkeypatch.setattr(LogFile, "os_write", staticmethod(failing))
    path = tmp_path / "full.mcap"
    told = threading.Event()
    rec = Recorder(
        path, reserve=0, compression="none", chunk_size=16384, on_fault=lambda m: told.set()
    ).start()
    for k in range(5000):
        rec.put(LOOP_TOPIC, k, (k + 1) * DT_NS, _row(k))
    assert told.wait(PATIENCE)
    rec.add_metadata("rths.summary", {"stopped": "recording: disk full"})
    with pytest.raises(RecordingFailed, match="No space left on device"):
        rec.close()
    seqs = _linear_messages(path)
    assert 0 < len(seqs) < 5000 and seqs == list(range(len(seqs)))  # a whole prefix
    with open(path, "rb") as f:  # the plain reader: no summary section, read linearly
        reader = make_reader(f)
        assert reader.get_summary() is None
        meta = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
    assert meta["rths.summary"] == {"stopped": "recording: disk full"}
    recording = meta["rths.recording"]
    written = int(recording[f"{LOOP_TOPIC}.written"])  # handed to the writer, on disk or not
    assert recording["complete"] == "false" and int(recording["lost"]) + written == 5000
    assert len(seqs) <= written
    assert read_topic(path, LOOP_TOPIC)["sequence"].size == len(seqs)


def test_a_nearly_full_disk_stops_the_run_with_a_finished_log(tmp_path, monkeypatch):
    """The reserve cannot be renewed: the recorder asks the run to stop while the reserve still
    holds its end; the log is finished (summary section and all) and says why."""
    monkeypatch.setattr(LogFile, "free_space", lambda self: 0 if self.pos > 200_000 else 1 << 40)
    monkeypatch.setattr(logfile, "CHECK_EVERY", 0.0)  # a fast run ends within one check period
    path = tmp_path / "nearly_full.mcap"
    scn = parse_scenario(short(5.0), "s.toml")
    outcome = run_scenario(scn, RunOptions(clock="fast", out=path))
    stopped = outcome.result.stopped or ""
    assert stopped.startswith("recording: disk nearly full"), stopped
    assert 0 < outcome.result.steps < scn.run.steps
    facts = plain_facts(path)
    assert facts.finished
    assert facts.metadata["rths.summary"]["stopped"] == stopped
    assert int(facts.metadata["rths.summary"]["steps"]) == facts.counts[LOOP_TOPIC]
    assert facts.metadata["rths.recording"]["fault"].startswith("disk nearly full")
    assert outcome.recording is not None and outcome.recording.fault is not None


def test_an_exception_in_the_loop_still_writes_the_summary(tmp_path, monkeypatch):
    from controllers.base import Compensator
    from rths.runtime.fastpath import FusedPlan

    real = Compensator.step
    count = [0]

    def breaks(self, target, measured):
        count[0] += 1
        if count[0] == 300:
            raise RuntimeError("compensator bug")
        return real(self, target, measured)

    monkeypatch.setattr(Compensator, "step", breaks)
    # the bug is planted in the Python step: keep the fast clock on its Python path
    monkeypatch.setattr(FusedPlan, "of", classmethod(lambda cls, loop: None))
    path = tmp_path / "bug.mcap"
    with pytest.raises(RuntimeError, match="compensator bug"):
        run_scenario(parse_scenario(short(1.0), "s.toml"), RunOptions(clock="fast", out=path))
    facts = plain_facts(path)
    assert facts.finished
    summary = facts.metadata["rths.summary"]
    assert summary["stopped"] == "error: RuntimeError('compensator bug')"
    assert int(summary["steps"]) == facts.counts[LOOP_TOPIC] > 0


@pytest.mark.parametrize("name", sorted(p.name for p in CORPUS_CUT.glob("*.mcap")))
def test_recover_makes_a_cut_log_whole(name, tmp_path):
    source = CORPUS_CUT / name
    before = source.read_bytes()
    out = tmp_path / "fixed.mcap"
    result = run_cli(["recover", str(source), "--out", str(out)])
    assert result.code == 0 and result.err_lines == [], result.err
    assert source.read_bytes() == before  # never modified
    facts = plain_facts(out)
    assert facts.finished and facts.metadata["rths.recovered"]["source_finished"] == "false"
    kept = facts.counts.get(LOOP_TOPIC, 0)
    assert f"kept {kept} messages" in result.out
    if kept:  # every whole record of the cut file, in order
        loop = read_topic(out, LOOP_TOPIC)
        assert np.array_equal(loop["sequence"], np.arange(kept))
        assert all(np.all(np.isfinite(loop[f])) for f in LOOP_FIELDS)


@pytest.mark.parametrize("command", ["report", "diagnose", "check"])
def test_a_cut_log_is_read_up_to_its_cut_with_one_warning(command, tmp_path):
    log = CORPUS_CUT / "cut_before_footer.mcap"  # 2.5 s: long enough for a diagnosis
    nominal = CORPUS_CUT.parent.parent.parent / "scenarios/nominal/nominal_seed_simplified.toml"
    argv = {
        "report": ["report", str(log), "--out", str(tmp_path / "r"), "--no-mock"],
        "diagnose": ["diagnose", str(log), "--nominal", str(nominal), "--quiet"],
        "check": ["check", str(log), "--max-rmse", "50"],
    }[command]
    result = run_cli(argv)
    assert result.code == (1 if command == "check" else 0), result.err
    assert len(result.err_lines) == 1 and "unfinished" in result.err_lines[0], result.err
    assert "rths recover" in result.err_lines[0]
    if command == "check":
        assert result.out.startswith("FAIL") and "log not finished" in result.out


def test_recover_refuses_what_is_not_a_log(tmp_path):
    (tmp_path / "x.mcap").write_text("time,command\n")
    result = run_cli(["recover", str(tmp_path / "x.mcap")])
    assert result.code == 2 and len(result.err_lines) == 1 and "not an MCAP" in result.err
    assert not (tmp_path / "x.recovered.mcap").exists()


# ------------------------------------------------------------------ a real full disk (tmpfs)
_FILL = r"""
import ctypes, os, select, signal, subprocess, sys, warnings
from rths.core.errors import DataError
from rths.log.reader import read_topic
warnings.simplefilter("ignore")
disk, out, scenario = sys.argv[1:4]
subprocess.run(["mount", "-t", "tmpfs", "-o", "size=48m", "tmpfs", disk], check=True)
libc = ctypes.CDLL(None, use_errno=True)
writes = libc.inotify_init1(os.O_CLOEXEC)  # readable when a file on the disk is written
assert writes >= 0 and libc.inotify_add_watch(writes, disk.encode(), 0x2 | 0x100) >= 0, (
    os.strerror(ctypes.get_errno()))  # IN_MODIFY | IN_CREATE
log = os.path.join(disk, "run.mcap")
run = subprocess.Popen([sys.executable, "-m", "rths", "run", scenario, "--clock", "fast",
                        "--out", log, "--no-progress"], stderr=subprocess.PIPE, text=True)
ended = os.pidfd_open(run.pid)  # readable when the run exits
seen = 0
while seen == 0:  # the loop runs and its first chunk is on the disk: woken by each flush
    ready, _, _ = select.select([writes, ended], [], [], 120)
    assert ready, "the run wrote nothing"
    assert ended not in ready, run.communicate()[1]
    # held at once, before the log is read: a slow read (a loaded machine) cannot let the
    # run end meanwhile; held on while the disk fills, so it cannot finish then either
    os.kill(run.pid, signal.SIGSTOP)
    _, status = os.waitpid(run.pid, os.WUNTRACED)  # returns once it is stopped (not reaped)
    assert os.WIFSTOPPED(status), f"the run ended before it was held: status {status}"
    os.read(writes, 1 << 16)  # the events themselves say nothing more: read the log
    try:
        seen = read_topic(log, "rths/loop")["sequence"].size
    except DataError:
        seen = 0
    if seen == 0:
        os.kill(run.pid, signal.SIGCONT)
with open(os.path.join(disk, "filler"), "wb") as f:  # another process fills the disk
    for margin in (1 << 20, 2 << 20, 4 << 20):  # < the 8 MiB reserve: the run must stop
        st = os.statvfs(disk)
        try:
            os.posix_fallocate(f.fileno(), 0, st.f_bavail * st.f_frsize - margin)
            break
        except OSError:  # the run wrote more than the margin meanwhile: leave it more
            f.truncate(0)
    else:
        raise SystemExit("could not fill the disk")
os.kill(run.pid, signal.SIGCONT)
_, err = run.communicate(timeout=120)
with open(os.path.join(out, "result.txt"), "w") as f:
    f.write(f"{run.returncode}\n{err}")
subprocess.run(["cp", log, out], check=True)
"""


def test_a_real_full_disk_stops_the_run_with_a_whole_log(tmp_path):
    """A 48 MB tmpfs in a private mount namespace (``unshare -rm``), filled by another process
    while a run writes its log there: the run stops with exit 3 and one line, and its log is
    finished, with the summary."""
    if shutil.which("unshare") is None or shutil.which("mount") is None:
        pytest.skip("needs unshare(1) and mount(8)")
    if subprocess.run(["unshare", "-rm", "true"], capture_output=True).returncode != 0:
        pytest.skip("no unprivileged mount namespace here")
    disk = tmp_path / "disk"
    disk.mkdir()
    scenario = tmp_path / "s.toml"
    # its whole log would fit the disk with the reserve; the run is stopped (SIGSTOP) at each
    # write to the disk, before the log is read, until its first rows are there, and held while
    # the disk is filled, so it cannot finish first however fast it runs (reading the log while
    # the run went on let a loaded CI machine's run end first).  A rate limiter (never reached
    # at 1 m/s) keeps the loop on its Python path (no compiled step): seconds of run.
    limited = {r'^preset = "mts_identified".*$': 'preset = "mts_identified"\nvelocity_limit = 1.0'}
    scenario.write_text(short(30.0, **limited))
    script = tmp_path / "fill.py"
    script.write_text(_FILL)
    done = subprocess.run(
        ["unshare", "-rm", sys.executable, str(script), str(disk), str(tmp_path), str(scenario)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    code, *err = (tmp_path / "result.txt").read_text().splitlines()
    lines = [line for line in err if line.strip()]
    assert int(code) == 3 and len(lines) == 1, lines
    assert lines[0].startswith("rths run: stopped early: recording: disk nearly full")
    facts = plain_facts(tmp_path / "run.mcap")
    assert facts.finished
    summary = facts.metadata["rths.summary"]
    assert summary["stopped"].startswith("recording: disk nearly full")
    assert int(summary["steps"]) == facts.counts[LOOP_TOPIC] > 0
    assert json.dumps(facts.metadata["rths.recording"])  # counts present
