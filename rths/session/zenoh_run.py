"""The zenoh side of ``rths run`` (``lockstep`` and ``realtime`` clocks; private to
rths.session.runner).

Starts the specimen process (or waits for an external one), wires the links, the log bridge and
the live copy of the loop record, runs the loop and, when the specimen fails or vanishes, ends the
run with a message that names it and the specimen's last words.
"""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from rths.config.scenario import Scenario
from rths.core.errors import RTHSError, TransportError
from rths.log.recorder import LOOP_TOPIC, Recorder
from rths.runtime.loop import LinkSample, Loop, LoopResult
from rths.wire.codec import Command
from rths.wire.transport import (
    BackgroundPublisher,
    LockstepClient,
    LogBridge,
    Presence,
    RealtimeClient,
    RunKeys,
    ZenohEndpoints,
    loopback_endpoint,
    open_session,
)

__all__ = ["run_over_zenoh"]


class _LockstepLink:
    def __init__(self, client: Any, timeout: float) -> None:
        self.client, self.timeout = client, timeout

    def exchange(self, seq: int, t_ns: int, command: float) -> LinkSample:
        m = self.client.exchange(Command(seq, t_ns, command), self.timeout)
        return LinkSample(m.displacement, m.force, 0, m.seq)


class _RealtimeLink:
    def __init__(self, client: Any) -> None:
        self.client = client

    def exchange(self, seq: int, t_ns: int, command: float) -> LinkSample:
        self.client.send(Command(seq, t_ns, command))
        latest = self.client.latest()
        if latest is None:  # the specimen has not sampled yet: rest
            return LinkSample(0.0, 0.0, 0, -1)
        m = latest.message
        return LinkSample(m.displacement, m.force, time.monotonic_ns() - m.sample_ns, m.seq)


def _wait_for_specimen(
    presence: Presence,
    publishers: list[Any],
    timeout: float,
    process: subprocess.Popen[bytes] | None,
) -> None:
    """The handshake, in slices, so a spawned specimen that exits at once is reported at once."""
    deadline = time.monotonic() + timeout
    while True:
        remaining = deadline - time.monotonic()
        try:
            presence.wait_for_peer(max(min(0.5, remaining), 1e-3), publishers)
            return
        except TransportError:
            if process is not None and process.poll() is not None:
                raise TransportError(
                    f"specimen process exited with code {process.returncode} before the run"
                ) from None
            if remaining <= 0.5:
                raise


def _spawn_specimen(
    scn: Scenario, run_id: str, endpoint: str, clock: str, log: Path, seed: int
) -> subprocess.Popen[bytes]:
    # the exact text the coordinator parsed, so an edit to the file mid-run cannot split them
    scenario = log.with_suffix(".scenario.toml")
    scenario.write_text(scn.text, encoding="utf-8")
    args = [
        sys.executable,
        "-m",
        "rths",
        "specimen",
        str(scenario),
        "--run-id",
        run_id,
        "--connect",
        endpoint,
        "--clock",
        clock,
        "--seed",
        str(seed),
    ]
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    with log.open("wb") as stderr:  # the child keeps its own descriptor
        return subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=stderr, env=env)


def run_over_zenoh(
    scn: Scenario,
    opts: Any,
    clock: str,
    run_id: str,
    rec: Recorder,
    make_loop: Callable[[Any, Callable[[dict[str, float]], None]], Loop],
    on_progress: Callable[[int], None],
    stderr_log: Path,
    now_ns: Callable[[], int],
    seed: int,
) -> LoopResult:
    """Run the loop against a specimen process over zenoh; see the module docstring.

    ``opts`` is the run's :class:`rths.session.runner.RunOptions`; ``make_loop(link, sink)`` builds
    the loop; ``stderr_log`` receives the spawned specimen's stderr; ``now_ns()`` gives the
    simulated time of the last recorded step for error events; ``seed`` seeds the lab's noise.
    """
    keys = RunKeys(run_id)
    listen = opts.listen or (() if opts.connect else (loopback_endpoint(),))
    endpoints = ZenohEndpoints(listen=tuple(listen), connect=tuple(opts.connect))
    process = None
    with (
        open_session(endpoints) as session,
        LogBridge(session, keys, rec),
        BackgroundPublisher(session, keys.loop, reliable=False) as live,
    ):
        client = (
            LockstepClient(session, keys, opts.step_timeout)
            if clock == "lockstep"
            else RealtimeClient(session, keys)
        )
        with client, Presence(session, keys, "coordinator", endpoints.describe()) as presence:
            if not opts.external_specimen:
                if not listen:
                    raise TransportError("starting the specimen here needs a --listen endpoint")
                process = _spawn_specimen(scn, run_id, listen[0], clock, stderr_log, seed)
            elif opts.on_waiting is not None:
                where = f"--connect {listen[0]}" if listen else "--listen <endpoint>"
                opts.on_waiting(
                    f"rths specimen {scn.source} --run-id {run_id} {where} "
                    f"--clock {clock} --seed {seed}"
                )
            try:
                _wait_for_specimen(presence, [client.publisher], opts.ready_timeout, process)
                link = (
                    _LockstepLink(client, opts.step_timeout)
                    if clock == "lockstep"
                    else (_RealtimeLink(client))
                )

                def sink(r: dict[str, float]) -> None:
                    t_ns = round(r["t"] * 1e9)
                    rec.put(LOOP_TOPIC, int(r["seq"]), t_ns, r)
                    live.put(t_ns, r)

                loop = make_loop(link, sink)
                watcher = threading.Thread(
                    target=_stop_on_peer_loss, args=(presence, loop), daemon=True
                )
                watcher.start()
                result = loop.run(on_progress)
                presence.request_stop("run complete")
                return result
            except RTHSError as exc:
                last = _last_words(process, stderr_log)
                why = presence.stop_reason or (
                    "the specimen process stopped answering (crashed or stuck?)"
                    if isinstance(exc, TransportError)
                    else ""
                )
                message = (
                    str(exc)
                    + (f"; {why}" if why else "")
                    + (f"; specimen process said: {last}" if last else "")
                )
                rec.event(now_ns(), "error", message)
                presence.request_stop(f"coordinator failed: {exc}")
                raise TransportError(message) if isinstance(exc, TransportError) else exc from None
            finally:
                _reap(process, rec)


def _stop_on_peer_loss(presence: Any, loop: Loop) -> None:
    presence.stop.wait()
    loop.stop(presence.stop_reason or "specimen stopped")


def _last_words(process: subprocess.Popen[bytes] | None, log: Path) -> str:
    if process is None:
        return ""
    try:
        process.wait(timeout=2.0)
    except subprocess.TimeoutExpired:
        return ""
    try:
        lines = [ln for ln in log.read_text(errors="replace").splitlines() if ln.strip()]
    except OSError:
        return ""
    return lines[-1][:300] if lines else f"exited with code {process.returncode}"


def _reap(process: subprocess.Popen[bytes] | None, rec: Recorder) -> None:
    """Wait for the spawned specimen (killing it after 10 s), note a failure, remove its copy
    of the scenario."""
    if process is None:
        return
    try:
        code = process.wait(timeout=10.0)
    except subprocess.TimeoutExpired:
        process.kill()
        code = process.wait()
    if code not in (0, None):
        rec.event(0, "specimen", f"specimen process exited with code {code}")
    args: Any = process.args
    Path(args[4]).unlink(missing_ok=True)  # the copy written by _spawn_specimen
