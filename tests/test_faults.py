"""Fault injection on real runs (coordinator and specimen process over zenoh): a stopped or frozen
specimen, a forged zenoh peer, replayed messages.  Each asserts what a safety review asks: the
largest command step the actuator executed, that the stop is a controlled ramp, that nothing
forged was accepted or changed a figure, and that the log is readable with its summary.

Faults are triggered by events (the run's progress), never by sleeping; wall-clock figures
(time from fault to safe stop) are measured by ``tools/fault_figures.py``, not asserted here.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest
import zenoh
from _scenarios import short
from mcap.reader import make_reader

from rths.config.scenario import parse_scenario
from rths.runtime.clocks import QuietGC
from rths.session.runner import RunOptions, run_scenario
from rths.wire.auth import RunSecret, write_secret_file
from rths.wire.codec import Command, LogRecord, Measurement
from rths.wire.transport import RunKeys, ZenohEndpoints, loopback_endpoint, session_config

MAX_VELOCITY = 0.5  # [loop] max_velocity default [m/s]
#: The watchdog for these runs [steps]: wide enough (25 ms at 1024 Hz) that a loaded test machine
#: does not trip it before the fault, which a stopped process always does.
MAX_LAG = 25


def _rt_scenario(duration: float) -> str:
    return short(duration, **{r"^rate = 2048.0": "rate = 1024.0"}).replace(
        "[loop]\n", f"[loop]\nmax_lag = {MAX_LAG}\n"
    )


def _read(path: Path) -> tuple[dict[str, list[dict]], dict[str, dict[str, str]]]:
    """Every topic's messages and the metadata, with the plain mcap reader."""
    topics: dict[str, list[dict]] = {}
    with open(path, "rb") as f:
        reader = make_reader(f)
        for _, channel, message in reader.iter_messages():
            topics.setdefault(channel.topic, []).append(json.loads(message.data))
    with open(path, "rb") as f:
        meta = {m.name: m.metadata for m in make_reader(f).iter_metadata()}
    return topics, meta


class _ExternalRun:
    """A run whose specimen process this test starts itself (so it knows its pid)."""

    def __init__(self, tmp: Path, text: str, clock: str, fault_at: int, fault) -> None:
        self.scn_path = tmp / "s.toml"
        self.scn_path.write_text(text)
        self.scn = parse_scenario(text, str(self.scn_path))
        self.out = tmp / "run.mcap"
        self.endpoint = loopback_endpoint()
        self.secret = tmp / "run.secret"
        write_secret_file(self.secret, RunSecret.new())
        self.run_id = f"fault-{os.getpid()}-{tmp.name[-8:]}".replace("_", "-")
        self.clock = clock
        self.fault_at, self.fault = fault_at, fault
        self.faulted = threading.Event()
        self.outcome = None
        self.error: BaseException | None = None
        self.specimen: subprocess.Popen[bytes] | None = None

    def _progress(self, done: int, total: int) -> None:
        if done >= self.fault_at and not self.faulted.is_set():
            self.faulted.set()
            self.fault(self.specimen)

    def run(self) -> None:
        opts = RunOptions(
            clock=self.clock,
            out=self.out,
            listen=(self.endpoint,),
            external_specimen=True,
            secret_file=self.secret,
            run_id=self.run_id,
            progress=self._progress,
        )
        thread = threading.Thread(target=self._coordinator, args=(opts,))
        thread.start()
        self.specimen = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "rths",
                "specimen",
                str(self.scn_path),
                "--run-id",
                self.run_id,
                "--connect",
                self.endpoint,
                "--clock",
                self.clock,
                "--secret-file",
                str(self.secret),
            ],
            stderr=subprocess.PIPE,
        )
        thread.join()

    def _coordinator(self, opts: RunOptions) -> None:
        try:
            self.outcome = run_scenario(self.scn, opts)
        except BaseException as exc:  # reported by the test
            self.error = exc

    def finish(self) -> tuple[int, str]:
        """Resume (if stopped) and wait for the specimen; its exit code and stderr."""
        assert self.specimen is not None
        self.specimen.send_signal(signal.SIGCONT)
        try:
            _, err = self.specimen.communicate(timeout=60)
        except subprocess.TimeoutExpired:
            self.specimen.kill()
            _, err = self.specimen.communicate()
        return self.specimen.returncode, err.decode(errors="replace")


def _stop(process) -> None:
    process.send_signal(signal.SIGSTOP)


def _stop_and_resume(process) -> None:
    process.send_signal(signal.SIGSTOP)
    # resumed as soon as the coordinator has stopped, by finish(): a pause of ~the watchdog
    # time plus however long the coordinator takes to notice


@pytest.mark.slow
@pytest.mark.parametrize("resume", [False, True], ids=["sigstop", "sigstop-sigcont"])
def test_a_frozen_specimen_stops_the_run_within_the_watchdog_and_never_jumps(tmp_path, resume):
    run = _ExternalRun(tmp_path, _rt_scenario(3.0), "realtime", 512, _stop)
    run.run()
    code, err = run.finish()
    assert run.error is None, run.error
    outcome = run.outcome
    assert outcome.result.stopped is not None
    # held for at most max_lag steps on the frozen measurement, then stopped
    assert "watchdog" in outcome.result.stopped
    topics, meta = _read(run.out)
    assert "rths.summary" in meta and meta["rths.summary"]["stopped"]
    loop = topics["rths/loop"]
    assert loop[-1]["lag"] <= MAX_LAG
    command = np.array([r["command"] for r in loop])
    assert np.all(np.isfinite(command)) and np.max(np.abs(command)) < 0.05
    specimen = topics["rths/specimen"]
    executed = np.array([r["command"] for r in specimen])
    steps = np.abs(np.diff(np.r_[0.0, executed]))
    dt = 1 / 1024
    assert steps.max() <= MAX_VELOCITY * dt * (1 + 1e-9)  # the guard's per-step limit
    # the specimen, resumed, saw the stop, ramped down and left by itself
    assert code == 0, err


def _forger(endpoint: str, keys: RunKeys, captured: list, done: threading.Event, counts: dict):
    """A foreign zenoh peer: connects to the coordinator, records real frames and publishes
    forged and replayed ones on every key of the run until ``done``."""
    cfg = session_config(ZenohEndpoints(connect=(endpoint,)))
    with zenoh.open(cfg) as session:
        session.declare_subscriber(
            keys.command, lambda s: captured.append(("c", s.payload.to_bytes()))
        )
        session.declare_subscriber(
            keys.measurement, lambda s: captured.append(("m", s.payload.to_bytes()))
        )
        wrong = RunSecret.new()
        fake_cmd = wrong.sealer("command")
        fake_meas = wrong.sealer("measurement")
        sent = 0
        k = 0
        while not done.is_set() and sent < 3000:
            k += 1
            session.put(keys.command, Command(k, k, 0.04).pack())  # plain, unsealed
            session.put(keys.command, fake_cmd.seal(Command(k, k, 0.04).pack()))
            session.put(keys.measurement, fake_meas.seal(Measurement(k, k, 0.03, 1e3, 0).pack()))
            session.put(keys.measurement, Measurement(k, k, 0.03, 1e3, 0).pack())
            session.put(keys.stop, json.dumps({"reason": "forged stop"}).encode())
            session.put(keys.log("specimen"), LogRecord(k, k, {"force": 1e9}).encode())
            session.put(keys.log("specimen/summary"), LogRecord(k, k, {"steps": 1}).encode())
            session.put(keys.log("forged"), LogRecord(k, k, {"sync_rmse": 0.0}).encode())
            sent += 8
            for kind, frame in list(captured[-4:]):  # replays of real, sealed frames
                session.put(keys.command if kind == "c" else keys.measurement, frame)
                sent += 1
        counts["sent"] = sent


@pytest.mark.slow
def test_a_forged_peer_changes_nothing_and_is_counted(tmp_path):
    """Lockstep is deterministic, so an attacked run must reproduce an unattacked fast run bit
    for bit: forged commands, measurements, stop requests, log records and replays of real
    frames are all dropped (counted), and no forged topic reaches the log."""
    text = short(1.0)
    fast_out = tmp_path / "fast.mcap"
    scn = parse_scenario(text)
    run_scenario(scn, RunOptions(clock="fast", out=fast_out))
    endpoint = loopback_endpoint()
    keys = RunKeys(f"forged-{os.getpid()}")
    done, captured, counts = threading.Event(), [], {}
    out = tmp_path / "attacked.mcap"

    def attack_when_running(n: int, total: int) -> None:
        if n and not hasattr(attack_when_running, "started"):
            attack_when_running.started = True
            threading.Thread(
                target=_forger, args=(endpoint, keys, captured, done, counts), daemon=True
            ).start()

    try:
        outcome = run_scenario(
            scn,
            RunOptions(
                clock="lockstep",
                out=out,
                listen=(endpoint,),
                run_id=keys.run_id,
                progress=attack_when_running,
            ),
        )
    finally:
        done.set()
    assert outcome.result.stopped is None  # the forged stop requests were not obeyed
    attacked, meta = _read(out)
    fast, _ = _read(fast_out)
    assert "rths/forged" not in attacked
    assert len(attacked["rths/specimen"]) == len(fast["rths/specimen"])
    for name in ("target", "command", "measured", "force", "correction"):
        assert [r[name] for r in attacked["rths/loop"]] == [r[name] for r in fast["rths/loop"]]
    summary = meta["rths.summary"]
    assert float(summary["sync_rmse"]) == float(_read(fast_out)[1]["rths.summary"]["sync_rmse"])
    dropped = int(summary["auth_forged"]) + int(summary["auth_replayed"])
    assert dropped > 0  # the coordinator saw (some of) them and dropped them
    (spec,) = attacked["rths/specimen/summary"]
    # every command the specimen accepted and executed was the loop's (peers do not relay:
    # forged messages reach the specimen's opener only through its own link, which
    # tests/test_transport.py attacks directly)
    assert spec["steps"] == spec["auth_commands_accepted"] == len(fast["rths/loop"])


def test_quiet_gc_keeps_automatic_collections_out_and_counts_idle_ones():
    """With QuietGC, cyclic garbage never triggers an automatic collection; the young
    generation is collected only in idle time, and every collection is counted."""
    import gc

    with QuietGC() as quiet:
        for _ in range(20000):
            a: list = []
            a.append(a)  # a reference cycle: only the collector frees it
        assert quiet.collections == 0 and gc.get_count()[0] > 10000
        quiet.idle(0)  # no room: nothing
        assert quiet.collections == 0
        quiet.idle(10**9)
        assert quiet.collections == 1 and gc.get_count()[0] < 100
    assert gc.isenabled()


@pytest.mark.slow
def test_the_specimen_ramps_down_by_itself_when_commands_stop(tmp_path):
    """A coordinator that stays connected but stops commanding (frozen, or stuck): the specimen's
    command watchdog trips, it says why, ramps the actuator to zero (never a jump) and leaves."""
    import math

    from rths.wire.transport import LockstepClient, Presence, open_session

    text = _rt_scenario(2.0)
    scn_path = tmp_path / "s.toml"
    scn_path.write_text(text)
    secret = RunSecret.new()
    secret_file = write_secret_file(tmp_path / "run.secret", secret)
    ep = ZenohEndpoints.loopback()
    keys = RunKeys(f"silent-{os.getpid()}")
    with open_session(ep) as session, LockstepClient(session, keys, 30.0, secret) as client:
        with Presence(session, keys, "coordinator", ep.describe(), secret) as presence:
            specimen = subprocess.Popen(
                [
                    sys.executable,
                    "-m",
                    "rths",
                    "specimen",
                    str(scn_path),
                    "--run-id",
                    keys.run_id,
                    "--connect",
                    ep.listen[0],
                    "--clock",
                    "realtime",
                    "--secret-file",
                    str(secret_file),
                ],
                stderr=subprocess.PIPE,
                text=True,
            )
            presence.wait_for_peer(60.0, [client.publisher])
            for k in range(256):  # half a 2 Hz cycle about 5 mm: it ends 5 mm away from zero
                u = 0.01 * math.sin(2 * math.pi * 2.0 * k / 1024)
                client.exchange(Command(k, 0, 0.005 + u))
            assert presence.stop.wait(60.0)  # ... and now silence: an event, not a sleep
            assert "command watchdog" in presence.stop_reason
            _, err = specimen.communicate(timeout=60)
    assert specimen.returncode == 0, err
    summary = json.loads(err.splitlines()[-1].removeprefix("specimen summary: "))
    assert summary["steps"] == 256 and "command watchdog" in summary["stop_reason"]
    assert summary["ramp_down_steps"] >= math.floor(0.0049 / (0.05 / 1024))  # from ~5 mm
    assert summary["largest_command_step"] <= MAX_VELOCITY / 1024 * (1 + 1e-9)
    assert summary["at_rest_ns"] >= summary["stopped_at_ns"] > 0
