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
of what was recorded.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from rths import __version__
from rths.config import build
from rths.config.scenario import Scenario
from rths.core.errors import ConfigError, DataError, check_positive
from rths.log.recorder import (
    LOOP_SCHEMA,
    LOOP_TOPIC,
    Recorder,
    RecordingSummary,
    object_schema,
)
from rths.metrics import TrackingSummary, summarize
from rths.runtime.clocks import SWITCH_INTERVAL, FreeRunning, Pacer, WallClock
from rths.runtime.loop import InProcessLink, LinkSample, Loop, LoopResult
from rths.wire.keys import check_run_id, new_run_id

__all__ = ["RunOptions", "RunOutcome", "run_scenario"]

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
        Handshake and per-step (lockstep) timeouts [s].
    progress
        Called from a display thread with (steps done, total).
    seed
        Noise seed overriding the scenario's.
    run_id
        The run id (keys ``rths/<run_id>/``); default ``<name>-<timestamp>-<random>``.
    on_waiting
        Called with the ``rths specimen`` command line when waiting for an external specimen.
    """

    clock: str | None = None
    out: Path | None = None
    compensator: str | None = None
    listen: tuple[str, ...] = ()
    connect: tuple[str, ...] = ()
    external_specimen: bool = False
    ready_timeout: float = 30.0
    step_timeout: float = 5.0
    progress: Callable[[int, int], None] | None = None
    seed: int | None = None
    run_id: str | None = None
    on_waiting: Callable[[str], None] | None = None


@dataclass
class RunOutcome:
    """What a run produced: the log, the loop result, metrics and the recording's counts."""

    path: Path
    run_id: str
    clock: str
    result: LoopResult
    metrics: TrackingSummary | None
    recording: RecordingSummary | None = None
    events: list[str] = field(default_factory=list)
    saturated: dict[str, int] = field(default_factory=dict)

    def line(self) -> str:
        """The one-line summary the CLI prints."""
        m, t = self.metrics, self.result.timing
        parts = [f"{self.result.steps} steps"]
        if m is not None:
            parts += [
                f"J1 {1e3 * m.j1_delay:.3f} ms",
                f"J2 {100 * m.j2:.3f} %",
                f"J3 {100 * m.j3:.3f} %",
                f"sync RMSE {100 * m.sync_rmse:.3f} %",
            ]
        else:
            parts.append("metrics n/a")
        parts.append(f"overruns {t.overruns}/{t.steps}")
        if self.clock == "realtime":
            parts.append(f"p99 jitter {1e6 * t.jitter_p99:.0f} us")
        gaps = sum(s.missing for s in self.recording.topics.values()) if self.recording else 0
        parts.append(f"gaps {gaps}")
        clipped = {k: v for k, v in self.saturated.items() if v}
        if clipped:
            parts.append("SATURATED " + ", ".join(f"{k} {v}" for k, v in clipped.items()))
        return ", ".join(parts) + f" -> {self.path}"


class _Collector:
    """Keeps target, measured and force per step for the summary (preallocated, no I/O)."""

    def __init__(self, n: int) -> None:
        self.target, self.measured, self.force = np.zeros(n), np.zeros(n), np.zeros(n)
        self.age = np.zeros(n)
        self.count = 0

    def __call__(self, record: dict[str, float]) -> None:
        k = int(record["seq"])
        self.target[k], self.measured[k] = record["target"], record["measured"]
        self.force[k], self.age[k] = record["force"], record["age"]
        self.count = k + 1


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


def _metadata(
    scn: Scenario, run_id: str, clock: str, comp_kind: str, seed: int
) -> dict[str, dict[str, str]]:
    s = scn.scaling
    return {
        "scenario": {
            "path": scn.source,
            "text": scn.text,
            "name": scn.run.name,
            **({"overrides": repr(dict(scn.overrides))} if scn.overrides else {}),
        },
        "rths": {"version": __version__, "run_id": run_id, "python": sys.version.split()[0]},
        "run": {
            "clock": clock,
            "rate_hz": repr(scn.run.rate),
            "dt_s": repr(scn.run.dt),
            "steps": str(scn.run.steps),
            "seed": str(seed),
            "compensator": comp_kind,
            "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        },
        "scaling": {
            "displacement": repr(s.displacement),
            "force": repr(s.force),
            "impedance": repr(s.impedance),
            "meaning": "specimen displacement = displacement * prototype displacement; "
            "prototype force = force * specimen force",
        },
        "units": {
            "t": "s",
            "target": "m",
            "command": "m",
            "measured": "m",
            "force": "N",
            "correction": "N (prototype scale)",
            "age": "s",
            "scale": "target/command/measured/force are at specimen scale",
        },
    }


def _new_run_id(name: str) -> str:
    safe = "".join(c if c.isalnum() or c in "-_." else "-" for c in name)[:32].strip("-.") or "run"
    return f"{safe}-{new_run_id()}"[:64]


def run_scenario(scn: Scenario, options: RunOptions | None = None) -> RunOutcome:
    """Run ``scn`` (see the module docstring); the MCAP log is always finished."""
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
    path.parent.mkdir(parents=True, exist_ok=True)
    n, dt = scn.run.steps, scn.run.dt
    substructure = build.substructure(scn)
    link_delay = REALTIME_LINK_DELAY_STEPS * dt if clock == "realtime" else 0.0
    compensator = build.compensator(scn, opts.compensator, extra_delay=link_delay)
    substructure.predict(0.0)  # compile kernels before the clock starts
    pacer: Pacer = WallClock(dt, n) if clock == "realtime" else FreeRunning(dt, n)
    collector = _Collector(n)
    progress = _Progress(opts.progress, n) if opts.progress else None
    topics = {LOOP_TOPIC: LOOP_SCHEMA, SPECIMEN_TOPIC: SPECIMEN_SCHEMA}
    outcome = RunOutcome(path, run_id, clock, LoopResult(0, pacer.stats()), None)
    with Recorder(
        path, topics=topics, metadata=_metadata(scn, run_id, clock, comp_kind, seed)
    ) as rec:
        rec.event(0, "start", f"run {run_id}: {scn.run.name}, clock {clock}, {n} steps")

        def make_loop(link: Any, sink: Callable[[dict[str, float]], None]) -> Loop:
            def record(r: dict[str, float]) -> None:
                collector(r)
                sink(r)

            return Loop(
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

        def on_progress(k: int) -> None:
            if progress is not None:
                progress.done = k

        if progress is not None:
            progress.start()
        switch = sys.getswitchinterval()
        if clock != "fast":  # see rths.runtime.clocks.SWITCH_INTERVAL
            sys.setswitchinterval(SWITCH_INTERVAL)
        try:
            if clock == "fast":
                lab = build.lab(scn, seed)
                loop = make_loop(
                    _TruthLink(lab, rec),
                    lambda r: rec.put(LOOP_TOPIC, int(r["seq"]), round(r["t"] * 1e9), r),
                )
                outcome.result = loop.run(on_progress)
            else:
                from rths.session.zenoh_run import (
                    run_over_zenoh,  # zenoh is imported only here
                )

                outcome.result = run_over_zenoh(
                    scn,
                    opts,
                    clock,
                    run_id,
                    rec,
                    make_loop,
                    on_progress,
                    path.with_suffix(".specimen.log"),
                    lambda: round(collector.count * dt * 1e9),
                    seed,
                )
        finally:
            sys.setswitchinterval(switch)
            if progress is not None:
                progress.finish()
        t_end = round(max(outcome.result.steps, collector.count) * dt * 1e9)
        if outcome.result.stopped:
            rec.event(t_end, "stopped", outcome.result.stopped)
        k = collector.count
        try:
            outcome.metrics = summarize(
                collector.target[:k],
                collector.measured[:k],
                collector.force[:k],
                dt,
                max_delay=min(0.1, 0.25 * k * dt),
            )
        except DataError as exc:  # too short or too quiet a record for some metric
            outcome.events.append(f"metrics not computed: {exc}")
        outcome.saturated = _saturations(scn, collector.measured[:k], collector.force[:k])
        for channel, count in outcome.saturated.items():
            if count:
                rec.event(
                    t_end,
                    "saturation",
                    f"{count} {channel} samples at the ADC's full scale: clipped",
                )
        rec.add_metadata("rths.summary", _summary(outcome))
        rec.event(t_end, "end", f"{outcome.result.steps} steps")
    outcome.recording = rec.summary
    return outcome


def _saturations(scn: Scenario, measured: np.ndarray, force: np.ndarray) -> dict[str, int]:
    """Samples at an ADC's extreme code (the converter clipped them), per channel."""
    conv = build.converters(scn)
    out = {}
    for name, values, c in (
        ("displacement", measured, conv.displacement),
        ("force", force, conv.force),
    ):
        top = 2 ** (c.bits - 1)
        high, low = (top - 1) * c.resolution, -top * c.resolution
        out[name] = int(
            np.count_nonzero((values >= high * (1 - 1e-12)) | (values <= low * (1 - 1e-12)))
        )
    return out


def _summary(outcome: RunOutcome) -> dict[str, str]:
    t = outcome.result.timing
    out = {
        "steps": str(outcome.result.steps),
        "stopped": outcome.result.stopped or "",
        "overruns": str(t.overruns),
        "jitter_p99_s": repr(t.jitter_p99),
        "busy_mean_s": repr(t.busy_mean),
        "busy_max_s": repr(t.busy_max),
    }
    if outcome.metrics is not None:
        out.update({k: repr(v) for k, v in outcome.metrics.to_dict().items()})
    if outcome.events:
        out["notes"] = "; ".join(outcome.events)
    out.update({f"saturated_{k}": str(v) for k, v in outcome.saturated.items()})
    return out
