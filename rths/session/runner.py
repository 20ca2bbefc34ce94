"""Run a scenario end to end: build, connect the specimen, loop, record, summarise.

``fast``      everything in this process; the loop writes the MCAP log through the recorder's
              queue.
``lockstep``  and ``realtime``: the specimen is a separate process (``rths specimen``) started here
              (or elsewhere, ``external_specimen=True``).  Commands and measurements cross zenoh;
              the specimen's own stream (its truth each step) arrives on ``rths/<run>/log/
              specimen`` and the recorder, subscribed through a
              :class:`rths.wire.transport.LogBridge`, writes it into the MCAP log.  The loop's
              record goes to the recorder's queue (never lost) and a live copy to
              ``rths/<run>/loop`` for monitors, published from a background thread: the loop thread
              only enqueues and publishes the command.

A crashed or vanished specimen ends the run with a :class:`rths.core.errors.TransportError`; the log
is finished, carries an ``error`` event with the specimen's last words (its stderr), and the summary
of what was recorded.  So does every other way a run can end (:mod:`rths.session.outcome`):
SIGINT, SIGTERM and SIGHUP stop the loop after its step (:mod:`rths.session.stopping`), as does a
nearly full disk; an exception is named in the summary's ``stopped``.  Everything a run can be
refused for -- bad options, plants that cannot be built (the lab included, also when a specimen
process will build it), a budget beyond the machine (:mod:`rths.session.budget`) -- is checked
before any file is opened or process started.
"""

from __future__ import annotations

import sys
import threading
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rths.config import build
from rths.config.scenario import Scenario
from rths.core.errors import ConfigError, check_positive
from rths.log.recorder import LOOP_SCHEMA, LOOP_TOPIC, Recorder, object_schema
from rths.runtime.clocks import SWITCH_INTERVAL, FreeRunning, Pacer, WallClock
from rths.runtime.loop import InProcessLink, LinkSample, Loop, LoopResult
from rths.session.budget import check_budget, step_cost
from rths.session.outcome import Collector, RunOutcome, finish_record, run_metadata
from rths.session.stopping import StopRequest
from rths.wire.keys import check_run_id, new_run_id

__all__ = ["RunOptions", "RunOutcome", "StopRequest", "run_scenario"]

SPECIMEN_TOPIC = "rths/specimen"

#: Extra delay [loop steps] the realtime link adds, which the compensator is told about: the
#: free-running specimen picks a command up at its next tick (~1 step) and the loop uses the
#: newest measurement, ~1 step old on average (the logged ``age``).
REALTIME_LINK_DELAY_STEPS = 2.0

#: Schema of ``rths/specimen``: the emulated lab's truth each step (plus the actuator's and the
#: specimen's internal states as ``actuator.<name>`` / ``actuator.specimen.<name>``, SI).
SPECIMEN_SCHEMA = object_schema(
    "rths.specimen",
    {
        "t": "simulated time at the end of the step [s]",
        "command": "command received [m]",
        "command_dac": "command after the DAC [m]",
        "displacement": "true displacement of the specimen end [m]",
        "velocity": "true velocity of the specimen end [m/s]",
        "acceleration": "true acceleration of the specimen end [m/s^2]",
        "force": "true restoring force of the specimen [N]",
        "measured_displacement": "displacement after the ADC (noise, quantisation) [m]",
        "measured_force": "force after the ADC (noise, quantisation) [N]",
    },
    description="One step of the emulated lab, specimen scale.",
)


@dataclass(frozen=True)
class RunOptions:
    """How to run a scenario (the CLI's flags).

    Attributes
    ----------
    clock
        ``lockstep``, ``realtime`` or ``fast`` (default: the scenario's).
    out
        MCAP path (default ``runs/<run-id>.mcap``).
    compensator
        Compensator kind overriding the scenario's (with default options).
    listen, connect
        zenoh endpoints of the coordinator (default: listen on a free loopback port).
    external_specimen
        Do not start ``rths specimen``; wait for one started elsewhere.
    ready_timeout, step_timeout
        Handshake and per-step (lockstep) timeouts [s]: a lockstep round trip takes half a
        millisecond, so a specimen silent for a second has hung.
    progress
        Called from a display thread with (steps done, total).
    seed
        Noise seed overriding the scenario's.
    run_id
        The run id (keys ``rths/<run_id>/``); default ``<name>-<timestamp>-<random>``.
    on_waiting
        Called with the ``rths specimen`` command line when waiting for an external specimen.
    stop
        The run's stop request (the CLI routes SIGINT, SIGTERM and SIGHUP to it); default: one
        of its own (the recorder still stops the run through it when the disk fills up).
    """

    clock: str | None = None
    out: Path | None = None
    compensator: str | None = None
    listen: tuple[str, ...] = ()
    connect: tuple[str, ...] = ()
    external_specimen: bool = False
    ready_timeout: float = 30.0
    step_timeout: float = 1.0
    progress: Callable[[int, int], None] | None = None
    seed: int | None = None
    run_id: str | None = None
    on_waiting: Callable[[str], None] | None = None
    stop: StopRequest | None = None


class _Progress(threading.Thread):
    """Calls ``report(done, total)`` a few times a second from its own thread."""

    def __init__(self, report: Callable[[int, int], None], total: int) -> None:
        super().__init__(daemon=True)
        self.report, self.total, self.done = report, total, 0
        self._stop = threading.Event()

    def run(self) -> None:
        while not self._stop.wait(0.2):
            self.report(self.done, self.total)

    def finish(self) -> None:
        self._stop.set()
        self.report(self.done, self.total)


class _TruthLink(InProcessLink):
    """The fast clock's link, also recording the lab's truth on ``rths/specimen``."""

    def __init__(self, lab: Any, recorder: Recorder) -> None:
        super().__init__(lab)
        self.recorder = recorder

    def exchange(self, seq: int, t_ns: int, command: float) -> LinkSample:
        sample = super().exchange(seq, t_ns, command)
        self.recorder.put(SPECIMEN_TOPIC, seq, t_ns, self.lab.truth())
        return sample


def _new_run_id(name: str) -> str:
    safe = "".join(c if c.isalnum() or c in "-_." else "-" for c in name)[:32].strip("-.") or "run"
    return f"{safe}-{new_run_id()}"[:64]


def _check_out(path: Path) -> None:
    """The log path must name a file that can be created, in a folder that exists or can be
    made (ConfigError); nothing is left behind by the check."""
    if path.is_dir():
        raise ConfigError(f"--out '{path}' is a directory; give the log's file name")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(f"cannot make the log's folder '{path.parent}': {exc.strerror}") from None
    existed = path.exists()
    try:
        with open(path, "ab"):
            pass
    except OSError as exc:
        raise ConfigError(f"cannot create the log '{path}': {exc.strerror}") from None
    if not existed:
        path.unlink()


def run_scenario(scn: Scenario, options: RunOptions | None = None) -> RunOutcome:
    """Run ``scn`` (see the module docstring); the MCAP log is always finished.

    Raises
    ------
    ConfigError
        Bad options, a scenario whose plants cannot be built, or a run beyond the machine's
        budget (:mod:`rths.session.budget`) -- all before any process starts or file is opened.
    rths.core.errors.RunFault
        The specimen process failed or vanished, or the log could not be written.
    rths.core.errors.Interrupted
        A stop signal arrived before the loop started (a signal during the loop stops it
        gracefully instead: the outcome's ``result.stopped`` says so).
    """
    opts = options or RunOptions()
    clock = opts.clock or scn.run.clock
    comp_kind = opts.compensator or scn.compensator_kind
    run_id = _new_run_id(scn.run.name) if opts.run_id is None else opts.run_id
    check_run_id(run_id)  # before anything is built: it names the keys and the log file
    seed = scn.run.seed if opts.seed is None else opts.seed
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ConfigError(f"seed must be an integer >= 0; got {seed!r}")
    check_positive(opts.ready_timeout, "ready timeout")
    check_positive(opts.step_timeout, "step timeout")
    path = opts.out or Path("runs") / f"{run_id}.mcap"
    _check_out(path)
    n, dt = scn.run.steps, scn.run.dt
    substructure = build.substructure(scn)
    link_delay = REALTIME_LINK_DELAY_STEPS * dt if clock == "realtime" else 0.0
    compensator = build.compensator(scn, opts.compensator, extra_delay=link_delay)
    # built on every clock: what the specimen process would refuse is refused before it starts
    lab = build.lab(scn, seed)
    substructure.predict(0.0)  # compile kernels before the clock starts
    check_budget(scn, clock, step_cost(substructure, compensator, lab), log_dir=path.parent)
    stop = opts.stop or StopRequest()
    pacer: Pacer = WallClock(dt, n) if clock == "realtime" else FreeRunning(dt, n)
    collector = Collector(n)
    progress = _Progress(opts.progress, n) if opts.progress else None
    topics = {LOOP_TOPIC: LOOP_SCHEMA, SPECIMEN_TOPIC: SPECIMEN_SCHEMA}
    outcome = RunOutcome(path, run_id, clock, LoopResult(0, pacer.stats()), None)
    with Recorder(
        path,
        topics=topics,
        metadata=run_metadata(scn, run_id, clock, comp_kind, seed),
        on_fault=lambda message: stop.request(f"recording: {message}", fault=True),
    ) as rec:
        rec.event(0, "start", f"run {run_id}: {scn.run.name}, clock {clock}, {n} steps")

        def make_loop(link: Any, sink: Callable[[dict[str, float]], None]) -> Loop:
            def record(r: dict[str, float]) -> None:
                collector(r)
                sink(r)

            loop = Loop(
                substructure,
                compensator,
                link,
                scn.scaling,
                n,
                pacer,
                record,
                command_limit=scn.loop.stroke,
                force_filter=build.correction_filter(scn),
            )
            stop.attach(loop)
            return loop

        def on_progress(k: int) -> None:
            if progress is not None:
                progress.done = k

        if progress is not None:
            progress.start()
        switch = sys.getswitchinterval()
        if clock != "fast":  # see rths.runtime.clocks.SWITCH_INTERVAL
            sys.setswitchinterval(SWITCH_INTERVAL)
        error: BaseException | None = None
        try:
            if clock == "fast":
                loop = make_loop(
                    _TruthLink(lab, rec),
                    lambda r: rec.put(LOOP_TOPIC, int(r["seq"]), round(r["t"] * 1e9), r),
                )
                outcome.result = loop.run(on_progress)
            else:
                from rths.session.zenoh_run import (
                    run_over_zenoh,  # zenoh is imported only here
                )

                del lab  # the specimen process builds its own
                outcome.result = run_over_zenoh(
                    scn,
                    opts,
                    clock,
                    run_id,
                    rec,
                    make_loop,
                    on_progress,
                    lambda: round(collector.count * dt * 1e9),
                    seed,
                )
        except BaseException as exc:
            error = exc
            raise
        finally:
            stop.detach()
            sys.setswitchinterval(switch)
            if progress is not None:
                progress.finish()
            finish_record(rec, scn, outcome, collector, error)
    outcome.recording = rec.summary
    return outcome
