"""The specimen process (``rths specimen``): the emulated lab served over zenoh.

It builds the lab from the scenario file (the same file the coordinator reads), reads the run's
secret (from its standard input when ``rths run`` starts it), connects to the coordinator,
announces readiness and then answers every command with one lab step, at once -- in ``lockstep``
(deterministic) and in ``realtime`` alike, where the coordinator waits for the answer until the
step's deadline.  A probe (:meth:`rths.wire.codec.Command.probe`, the ``realtime`` clock's
warm-up before step 0) is answered at once without stepping the lab.  Messages that do not carry
the run's check are dropped and counted.
Commands are read from a FIFO channel on the serving thread, not answered inside zenoh's
callback (:class:`rths.wire.transport.CallbackServer`): that saved ~25 µs p50 per round trip
but publishes while holding the interpreter lock on zenoh's thread, and one lockstep run at load
15 hung for a second with it; a frozen interpreter could not ramp the actuator down.

Every command passes the specimen side's own interlock first (:class:`CommandGuard`: stroke,
velocity, per-step change); the actuator never sees anything else.  When the guard trips, when
the coordinator asks to stop or goes away, or -- in real time -- when commands stop coming for
``[loop] command_timeout`` (the command watchdog; 20 ms by default, never less than the
measurement watchdog's ``max_lag`` steps), the process drives the actuator back to zero with a
controlled ramp on its own clock, asks the coordinator to stop (naming why) and ends.

Every step it also records the lab's row (true kinematics and force, the actuator's and the
specimen's internal states; :meth:`plants.lab.EmulatedLab.write_channels`) into a preallocated
block, published a block at a time on the ``specimen`` log stream, which the coordinator records
as MCAP topic ``rths/specimen``.  In ``realtime`` the row rides on the step's measurement
instead (:func:`rths.wire.codec.pack_reply`): a side-stream frame while the loop runs wakes a
thread in each process, and interleaved at load 5-7 (2048 Hz, 10 s, ``RTHS_RT_PRIORITY=50``)
runs without that stream missed 3.5 / 1.6 / 16.8 % of their deadlines against 5.2 / 26 / 28 %
with it.  Its summary (steps, guard figures, ramp-down, timing, garbage
collections, messages dropped) goes on ``specimen/summary``.  The garbage collector is kept out
of the serving loop (:class:`rths.runtime.clocks.QuietGC`).
"""

from __future__ import annotations

import json
import math
import sys
import threading
import time
import traceback
from typing import Any

from plants.lab import EmulatedLab
from rths.config import build
from rths.config.scenario import Scenario
from rths.core.channels import RowBlock
from rths.core.errors import TransportError
from rths.runtime.clocks import (
    SWITCH_INTERVAL,
    QuietGC,
    WallClock,
    realtime_priority,
    realtime_thread,
)
from rths.runtime.cpu_latency import CpuLatency
from rths.runtime.guard import CommandGuard
from rths.wire.auth import RunSecret
from rths.wire.codec import Command, Measurement
from rths.wire.transport import (
    BackgroundPublisher,
    BlockPublisher,
    LockstepServer,
    Presence,
    RunKeys,
    ZenohEndpoints,
    open_session,
)

__all__ = ["serve"]

#: Rows per published block of the lab's truth.  Small on purpose: a side-stream frame of
#: 13 kB (64 rows) held the zenoh ``put`` for 5.3-7.5 ms the first time one was sent while the
#: real-time loop ran, and the coordinator missed the measurements of the 3-6 steps after it in
#: every run at 2048 Hz (the "stall at step 80"; a primer of that size sent before step 0 moved
#: the stall to the start instead of removing it).  16-row frames (4.5 kB) never took more than
#: 0.35 ms (36 puts in 3 runs, ``RTHS_RT_PRIORITY=50``).
BLOCK_ROWS = 16
#: Most rows one reply carries in real time (rows of steps stepped without a reply, after a
#: hold-up, wait for the next one); beyond that they go out on the side stream.
RIDE_ROWS = 64
#: Resolution [s] of the command watchdog (the inbox's wake-up tick).
WATCHDOG_TICK = 0.002
#: Longest wait [s] for a command before a stop request is looked at: a long command watchdog
#: (``command_timeout``) must not delay the ramp-down after a stop.
STOP_SLICE = 0.005
#: Longest wait [s], after a stop this side asked for and its ramp-down, for the coordinator's
#: stop in return before this process leaves: leaving at once withdrew its liveliness token
#: before a held-up coordinator had read the request, which then reported "went away".
STOP_ACK = 0.5


def _warm_up(lab: EmulatedLab) -> None:
    """Step once and reset, so compiled kernels are built before the handshake."""
    lab.step(0.0)
    lab.write_channels(RowBlock(lab.channels(), 1).values[0])
    lab.reset()


class _Rows:
    """The lab's rows: :data:`BLOCK_ROWS` at a time to a :class:`BlockPublisher` (``lockstep``),
    or riding on the measurements (``ride``, the ``realtime`` clock: :meth:`riding` hands the
    rows not sent yet to the next reply; when :data:`RIDE_ROWS` of them wait, a backlog, they
    go to the publisher).

    Parameters
    ----------
    lab
        The lab whose rows are logged.
    publisher
        Where blocks go; None: the rows are not logged at all.
    ride
        Whether the rows ride on the replies.
    """

    def __init__(
        self, lab: EmulatedLab, publisher: BlockPublisher | None, ride: bool = False
    ) -> None:
        self.lab, self.publisher = lab, publisher
        self.channels = lab.channels()
        self.ride = ride and publisher is not None
        self.size = RIDE_ROWS if self.ride else BLOCK_ROWS
        self.block = RowBlock(self.channels, self.size)

    def add(self, seq: int, t_ns: int) -> None:
        if self.publisher is None:
            return
        b = self.block
        i = b.count
        self.lab.write_channels(b.values[i])
        b.seq[i], b.t_ns[i] = seq, t_ns
        b.count = i + 1
        if b.count == self.size:
            self.flush()

    def riding(self) -> RowBlock | None:
        """The rows the next reply carries (None: none); :meth:`sent` once it is packed."""
        return self.block if self.ride and self.block.count else None

    def sent(self) -> None:
        """The rows handed out by :meth:`riding` were packed into a reply: start afresh."""
        if self.ride:
            self.block.count = 0

    def flush(self) -> None:
        if self.publisher is not None and self.block.count:
            self.publisher.put_block(self.block)
            self.block = RowBlock(self.channels, self.size)


def serve(
    scn: Scenario,
    run_id: str,
    endpoints: ZenohEndpoints,
    clock: str,
    *,
    ready_timeout: float = 30.0,
    log_state: bool = True,
    seed: int | None = None,
    secret: RunSecret | None = None,
) -> int:
    """Serve the scenario's emulated lab until stopped; return the number of steps served.

    Parameters
    ----------
    scn
        The scenario (its ``[specimen]``, ``[actuator]``, ``[lab]``, ``[loop]`` and ``[run]``
        tables).
    run_id
        The run's id (keys under ``rths/<run_id>/``).
    endpoints
        Where to connect (or listen).
    clock
        ``"lockstep"`` or ``"realtime"``.
    ready_timeout
        Longest wait [s] for the coordinator.
    log_state
        Publish the lab's rows on the ``specimen`` log stream.
    seed
        Noise seed of the lab (default: the scenario's ``[run] seed``).
    secret
        The run's secret (:mod:`rths.wire.auth`); None: plain messages (tests only).

    Raises
    ------
    TransportError
        If the coordinator never comes up or the link fails.
    """
    if clock not in ("lockstep", "realtime"):
        raise TransportError(f"the specimen process serves 'lockstep' or 'realtime'; got {clock!r}")
    if clock == "realtime":
        realtime_priority()  # opt-in (RTHS_RT_PRIORITY), before zenoh starts its threads
    lab = build.lab(scn, seed)
    _warm_up(lab)
    guard = CommandGuard(build.guard_limits(scn), scn.run.dt)
    keys = RunKeys(run_id)
    with (
        open_session(endpoints) as session,
        BlockPublisher(session, keys.specimen_state, secret=secret) as log,
        BackgroundPublisher(session, keys.log("specimen/summary"), secret=secret) as summary,
    ):
        rows = _Rows(lab, log if log_state else None, ride=clock == "realtime")
        server = _Server(scn, lab, guard, rows, clock)
        try:
            server.run(session, keys, endpoints, ready_timeout, secret)
        except Exception as exc:
            summary.put(
                round(lab.time * 1e9),
                {"error": f"specimen process failed: {exc!r}", "traceback": traceback.format_exc()},
            )
            raise
        finally:
            server.rows.flush()
        figures = server.summary()
        summary.put(round(lab.time * 1e9), figures)
        print("specimen summary: " + json.dumps(figures), file=sys.stderr, flush=True)
        return server.served


class _Server:
    """The serving loop (one instance per run)."""

    def __init__(
        self, scn: Scenario, lab: EmulatedLab, guard: CommandGuard, rows: _Rows, clock: str
    ) -> None:
        self.scn, self.lab, self.guard, self.rows, self.clock = scn, lab, guard, rows, clock
        self.dt = scn.run.dt
        self.steps = scn.run.steps
        self.served = 0
        self.ramp_steps = 0
        self.stop_reason = ""
        self.quiet = QuietGC()
        self.latency = CpuLatency()  # both clocks the specimen serves are round trips
        self.opener: Any = None
        self.refused = 0
        self.late_commands = 0
        self.probes = 0  # warm-up probes answered (rths.wire.codec.Command.probe)
        self.tripped_ns = 0  # monotonic clock when the serving loop ended (trip or stop)
        self.safe_ns = 0  # monotonic clock when the actuator was back at rest

    def run(
        self,
        session: Any,
        keys: RunKeys,
        endpoints: ZenohEndpoints,
        ready_timeout: float,
        secret: RunSecret | None,
    ) -> None:
        with (
            LockstepServer(session, keys, secret, tick=WATCHDOG_TICK) as link,
            Presence(session, keys, "specimen", endpoints.describe(), secret) as presence,
        ):
            self.opener = link.opener
            sys.setswitchinterval(SWITCH_INTERVAL)
            realtime_thread()
            with (
                self.quiet,  # before announcing: the full collection it starts with is slow
                self.latency,
            ):
                presence.wait_for_peer(ready_timeout, [link.publisher])
                self._serve(link, presence)
                self.tripped_ns = time.monotonic_ns()
                asked = self.guard.tripped is not None and not presence.stop.is_set()
                if asked:  # say why, then ramp
                    presence.request_stop(f"specimen interlock: {self.guard.tripped}")
                self._ramp_down(link)
                self.safe_ns = time.monotonic_ns()
                if asked:  # the coordinator's answer: it has our reason (not "went away")
                    presence.stop.wait(STOP_ACK)
            self.refused = presence.refused

    def _serve(self, link: LockstepServer, presence: Presence) -> None:
        """Answer commands until a stop, the end of the run, a trip or a silent coordinator."""
        guard, rows = self.guard, self.rows
        realtime = self.clock == "realtime"
        # the command watchdog: real time only (in lockstep the lab does not move on its own)
        loop = self.scn.loop
        timeout = max(loop.command_timeout, loop.max_lag * self.dt, WATCHDOG_TICK)
        idle = self.quiet.idle
        last_seq = -1
        while not presence.stop.is_set():
            wait = timeout if realtime and 0 <= last_seq < self.steps - 1 else 0.05
            command = _receive(link, presence.stop, wait)
            if command is None:
                if realtime and 0 <= last_seq < self.steps - 1 and not presence.stop.is_set():
                    guard.trip(
                        f"no command for {wait * 1e3:.1f} ms after step {last_seq} "
                        "(command watchdog)"
                    )
                    self.stop_reason = guard.tripped or ""
                    return
                continue
            # a backlog (this process was held up): step through every queued command, answer
            # only the newest (the coordinator has dropped the older ones); probes move nothing
            while (newer := link.pending()) is not None:
                if not command.is_probe:
                    self._step(command, reply=None)
                    self.late_commands += 1
                command = newer
            if presence.stop.is_set():
                break  # its reason is recorded below
            if command.is_probe:  # the coordinator warming the round trip: answer, move nothing
                link.reply(Measurement(command.seq, command.t_ns, 0.0, 0.0, time.monotonic_ns()))
                self.probes += 1
                continue
            self._step(command, reply=link)
            last_seq = command.seq
            if guard.tripped:
                self.stop_reason = guard.tripped
                return
            idle(round(self.dt * 1e9) // 2)
        self.stop_reason = presence.stop_reason
        rows.flush()

    def _step(self, command: Command, reply: LockstepServer | None) -> None:
        displacement, force = self.lab.step(self.guard.apply(command.command))
        rows = self.rows
        if rows.ride:  # the step's row rides on its measurement (and any not sent yet)
            rows.add(command.seq, command.t_ns)
        if reply is not None:
            reply.reply(
                Measurement(command.seq, command.t_ns, displacement, force, time.monotonic_ns()),
                rows.riding(),
            )
            rows.sent()
        if not rows.ride:
            rows.add(command.seq, command.t_ns)
        self.lab.prepare()  # e.g. the next block of noise, now rather than in the next step
        self.served += 1

    def _ramp_down(self, link: LockstepServer) -> None:
        """Drive the actuator to zero through the guard (paced by the wall clock in real time);
        commands that still arrive are counted and ignored."""
        guard = self.guard
        guard.trip(self.stop_reason or "stop")
        n = guard.ramp_steps()
        if n == 0:
            return
        pacer = WallClock(self.dt, n + 1) if self.clock == "realtime" else None
        if pacer is not None:
            pacer.start()
        for k in range(n + 1):
            if pacer is not None:
                pacer.wait(k)
            while link.pending() is not None:
                guard.ignored += 1
            self.lab.step(guard.ramp())
            self.ramp_steps += 1
            if guard.at_rest:
                break

    def summary(self) -> dict[str, Any]:
        """The process's figures for the coordinator's log."""
        out: dict[str, Any] = {
            "steps": self.served,
            "stop_reason": self.stop_reason,
            "ramp_down_steps": self.ramp_steps,
            "late_commands": self.late_commands,
            "probes_answered": self.probes,
            "gc_collections_in_loop": self.quiet.collections,
            "gc_longest_s": self.quiet.longest,
            "cpu_latency": self.latency.describe(),
            "stopped_at_ns": self.tripped_ns,
            "at_rest_ns": self.safe_ns,
            **self.guard.summary(),
            **{f"saturated_{name}": count for name, count in self.lab.saturation_counts.items()},
        }
        if self.opener is not None:
            c = self.opener.counts()
            out["auth_commands_accepted"] = c["accepted"]
            out["auth_forged_dropped"] = c["forged"] + self.refused
            out["auth_replayed_dropped"] = c["replayed"]
        if not math.isfinite(out["gc_longest_s"]):
            out["gc_longest_s"] = 0.0
        return out


def _receive(link: LockstepServer, stop: threading.Event, wait: float) -> Command | None:
    """The next command within ``wait`` [s], or None -- at once (within :data:`STOP_SLICE`)
    when ``stop`` is set meanwhile."""
    if wait <= STOP_SLICE:
        return link.receive(wait)
    deadline = time.monotonic() + wait
    while True:
        left = deadline - time.monotonic()
        command = link.receive(max(min(left, STOP_SLICE), 0.0))
        if command is not None or stop.is_set() or left <= STOP_SLICE:
            return command
