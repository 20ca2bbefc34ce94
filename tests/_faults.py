"""A real ``rths run`` in a subprocess, for the fault-injection tests: started on a known
endpoint and run id, watched through its live ``loop`` stream on zenoh (the event "the loop is
running"), signalled, and its log read back with the plain ``mcap`` reader."""

from __future__ import annotations

import json
import os
import select
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from _scenarios import short
from mcap.reader import make_reader

from rths.runtime.loop import BLOCK_ROWS
from rths.wire.transport import RunKeys, ZenohEndpoints, loopback_endpoint, open_session

__all__ = ["LogFacts", "Run", "plain_facts", "processes_of"]

PATIENCE = 120.0  # deadlock guard for events on a loaded 2-core machine; never reached normally


@dataclass
class LogFacts:
    """What the plain ``mcap`` reader sees in a log."""

    finished: bool  #: the seeking reader finds the summary section
    counts: dict[str, int]  #: messages per topic
    metadata: dict[str, dict[str, str]]
    events: list[dict]
    specimen_summary: dict  #: the specimen process's own summary (``rths/specimen/summary``)


def plain_facts(path: Path) -> LogFacts:
    """Read ``path`` with ``mcap.reader.make_reader`` only (no project code)."""
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        counts: dict[str, int] = {}
        events = []
        specimen: dict = {}
        for _, channel, message in reader.iter_messages(log_time_order=False):
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            if channel.topic == "rths/events":
                events.append(json.loads(message.data))
            elif channel.topic == "rths/specimen/summary":
                specimen = json.loads(message.data)
    with open(path, "rb") as f:
        metadata = {m.name: dict(m.metadata) for m in make_reader(f).iter_metadata()}
    return LogFacts(summary is not None, counts, metadata, events, specimen)


def wait_exited(pids: list[int], timeout: float) -> bool:
    """Block until every process in ``pids`` has exited (or ``timeout`` [s] passes), woken by
    the kernel: a pidfd becomes readable when its process exits (Linux >= 5.3)."""
    poll = select.poll()
    fds = []
    try:
        for pid in pids:
            try:
                fd = os.pidfd_open(pid)
            except ProcessLookupError:
                continue  # gone already
            fds.append(fd)
            poll.register(fd, select.POLLIN)
        deadline = time.monotonic() + timeout
        pending = len(fds)
        while pending:
            left = deadline - time.monotonic()
            if left <= 0:
                return False
            ready = poll.poll(left * 1e3)
            for fd, _ in ready:
                poll.unregister(fd)
                pending -= 1
        return True
    finally:
        for fd in fds:
            os.close(fd)


def processes_of(run_id: str) -> list[int]:
    """Pids of live processes whose command line names ``run_id`` (the specimen's does)."""
    pids = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            cmdline = (entry / "cmdline").read_bytes().split(b"\0")
            state = (entry / "stat").read_text().split(") ", 1)[1][0]
        except OSError:
            continue
        if run_id.encode() in cmdline and state != "Z":
            pids.append(int(entry.name))
    return pids


def writer_processes(pid: int) -> list[int]:
    """Pids of the MCAP writer processes (``rths.log.writer.writer_child``) started by process ``pid``."""
    children = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        children += [int(c) for c in (task / "children").read_text().split()]
    found = []
    for child in children:
        try:
            cmdline = Path(f"/proc/{child}/cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        if b"rths.log.writer.writer_child" in cmdline:
            found.append(child)
    return found


class Run:
    """``python -m rths run SCENARIO`` (the seed scenario shortened) in lockstep, listening on a
    known loopback endpoint with a known run id; stderr is captured."""

    def __init__(
        self, tmp: Path, name: str, duration: float = 60.0, *extra: str, text: str | None = None
    ) -> None:
        self.scenario = tmp / f"{name}.toml"
        self.scenario.write_text(short(duration) if text is None else text)
        self.log = tmp / f"{name}.mcap"
        self.run_id = f"fault-{name}-{os.getpid()}"
        self.endpoint = loopback_endpoint()
        self.args = [
            sys.executable, "-m", "rths", "run", str(self.scenario), "--out", str(self.log),
            "--listen", self.endpoint, "--run-id", self.run_id, "--no-progress", *extra,
        ]  # fmt: skip
        self.process = subprocess.Popen(
            self.args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=tmp
        )
        self.stdout = self.stderr = ""

    def wait_running(self, steps: int = 200) -> None:
        """Block until the loop has published ``steps`` live rows (the run is under way); the
        live copy goes out a block of :data:`rths.runtime.loop.BLOCK_ROWS` rows at a time."""
        seen = threading.Event()
        count = [0]
        blocks = -(-steps // BLOCK_ROWS)

        def on_sample(sample: object) -> None:
            count[0] += 1
            if count[0] >= blocks:
                seen.set()

        deadline = time.monotonic() + PATIENCE
        with open_session(ZenohEndpoints(connect=(self.endpoint,))) as session:
            sub = session.declare_subscriber(RunKeys(self.run_id).loop, on_sample)
            try:
                while not seen.wait(0.5):  # the poll only notices a run that died
                    if self.process.poll() is not None:
                        raise AssertionError(f"the run ended early: {self.finish()}")
                    if time.monotonic() > deadline:
                        raise AssertionError("the run never started")
            finally:
                sub.undeclare()

    def specimen_pids(self) -> list[int]:
        """The specimen process(es) of this run."""
        return [p for p in processes_of(self.run_id) if p != self.process.pid]

    def finish(self, timeout: float = PATIENCE) -> int:
        """Wait for the coordinator to exit; keep its output; return its exit code."""
        out, err = self.process.communicate(timeout=timeout)
        self.stdout, self.stderr = out.decode(), err.decode()
        return self.process.returncode

    @property
    def err_lines(self) -> list[str]:
        """Non-empty stderr lines."""
        return [line for line in self.stderr.splitlines() if line.strip()]
