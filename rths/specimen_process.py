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
from rths import build
from rths.clocks import WallClock
from rths.codec import Command, Measurement
from rths.errors import TransportError
from rths.scenario import Scenario
from rths.transport import (
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

    Raises
    ------
    TransportError
        If the coordinator never comes up or the link fails.
    """
    if clock not in ("lockstep", "realtime"):
        raise TransportError(f"the specimen process serves 'lockstep' or 'realtime'; got {clock!r}")
    lab = build.lab(scn)
    _warm_up(lab)
    keys = RunKeys(run_id)
    with open_session(endpoints) as session, BackgroundPublisher(session, keys.specimen_state) as log:
        try:
            if clock == "lockstep":
                return _lockstep(lab, session, keys, endpoints, log, ready_timeout, log_state)
            return _realtime(scn, lab, session, keys, endpoints, log, ready_timeout, log_state)
        except Exception as exc:
            log.put(0, {"error": f"specimen process failed: {exc!r}",
                        "traceback": traceback.format_exc()})  # fmt: skip
            raise


def _lockstep(lab, session, keys, endpoints, log, ready_timeout, log_state) -> int:  # noqa: ANN001
    with LockstepServer(session, keys) as link, Presence(
        session, keys, "specimen", endpoints.describe()
    ) as presence:
        presence.wait_for_peer(ready_timeout, [link.publisher])
        sys.setswitchinterval(50e-6)  # as the coordinator (rths.runner.REALTIME_SWITCH_INTERVAL)

        def respond(command: Command) -> Measurement:
            displacement, force = lab.step(command.command)
            if log_state:
                log.put(command.t_ns, lab.truth())
            return Measurement(command.seq, command.t_ns, displacement, force, time.monotonic_ns())

        return link.serve(respond, presence.stop)


def _realtime(scn, lab, session, keys, endpoints, log, ready_timeout, log_state) -> int:  # noqa: ANN001
    dt = scn.run.dt
    dt_ns = round(dt * 1e9)
    # run up to 10 s past the scenario's end if the coordinator is late to stop us
    horizon = scn.run.steps + round(10.0 / dt)
    with RealtimeServer(session, keys) as link, Presence(
        session, keys, "specimen", endpoints.describe()
    ) as presence:
        presence.wait_for_peer(ready_timeout, [link.publisher])
        sys.setswitchinterval(50e-6)  # as the coordinator (rths.runner.REALTIME_SWITCH_INTERVAL)
        pacer = WallClock(dt, horizon)
        command = 0.0
        pacer.start()
        k = 0
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
        stats = pacer.stats()
        log.put((k + 1) * dt_ns, {"overruns": stats.overruns, "steps": stats.steps,
                                  "jitter_p99": stats.jitter_p99})  # fmt: skip
        return k
