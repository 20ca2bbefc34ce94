"""The zenoh side of ``rths run`` (``lockstep`` and ``realtime`` clocks; private to
rths.session.runner).

Starts the specimen process (or waits for an external one), hands it the run's secret off the
command line (its standard input; a mode-600 file for a specimen on another host), wires the
authenticated links, the log bridge and the live copy of the loop rows, runs the loop and, when
the specimen fails or vanishes, ends the run with a message that names it and the specimen's last
words.  After every stop the specimen is asked to stop, which it does with a controlled ramp to
zero (its :class:`rths.runtime.guard.CommandGuard`).

``realtime`` is synchronous: command ``k`` goes out, the specimen steps once and answers at once,
and the loop waits for that answer until the step's deadline (:class:`rths.wire.links.SyncClient`).
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
from rths.log.recorder import Recorder
from rths.runtime.loop import LinkSample, Loop, LoopResult
from rths.wire.auth import RunSecret, read_secret, write_secret_file
from rths.wire.codec import Command
from rths.wire.transport import (
    BlockPublisher,
    LockstepClient,
    LogBridge,
    Presence,
    RunKeys,
    SyncClient,
    ZenohEndpoints,
    loopback_endpoint,
    open_session,
)

__all__ = ["run_over_zenoh"]


class _LockstepLink:
    def __init__(self, client: Any, timeout: float, presence: Presence) -> None:
        self.client, self.timeout, self.presence = client, timeout, presence

    def exchange(self, seq: int, t_ns: int, command: float) -> LinkSample:
        m = self.client.exchange(Command(seq, t_ns, command), self.timeout)
        return LinkSample(m.displacement, m.force, 0, m.seq)

    def safe_stop(self, reason: str) -> int:
        self.presence.request_stop(reason)
        return 0


#: Time [ns] kept free at the end of a step after a missed measurement: the rest of the step's
#: work (its row, the pacer) must still end before the next step is due.
RESERVE_NS = 20_000


class _SyncLink:
    """Synchronous real time: wait for measurement ``k`` until the start of step ``k + 1``
    (less :data:`RESERVE_NS`)."""

    def __init__(
        self,
        client: SyncClient,
        deadline_ns: Callable[[int], int],
        presence: Presence,
        dt: float,
    ):
        self.client, self.deadline_ns, self.presence = client, deadline_ns, presence
        self.half_step = round(dt * 5e8)

    def exchange(self, seq: int, t_ns: int, command: float) -> LinkSample:
        client = self.client
        # on schedule: until the next step is due; behind it (already an overrun, counted):
        # half a step for the answer, so a late loop still uses fresh measurements and
        # catches up instead of missing every one
        deadline = max(self.deadline_ns(seq + 1) - RESERVE_NS, time.monotonic_ns() + self.half_step)
        m = client.exchange(Command(seq, t_ns, command), deadline)
        if m is None:  # deadline missed: the newest sample we have (or rest before the first)
            m = client.newest
            if m is None:
                return LinkSample(0.0, 0.0, 0, -1)
        return LinkSample(m.displacement, m.force, time.monotonic_ns() - m.sample_ns, m.seq)

    def safe_stop(self, reason: str) -> int:
        self.presence.request_stop(reason)
        return 0


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
    scn: Scenario, run_id: str, endpoint: str, clock: str, log: Path, seed: int, secret: RunSecret
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
        "--secret-stdin",
    ]
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    env.pop("RTHS_RUN_SECRET", None)
    with log.open("wb") as stderr:  # the child keeps its own descriptor
        process = subprocess.Popen(
            args, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=stderr, env=env
        )
    assert process.stdin is not None
    process.stdin.write((secret.hex() + "\n").encode())  # off argv: ps shows argv to everyone
    process.stdin.close()
    return process


def _secret(opts: Any, out: Path) -> tuple[RunSecret, Path | None]:
    """The run's secret: a fresh one, or the external specimen's from ``--secret-file``."""
    if opts.secret_file is not None:
        return read_secret(opts.secret_file), Path(opts.secret_file)
    secret = RunSecret.new()
    if opts.external_specimen:
        return secret, write_secret_file(out.with_suffix(".secret"), secret)
    return secret, None


def run_over_zenoh(
    scn: Scenario,
    opts: Any,
    clock: str,
    run_id: str,
    rec: Recorder,
    make_loop: Callable[..., Loop],
    on_progress: Callable[[int], None],
    stderr_log: Path,
    now_ns: Callable[[], int],
    seed: int,
    live: Any = None,
) -> tuple[LoopResult, dict[str, int]]:
    """Run the loop against a specimen process over zenoh; see the module docstring.

    ``opts`` is the run's :class:`rths.session.runner.RunOptions`; ``make_loop(link, sink)`` builds
    the loop; ``stderr_log`` receives the spawned specimen's stderr; ``now_ns()`` gives the
    simulated time of the last recorded step for error events; ``seed`` seeds the lab's noise;
    ``live`` (a Foxglove server, or None) also receives the specimen's rows.  Returns the loop's
    result and the authentication counts (messages accepted, dropped as forged or replayed).
    """
    keys = RunKeys(run_id)
    listen = opts.listen or (() if opts.connect else (loopback_endpoint(),))
    endpoints = ZenohEndpoints(listen=tuple(listen), connect=tuple(opts.connect))
    secret, secret_path = _secret(opts, stderr_log.with_suffix("").with_suffix(".mcap"))
    process = None
    tee = _Tee(rec, live)
    with (
        open_session(endpoints) as session,
        LogBridge(session, keys, tee, secret) as bridge,
        BlockPublisher(session, keys.loop, reliable=False, secret=secret) as live_copy,
    ):
        client: LockstepClient | SyncClient = (
            LockstepClient(session, keys, opts.step_timeout, secret)
            if clock == "lockstep"
            else SyncClient(session, keys, secret)
        )
        with (
            client,
            Presence(session, keys, "coordinator", endpoints.describe(), secret) as presence,
        ):
            if not opts.external_specimen:
                if not listen:
                    raise TransportError("starting the specimen here needs a --listen endpoint")
                process = _spawn_specimen(scn, run_id, listen[0], clock, stderr_log, seed, secret)
            elif opts.on_waiting is not None:
                where = f"--connect {listen[0]}" if listen else "--listen <endpoint>"
                opts.on_waiting(
                    f"rths specimen {scn.source} --run-id {run_id} {where} "
                    f"--clock {clock} --seed {seed} --secret-file {secret_path}"
                )
            try:
                _wait_for_specimen(presence, [client.publisher], opts.ready_timeout, process)
                link: Any
                if isinstance(client, SyncClient):
                    link = _SyncLink(
                        client, lambda k: loop.pacer.deadline_ns(k), presence, scn.run.dt
                    )
                else:
                    link = _LockstepLink(client, opts.step_timeout, presence)
                loop = make_loop(link, live_copy.put_block)
                watcher = threading.Thread(
                    target=_stop_on_peer_loss, args=(presence, loop), daemon=True
                )
                watcher.start()
                result = loop.run(on_progress)
                return result, _security(client, presence, bridge)
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
                counts = _security(client, presence, bridge)
                if counts.get("forged") or counts.get("replayed"):
                    rec.event(
                        now_ns(),
                        "forged",
                        f"dropped {counts['forged']} forged and {counts['replayed']} replayed "
                        "messages (they changed nothing)",
                        **counts,
                    )


class _Tee:
    """The bridge's sink: the recorder, and the live server for the specimen's rows."""

    def __init__(self, rec: Recorder, live: Any) -> None:
        self.rec, self.live = rec, live

    def put_record(self, topic: str, payload: bytes) -> None:
        self.rec.put_record(topic, payload)

    def put_block(self, topic: str, block: Any) -> None:
        self.rec.put_block(topic, block)
        if self.live is not None:
            self.live.put_block(topic, block)


def _security(client: Any, presence: Presence, bridge: LogBridge) -> dict[str, int]:
    """Messages accepted and dropped (forged, replayed) by every opener of the run."""
    out = {"accepted": 0, "forged": 0, "replayed": 0}
    counts = [c for c in bridge.refused().values()]
    if client.opener is not None:
        counts.append(client.opener.counts())
    for c in counts:
        for k in out:
            out[k] += c[k]
    out["forged"] += presence.refused
    return out


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
