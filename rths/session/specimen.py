"""The specimen process (``rths specimen``): the emulated lab served over zenoh.

It builds the lab from the scenario file (the same file the coordinator reads), connects to the
coordinator, announces readiness and then, per clock:

``lockstep``  answers every command with one lab step (deterministic);
``realtime``  free-runs at the scenario's rate on a wall-clock schedule, stepping the lab with the
              newest command it has (zero-order hold) and publishing every sample stamped with
              the monotonic clock, so the coordinator can measure its age.

Every step it also publishes the lab's truth (true kinematics and force, the specimen's and the
actuator's internal states) on the ``specimen`` log stream, which the coordinator records as MCAP
topic ``rths/specimen``.  It stops when the coordinator asks, when the coordinator disappears, or
when the lab fails -- in which case it publishes an ``error`` record first so the coordinator's
log says why.
"""

from __future__ import annotations

import sys
import time
import traceback

from plants.lab import EmulatedLab
from rths.config import build
from rths.config.scenario import Scenario
from rths.core.errors import TransportError
from rths.runtime.clocks import SWITCH_INTERVAL, WallClock
from rths.wire.codec import Measurement
from rths.wire.transport import (
    BackgroundPublisher,
    LockstepServer,
    Presence,
    RealtimeServer,
    RunKeys,
    ZenohEndpoints,
    open_session,
)

__all__ = ["serve"]


def _warm_up(lab: EmulatedLab) -> None:
    """Step once and reset, so compiled kernels are built before the handshake."""
    lab.step(0.0)
    lab.reset()


def serve(
    scn: Scenario,
    run_id: str,
    endpoints: ZenohEndpoints,
    clock: str,
    *,
    ready_timeout: float = 30.0,
    log_state: bool = True,
    seed: int | None = None,
) -> int:
    """Serve the scenario's emulated lab until stopped; return the number of steps served.

    Parameters
    ----------
    scn
        The scenario (its ``[specimen]``, ``[actuator]``, ``[lab]`` and ``[run]`` tables).
    run_id
        The run's id (keys under ``rths/<run_id>/``).
    endpoints
        Where to connect (or listen).
    clock
        ``"lockstep"`` or ``"realtime"``.
    ready_timeout
        Longest wait [s] for the coordinator.
    log_state
        Publish the lab's truth every step on the ``specimen`` log stream.
    seed
        Noise seed of the lab (default: the scenario's ``[run] seed``).

    Raises
    ------
    TransportError
        If the coordinator never comes up or the link fails.
    """
    if clock not in ("lockstep", "realtime"):
        raise TransportError(f"the specimen process serves 'lockstep' or 'realtime'; got {clock!r}")
    lab = build.lab(scn, seed)
    _warm_up(lab)
    keys = RunKeys(run_id)
    with (
        open_session(endpoints) as session,
        BackgroundPublisher(session, keys.specimen_state) as log,
        BackgroundPublisher(session, keys.log("specimen/summary")) as summary,
    ):
        try:
            if clock == "lockstep":
                served = _lockstep(lab, session, keys, endpoints, log, ready_timeout, log_state)
            else:
                served = _realtime(
                    scn, lab, session, keys, endpoints, log, ready_timeout, log_state, summary
                )
        except Exception as exc:
            summary.put(
                round(lab.time * 1e9),
                {"error": f"specimen process failed: {exc!r}", "traceback": traceback.format_exc()},
            )
            raise
        summary.put(
            round(lab.time * 1e9),
            {
                "steps": served,
                **{f"saturated_{name}": count for name, count in lab.saturation_counts.items()},
            },
        )
        return served


def _lockstep(lab, session, keys, endpoints, log, ready_timeout, log_state) -> int:
    with (
        LockstepServer(session, keys) as link,
        Presence(session, keys, "specimen", endpoints.describe()) as presence,
    ):
        presence.wait_for_peer(ready_timeout, [link.publisher])
        sys.setswitchinterval(SWITCH_INTERVAL)
        served = 0
        while not presence.stop.is_set():
            command = link.receive(0.05)
            if command is None:
                continue
            displacement, force = lab.step(command.command)
            link.reply(
                Measurement(command.seq, command.t_ns, displacement, force, time.monotonic_ns())
            )
            if log_state:  # after the reply: logging is off the round trip
                log.put(command.t_ns, lab.truth())
            served += 1
        return served


def _realtime(scn, lab, session, keys, endpoints, log, ready_timeout, log_state, summary) -> int:
    dt = scn.run.dt
    dt_ns = round(dt * 1e9)
    # run up to 10 s past the scenario's end if the coordinator is late to stop us
    horizon = scn.run.steps + round(10.0 / dt)
    with (
        RealtimeServer(session, keys) as link,
        Presence(session, keys, "specimen", endpoints.describe()) as presence,
    ):
        presence.wait_for_peer(ready_timeout, [link.publisher])
        sys.setswitchinterval(SWITCH_INTERVAL)
        pacer = WallClock(dt, horizon)
        command = 0.0
        pacer.start()
        served = 0
        for k in range(horizon):
            if presence.stop.is_set():
                break
            pacer.wait(k)
            latest = link.latest()
            if latest is not None:
                command = latest.message.command
            displacement, force = lab.step(command)
            t_ns = (k + 1) * dt_ns
            link.publish(Measurement(k, t_ns, displacement, force, time.monotonic_ns()))
            if log_state:
                log.put(t_ns, lab.truth())
            pacer.done(k)
            served = k + 1
        stats = pacer.stats()
        summary.put(served * dt_ns, {"overruns": stats.overruns, "jitter_p99": stats.jitter_p99})
        return served
