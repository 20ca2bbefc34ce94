"""The zenoh side of ``rths run`` (``lockstep`` and ``realtime`` clocks; private to
rths.session.runner).

Starts the specimen process (or waits for an external one), hands it the run's secret off the
command line (its standard input; a mode-600 file for a specimen on another host), wires the
authenticated links, the log bridge and the live copy of the loop rows, runs the loop and, when
the specimen fails or vanishes, ends the run with a message that names it and the specimen's last
words.  After every stop the specimen is asked to stop, which it does with a controlled ramp to
zero (its :class:`rths.runtime.guard.CommandGuard`).

``realtime`` is synchronous: command ``k`` goes out, the specimen steps once and answers at once,
and the loop waits for that answer until the step's deadline
(:class:`rths.wire.sync_link.SyncClient`).
Before step 0 the round trip is warmed with probes that move nothing
(:mod:`rths.session.warm_up`; a ``warm-up`` event in the log says what it saw).

The spawned specimen reads the secret and then the scenario text from its stdin (no file is left
behind on any path) and runs in its own session, so a Ctrl-C in the terminal reaches the
coordinator only: the coordinator stops the loop and then tells the specimen to stop, in that
order.  A specimen that dies is noticed at once (its liveliness token, or its exit status), and a
lockstep wait for its measurement is woken rather than left to time out.  At the end the
specimen gets :data:`GRACE` seconds to exit after the stop request, then SIGTERM, then SIGKILL;
its stderr is read into memory and its lines written into the log as an event.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from rths.config.scenario import Scenario
from rths.core.channels import Channel
from rths.core.errors import ConfigError, RTHSError, TransportError
from rths.log.recorder import Recorder
from rths.runtime.loop import LinkSample, Loop, LoopResult
from rths.session.specimen_rows import SpecimenRows
from rths.session.warm_up import warm_up
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

__all__ = ["GRACE", "run_over_zenoh"]

#: Seconds a specimen process gets to exit after the stop request before SIGTERM (and as long
#: again before SIGKILL); after a failure, :data:`FAILED_GRACE`.
GRACE = 2.0
FAILED_GRACE = 0.3
#: Lines of the spawned specimen's stderr kept (the last is quoted when it fails).
STDERR_LINES = 50
#: How often [s] the watcher checks that a spawned specimen process is still running.
_WATCH = 0.05


class _LockstepLink:
    def __init__(self, client: Any, timeout: float, presence: Presence) -> None:
        self.client, self.timeout, self.presence = client, timeout, presence

    def exchange(self, seq: int, t_ns: int, command: float) -> LinkSample:
        m = self.client.exchange(Command(seq, t_ns, command), self.timeout)
        return LinkSample(m.displacement, m.force, 0, m.seq)

    def safe_stop(self, reason: str) -> int:
        self.presence.request_stop(reason)
        return 0


#: How long [ns] the coordinator waits, after a real-time loop, for replies still on their way
#: (their rows belong in the log).
DRAIN_NS = 20_000_000

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
        riders: SpecimenRows | None = None,
    ):
        self.client, self.deadline_ns, self.presence = client, deadline_ns, presence
        self.half_step = round(dt * 5e8)
        self.riders = riders

    def exchange(self, seq: int, t_ns: int, command: float) -> LinkSample:
        client = self.client
        # on schedule: until the next step is due; behind it (already an overrun, counted):
        # half a step for the answer, so a late loop still uses fresh measurements and
        # catches up instead of missing every one
        deadline = max(self.deadline_ns(seq + 1) - RESERVE_NS, time.monotonic_ns() + self.half_step)
        m = client.exchange(Command(seq, t_ns, command), deadline)
        if self.riders is not None:
            self.riders.handover()  # a full block of the specimen's rows, once the wait is over
        if m is None:  # deadline missed: the newest sample we have (or rest before the first)
            m = client.newest
            if m is None:
                return LinkSample(0.0, 0.0, 0, -1)
        return LinkSample(m.displacement, m.force, time.monotonic_ns() - m.sample_ns, m.seq)

    def safe_stop(self, reason: str) -> int:
        self.presence.request_stop(reason)
        return 0

    def finish(self) -> None:
        """After the loop: the specimen's rows gathered so far to the log first (its last rows,
        stepped without a reply, come on its side stream as it stops), then those of the
        replies still on their way."""
        if self.riders is not None:
            self.riders.flush()
            self.client.drain(time.monotonic_ns() + DRAIN_NS)
            self.riders.flush()


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


class _SpecimenProcess:
    """The spawned ``rths specimen``: the process, and the last lines of its stderr, read by a
    thread into memory -- no file is left behind, even when the coordinator is killed."""

    def __init__(
        self, scn: Scenario, run_id: str, endpoint: str, clock: str, seed: int, secret: RunSecret
    ) -> None:
        args = [
            sys.executable, "-m", "rths", "specimen",
            "-",  # the text the coordinator parsed, on stdin: an edit mid-run cannot split them
            "--run-id", run_id, "--connect", endpoint, "--clock", clock, "--seed", str(seed),
            "--secret-stdin",
        ]  # fmt: skip
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        env.pop("RTHS_RUN_SECRET", None)
        self.process = subprocess.Popen(
            args,
            stdin=subprocess.PIPE,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            env=env,
            start_new_session=True,  # terminal signals reach the coordinator, which stops it
        )
        self.lines: deque[str] = deque(maxlen=STDERR_LINES)
        self._reader = threading.Thread(target=self._read, name="rths-specimen-stderr", daemon=True)
        self._reader.start()
        assert self.process.stdin is not None
        try:  # off argv (ps shows argv to everyone): the secret's line, then the scenario
            self.process.stdin.write((secret.hex() + "\n" + scn.text).encode("utf-8"))
            self.process.stdin.close()
        except OSError:  # it died at once: the handshake reports its exit code
            pass

    def _read(self) -> None:
        assert self.process.stderr is not None
        with self.process.stderr:
            for raw in self.process.stderr:
                line = raw.decode("utf-8", errors="replace").rstrip()
                if line:
                    self.lines.append(line)

    def stop(self, grace: float) -> int:
        """Stop it (:func:`_stop_process`) and collect the rest of its stderr; its exit code."""
        code = _stop_process(self.process, grace)
        self._reader.join(timeout=1.0)
        return code

    def last_words(self) -> str:
        """Its last stderr line (after :meth:`stop`), or its exit code."""
        if self.lines:
            return self.lines[-1][:300]
        return f"exited with code {self.process.returncode}"


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
    now_ns: Callable[[], int],
    seed: int,
    live: Any = None,
    specimen_channels: Sequence[Channel] = (),
) -> tuple[LoopResult, dict[str, int]]:
    """Run the loop against a specimen process over zenoh; see the module docstring.

    Parameters
    ----------
    scn : rths.config.scenario.Scenario
        The parsed scenario (the specimen process builds its lab from the same file).
    opts : rths.session.runner.RunOptions
        The run's options (endpoints, secret file, external specimen, timeouts).
    clock : str
        ``"lockstep"`` or ``"realtime"``.
    run_id : str
        The run's id; every key lives under ``rths/<run_id>/``.
    rec : rths.log.recorder.Recorder
        The run's open recorder (the specimen's log streams are bridged into it).
    make_loop : Callable[..., rths.runtime.loop.Loop]
        ``make_loop(link, sink)`` builds the loop on the zenoh link.
    on_progress : Callable[[int], None]
        ``on_progress(k)``, called every 256 steps from the loop thread.
    now_ns : Callable[[], int]
        Simulated time [ns] of the last recorded step, for error events.
    seed : int
        Seed of the lab's noise, >= 0.
    live : object or None
        A Foxglove live server that also receives the specimen's rows; None (default): none.
    specimen_channels : sequence of rths.core.channels.Channel
        The lab's channels: in ``realtime`` its rows ride on the measurements
        (:mod:`rths.session.specimen_rows`).

    Returns
    -------
    result : rths.runtime.loop.LoopResult
        The loop's result.
    security : dict of str to int
        Messages ``"accepted"`` and dropped as ``"forged"`` or ``"replayed"``.
    """
    keys = RunKeys(run_id)
    listen = opts.listen or (() if opts.connect else (loopback_endpoint(),))
    endpoints = ZenohEndpoints(listen=tuple(listen), connect=tuple(opts.connect))
    secret, secret_path = _secret(opts, rec.path)
    specimen: _SpecimenProcess | None = None
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
                    raise ConfigError("starting the specimen here needs a --listen endpoint")
                specimen = _SpecimenProcess(scn, run_id, listen[0], clock, seed, secret)
            elif opts.on_waiting is not None:
                where = f"--connect {listen[0]}" if listen else "--listen <endpoint>"
                opts.on_waiting(
                    f"rths specimen {scn.source} --run-id {run_id} {where} "
                    f"--clock {clock} --seed {seed} --secret-file {secret_path}"
                )
            watcher: _PeerWatch | None = None
            try:
                process = specimen.process if specimen else None
                _wait_for_specimen(presence, [client.publisher], opts.ready_timeout, process)
                link: Any
                riders: SpecimenRows | None = None
                if isinstance(client, SyncClient):
                    topic = keys.topic_of(keys.specimen_state)
                    riders = SpecimenRows(specimen_channels, topic, tee.put_block)
                    client.on_rows = riders.add
                    warmed = warm_up(client, scn.run.dt, reserve_ns=RESERVE_NS)
                    rec.event(0, "warm-up", warmed.describe(), **warmed.as_dict())
                    link = _SyncLink(
                        client, lambda k: loop.pacer.deadline_ns(k), presence, scn.run.dt, riders
                    )
                else:
                    link = _LockstepLink(client, opts.step_timeout, presence)
                loop = make_loop(link, live_copy.put_block)
                abort = getattr(client, "abort", lambda: None)
                watcher = _PeerWatch(presence, loop, abort, process)
                watcher.start()
                try:
                    result = loop.run(on_progress)
                finally:
                    watcher.finish()
                    if isinstance(link, _SyncLink):
                        link.finish()
                if watcher.lost and result.stopped == watcher.reason:
                    # the loop saw the stop between two steps rather than in its wait for a
                    # measurement: a dead specimen is an error whichever way it was noticed
                    raise TransportError(watcher.reason)
                return result, _security(client, presence, bridge)
            except RTHSError as exc:
                presence.request_stop(f"coordinator failed: {exc}")
                last = ""
                if specimen is not None:
                    specimen.stop(FAILED_GRACE)
                    last = specimen.last_words()
                why = (
                    (watcher.reason if watcher else "")
                    or presence.stop_reason
                    or (
                        "the specimen process stopped answering (crashed or stuck?)"
                        if isinstance(exc, TransportError)
                        else ""
                    )
                )
                if watcher is not None and watcher.reason and isinstance(exc, TransportError):
                    # the link was woken because the specimen is gone: that is the news
                    head = f"lost the specimen at t = {now_ns() * 1e-9:.4f} s: {watcher.reason}"
                else:
                    head = str(exc) + (f"; {why}" if why else "")
                message = head + (f"; specimen process said: {last}" if last else "")
                rec.event(now_ns(), "error", message)
                raise TransportError(message) if isinstance(exc, TransportError) else exc from None
            except BaseException:  # Ctrl-C before the loop, or a bug: the specimen stops too
                presence.request_stop("coordinator interrupted")
                raise
            finally:
                _reap(specimen, rec)
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


class _PeerWatch(threading.Thread):
    """Stops the loop -- and wakes its wait for a measurement -- as soon as the specimen is gone:
    its liveliness token withdrawn, a stop request from it, or (spawned here) its exit."""

    def __init__(
        self,
        presence: Any,
        loop: Loop,
        abort: Callable[[], None],
        process: subprocess.Popen[bytes] | None,
    ) -> None:
        super().__init__(name="rths-peer-watch", daemon=True)
        self.presence, self.loop, self.abort, self.process = presence, loop, abort, process
        self.reason = ""
        #: the specimen died (exited, or its token went away unasked), rather than asking to stop
        self.lost = False
        self._done = threading.Event()

    def run(self) -> None:
        while not self.presence.stop.wait(_WATCH):
            if self._done.is_set():
                return
            if self.process is not None and self.process.poll() is not None:
                if self.presence.stop.wait(_WATCH):
                    break  # it asked to stop before it exited: its request is the reason
                self.reason = f"specimen process exited with code {self.process.returncode}"
                self.lost = True
                break
        if self._done.is_set():
            return
        self.lost = self.lost or bool(getattr(self.presence, "peer_gone", False))
        self.reason = self.reason or self.presence.stop_reason or "specimen stopped"
        self.loop.stop(self.reason)
        try:
            self.abort()
        except Exception:  # the link is closing anyway
            pass

    def finish(self) -> None:
        """The loop has returned: stand down."""
        self._done.set()
        self.join(timeout=1.0)


def _stop_process(process: subprocess.Popen[bytes], grace: float) -> int:
    """Wait ``grace`` seconds for the process to exit, then SIGTERM (and SIGCONT, should it be
    stopped), as long again, then SIGKILL; return its exit code."""
    try:
        return process.wait(timeout=grace)
    except subprocess.TimeoutExpired:
        pass
    for sig in (signal.SIGTERM, signal.SIGCONT):
        try:
            process.send_signal(sig)
        except OSError:
            pass
    try:
        return process.wait(timeout=max(grace, 0.5))
    except subprocess.TimeoutExpired:
        process.kill()
        return process.wait()


def _reap(specimen: _SpecimenProcess | None, rec: Recorder) -> None:
    """Stop the spawned specimen (:data:`GRACE`); log a failure and what it wrote on stderr."""
    if specimen is None:
        return
    code = specimen.stop(GRACE)
    if code not in (0, None):
        rec.event(0, "specimen", f"specimen process exited with code {code}")
    if specimen.lines:
        rec.event(0, "specimen_stderr", "\n".join(specimen.lines))
