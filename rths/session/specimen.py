"""The specimen process (``rths specimen``): the emulated lab served over zenoh.

It builds the lab from the scenario file (the same file the coordinator reads), reads the run's
secret (from its standard input when ``rths run`` starts it), connects to the coordinator,
announces readiness and then answers every command with one lab step, at once -- in ``lockstep``
(deterministic) and in ``realtime`` alike, where the coordinator waits for the answer until the
step's deadline.  The answer is computed and published inside zenoh's subscriber callback
(:class:`rths.wire.transport.CallbackServer`): no hand-over to another thread on the way, one
thread wake-up per step in this process.  Messages that do not carry the run's check are
dropped and counted.

Every command passes the specimen side's own interlock first (:class:`CommandGuard`: stroke,
velocity, per-step change); the actuator never sees anything else.  When the guard trips, when
the coordinator asks to stop or goes away, or -- in real time -- when commands stop coming for
``max_lag`` steps (the command watchdog), the process drives the actuator back to zero with a
controlled ramp on its own clock, asks the coordinator to stop (naming why) and ends.

Every step it also records the lab's row (true kinematics and force, the actuator's and the
specimen's internal states; :meth:`plants.lab.EmulatedLab.write_channels`) into a preallocated
block, published a block at a time on the ``specimen`` log stream, which the coordinator records
as MCAP topic ``rths/specimen``.  Its summary (steps, guard figures, ramp-down, timing, garbage
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
from rths.runtime.guard import CommandGuard
from rths.wire.auth import RunSecret
from rths.wire.codec import Command, Measurement
from rths.wire.transport import (
    BackgroundPublisher,
    BlockPublisher,
    CallbackServer,
    Presence,
    RunKeys,
    ZenohEndpoints,
    open_session,
)

__all__ = ["serve"]

#: Rows per published block of the lab's truth.
BLOCK_ROWS = 64
#: Resolution [s] of the command watchdog and of noticing a stop request (the serving thread's
#: wake-up tick; the commands themselves are answered in zenoh's callback, not on this tick).
WATCHDOG_TICK = 0.002
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
    """The lab's rows, a block at a time, to a :class:`BlockPublisher`."""

    def __init__(self, lab: EmulatedLab, publisher: BlockPublisher | None) -> None:
        self.lab, self.publisher = lab, publisher
        self.channels = lab.channels()
        self.block = RowBlock(self.channels, BLOCK_ROWS)

    def add(self, seq: int, t_ns: int) -> None:
        if self.publisher is None:
            return
        b = self.block
        i = b.count
        self.lab.write_channels(b.values[i])
        b.seq[i], b.t_ns[i] = seq, t_ns
        b.count = i + 1
        if b.count == BLOCK_ROWS:
            self.flush()

    def flush(self) -> None:
        if self.publisher is not None and self.block.count:
            self.publisher.put_block(self.block)
            self.block = RowBlock(self.channels, BLOCK_ROWS)


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
        server = _Server(scn, lab, guard, _Rows(lab, log if log_state else None), clock)
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
    """The serving loop (one instance per run).

    Commands are answered inside zenoh's subscriber callback (:meth:`_respond`, on zenoh's
    thread: guard, lab step, reply, row); the main thread only watches -- the command watchdog,
    stop requests, trips -- every :data:`WATCHDOG_TICK`, then ramps down.  ``_lock`` keeps the
    two apart: once serving has ended, the callback counts commands as ignored and never
    touches the lab again.
    """

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
        self.opener: Any = None
        self.refused = 0
        self.tripped_ns = 0  # monotonic clock when the serving loop ended (trip or stop)
        self.safe_ns = 0  # monotonic clock when the actuator was back at rest
        self._lock = threading.Lock()
        self._serving = False
        self._ended = threading.Event()  # set by the callback: a trip or an error
        self._last_seq = -1
        self._last_ns = 0
        self._idle_ns = round(self.dt * 1e9) // 2
        self._link: CallbackServer | None = None

    def run(
        self,
        session: Any,
        keys: RunKeys,
        endpoints: ZenohEndpoints,
        ready_timeout: float,
        secret: RunSecret | None,
    ) -> None:
        with (
            CallbackServer(
                session, keys, self._respond, secret, on_error=lambda _: self._ended.set()
            ) as link,
            Presence(session, keys, "specimen", endpoints.describe(), secret) as presence,
        ):
            self._link, self.opener = link, link.opener
            sys.setswitchinterval(SWITCH_INTERVAL)
            realtime_thread()
            with self.quiet:  # before announcing: the full collection it starts with is slow
                with self._lock:
                    self._serving = True
                presence.wait_for_peer(ready_timeout, [link.publisher])
                self._serve(presence)
                self.tripped_ns = time.monotonic_ns()
                if link.error is not None:
                    raise link.error
                asked = self.guard.tripped is not None and not presence.stop.is_set()
                if asked:  # say why, then ramp
                    presence.request_stop(f"specimen interlock: {self.guard.tripped}")
                self._ramp_down()
                self.safe_ns = time.monotonic_ns()
                if asked:  # the coordinator's answer: it has our reason (not "went away")
                    presence.stop.wait(STOP_ACK)
            self.refused = presence.refused

    def _respond(self, command: Command) -> None:
        """Answer one command (zenoh's thread): guard, lab step, reply at once, then the row."""
        with self._lock:
            if not self._serving:
                self.guard.ignored += 1
                return
            guard = self.guard
            displacement, force = self.lab.step(guard.apply(command.command))
            assert self._link is not None
            self._link.reply(
                Measurement(command.seq, command.t_ns, displacement, force, time.monotonic_ns())
            )
            self.rows.add(command.seq, command.t_ns)
            self.served += 1
            self._last_seq, self._last_ns = command.seq, time.monotonic_ns()
            if guard.tripped:
                self._serving = False
                self._ended.set()
                return
            self.quiet.idle(self._idle_ns)

    def _serve(self, presence: Presence) -> None:
        """Watch the callback serve until a stop, a trip, an error or a silent coordinator."""
        realtime = self.clock == "realtime"
        # the command watchdog: real time only (in lockstep the lab does not move on its own)
        timeout_ns = round(max(self.scn.loop.max_lag * self.dt, WATCHDOG_TICK) * 1e9)
        last = self.steps - 1
        while not self._ended.wait(WATCHDOG_TICK):
            if presence.stop.is_set():
                break
            if not realtime:
                continue
            with self._lock:
                seq, silent = self._last_seq, time.monotonic_ns() - self._last_ns
                if 0 <= seq < last and silent > timeout_ns and self._serving:
                    self.guard.trip(
                        f"no command for {silent * 1e-6:.1f} ms after step {seq} "
                        f"(command watchdog, {timeout_ns * 1e-6:.1f} ms)"
                    )
                    self._serving = False
                    break
        with self._lock:
            self._serving = False
            self.rows.flush()
        self.stop_reason = self.guard.tripped or presence.stop_reason

    def _ramp_down(self) -> None:
        """Drive the actuator to zero through the guard (paced by the wall clock in real time);
        commands that still arrive are counted and ignored (by :meth:`_respond`)."""
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
            "gc_collections_in_loop": self.quiet.collections,
            "gc_longest_s": self.quiet.longest,
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
