"""Run a scenario end to end: build, connect the specimen, loop, record, summarise.

``fast``      everything in this process; the loop writes the MCAP log through the recorder's
              queue.
``lockstep``  and ``realtime``: the specimen is a separate process (``rths specimen``) started here
              (or elsewhere, ``external_specimen=True``).  Commands and measurements cross zenoh,
              sealed with the run's secret (:mod:`rths.wire.auth`), which the specimen process
              gets on its standard input; the specimen's own rows (its truth each step) arrive
              in blocks on ``rths/<run>/log/specimen`` and the recorder, subscribed through a
              :class:`rths.wire.transport.LogBridge`, writes them into the MCAP log.  The loop's
              rows go to the recorder's queue a block at a time (never lost): the loop thread
              only fills preallocated rows and publishes the command.

Real-time runs keep the garbage collector out of the loop (:class:`rths.runtime.clocks.QuietGC`)
and lower the loop thread's timer slack; collections, deadline misses and the measurement's age
are counted and written to the summary.

A crashed or vanished specimen ends the run with a :class:`rths.core.errors.TransportError`; the log
is finished, carries an ``error`` event with the specimen's last words (its stderr), and the summary
of what was recorded.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from rths import __version__
from rths.config import build
from rths.config.scenario import Scenario
from rths.core.channels import RowBlock
from rths.core.errors import ConfigError, DataError, ParameterError, check_positive
from rths.log.recorder import (
    LOOP_TOPIC,
    Recorder,
    RecordingSummary,
    block_schema,
)
from rths.metrics import TrackingSummary, summarize
from rths.runtime.clocks import (
    SWITCH_INTERVAL,
    FreeRunning,
    Pacer,
    QuietGC,
    WallClock,
    realtime_priority,
    realtime_thread,
)
from rths.runtime.guard import CommandGuard
from rths.runtime.loop import InProcessLink, LinkSample, Loop, LoopResult
from rths.wire.keys import check_run_id, new_run_id

__all__ = ["RunOptions", "RunOutcome", "run_scenario"]

SPECIMEN_TOPIC = "rths/specimen"

SPEC_DOC = "One step of the emulated lab, specimen scale (its actuator's state as actuator.*)."
LOOP_DOC = (
    "One RTHS loop step at the interface (specimen scale); Message.sequence = seq = k; "
    "ctrl_*: the compensator's channels, sub_*: the substructure's."
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
    secret_file
        File holding the run secret (hex) for an external specimen; default: a fresh secret
        written to ``<log>.secret`` (mode 600) when the specimen is external.
    live
        Serve the run to Foxglove over WebSocket while it runs (``host:port``; None: no).
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
    secret_file: Path | None = None
    live: str | None = None


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
    age_p99: float = 0.0
    priority: int = 0
    gc: tuple[int, float] = (0, 0.0)
    security: dict[str, int] = field(default_factory=dict)

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
            parts.append(f"misses {self.result.misses}/{t.steps}")
            parts.append(f"p99 jitter {1e6 * t.jitter_p99:.0f} us")
            parts.append(f"p99 age {1e6 * self.age_p99:.0f} us")
        if self.security:
            dropped = self.security.get("forged", 0) + self.security.get("replayed", 0)
            parts.append(f"forged/replayed dropped {dropped}")
        gaps = sum(s.missing for s in self.recording.topics.values()) if self.recording else 0
        parts.append(f"gaps {gaps}")
        clipped = {k: v for k, v in self.saturated.items() if v}
        if clipped:
            parts.append("SATURATED " + ", ".join(f"{k} {v}" for k, v in clipped.items()))
        return ", ".join(parts) + f" -> {self.path}"


class _Collector:
    """Keeps target, measured, force and age per step for the summary (preallocated; a block's
    columns are copied when the block is handed over, not per step)."""

    def __init__(self, n: int) -> None:
        self.target, self.measured, self.force = np.zeros(n), np.zeros(n), np.zeros(n)
        self.age = np.zeros(n)
        self.count = 0

    def __call__(self, block: RowBlock) -> None:
        n = block.count
        if not n:
            return
        k0 = int(block.seq[0])
        for name in ("target", "measured", "force", "age"):
            getattr(self, name)[k0 : k0 + n] = block.column(name)
        self.count = k0 + n


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
    """The fast clock's link, also recording the lab's rows on ``rths/specimen`` (in blocks)."""

    def __init__(
        self, lab: Any, guard: CommandGuard, recorder: Recorder, rows: int, live: Any = None
    ) -> None:
        super().__init__(lab, guard)
        self.recorder, self.live, self.rows_of = recorder, live, lab
        self._channels = lab.channels()
        self._rows = rows
        self._block = RowBlock(self._channels, rows)
        recorder.add_topic(SPECIMEN_TOPIC, block_schema(SPECIMEN_TOPIC, self._block, SPEC_DOC))

    def exchange(self, seq: int, t_ns: int, command: float) -> LinkSample:
        sample = super().exchange(seq, t_ns, command)
        b = self._block
        i = b.count
        self.rows_of.write_channels(b.values[i])
        b.seq[i], b.t_ns[i] = seq, t_ns
        b.count = i + 1
        if b.count == self._rows:
            self.flush()
        return sample

    def flush(self) -> None:
        """Hand the filled rows to the recorder."""
        if self._block.count:
            self.recorder.put_block(SPECIMEN_TOPIC, self._block)
            if self.live is not None:
                self.live.put_block(SPECIMEN_TOPIC, self._block)
            self._block = RowBlock(self._channels, self._rows)

    def safe_stop(self, reason: str) -> int:
        self.flush()
        return super().safe_stop(reason)


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
            "lag": "steps",
            "late": "s",
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
    compensator = build.compensator(scn, opts.compensator)
    substructure.predict(0.0)  # compile kernels before the clock starts
    quiet = QuietGC() if clock == "realtime" else None
    priority = realtime_priority() if clock == "realtime" else 0  # opt-in: RTHS_RT_PRIORITY
    pacer: Pacer = WallClock(dt, n) if clock == "realtime" else FreeRunning(dt, n)
    if quiet is not None:
        pacer.idle = quiet.idle
    collector = _Collector(n)
    progress = _Progress(opts.progress, n) if opts.progress else None
    outcome = RunOutcome(path, run_id, clock, LoopResult(0, pacer.stats()), None)
    outcome.priority = priority
    with Recorder(path, topics={}, metadata=_metadata(scn, run_id, clock, comp_kind, seed)) as rec:
        rec.event(0, "start", f"run {run_id}: {scn.run.name}, clock {clock}, {n} steps")
        live = _live_server(opts.live, rec) if opts.live else None

        def make_loop(link: Any, extra_sink: Callable[[RowBlock], None] | None = None) -> Loop:
            def sink(block: RowBlock) -> None:
                collector(block)
                rec.put_block(LOOP_TOPIC, block)
                if live is not None:
                    live.put_block(LOOP_TOPIC, block)
                if extra_sink is not None:
                    extra_sink(block)

            loop = Loop(
                substructure,
                compensator,
                link,
                scn.scaling,
                n,
                pacer,
                sink,
                command_limit=scn.loop.stroke,
                force_filter=build.correction_filter(scn),
                max_lag=scn.loop.max_lag,
            )
            schema = block_schema(LOOP_TOPIC, RowBlock(loop.channels, 0), LOOP_DOC)
            rec.add_topic(LOOP_TOPIC, schema)
            if live is not None:
                live.add_topic(LOOP_TOPIC, schema)
            return loop

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
                guard = CommandGuard(build.guard_limits(scn), dt)
                loop = make_loop(_TruthLink(lab, guard, rec, 256, live))
                outcome.result = loop.run(on_progress)
                if guard.tripped or loop.safe_stop_steps:
                    rec.event(
                        round(outcome.result.steps * dt * 1e9),
                        "ramp-down",
                        f"{loop.safe_stop_steps} steps to zero at "
                        f"{scn.loop.ramp_velocity:g} m/s ({guard.tripped})",
                        **guard.summary(),
                    )
            else:
                from rths.session.zenoh_run import run_over_zenoh  # zenoh is imported only here

                realtime_thread()
                with quiet if quiet is not None else _nothing():
                    outcome.result, outcome.security = run_over_zenoh(
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
                        live,
                    )
                if quiet is not None:
                    outcome.gc = (quiet.collections, quiet.longest)
        finally:
            sys.setswitchinterval(switch)
            if progress is not None:
                progress.finish()
            if live is not None:
                live.close()
        t_end = round(max(outcome.result.steps, collector.count) * dt * 1e9)
        if outcome.result.stopped:
            rec.event(t_end, "stopped", outcome.result.stopped)
        k = collector.count
        if k:
            outcome.age_p99 = float(np.percentile(collector.age[:k], 99))
        try:
            outcome.metrics = summarize(
                collector.target[:k],
                collector.measured[:k],
                collector.force[:k],
                dt,
                max_delay=min(0.1, 0.25 * k * dt),
            )
        except (DataError, ParameterError) as exc:  # too short or too quiet a record
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


@contextmanager
def _nothing() -> Iterator[None]:
    yield


def _live_server(where: str, rec: Recorder) -> Any:
    """The Foxglove WebSocket server of ``--live HOST:PORT`` (imported only when asked); its
    address goes into the log's events."""
    from rths.log.live import LiveServer

    server = LiveServer.start(where)
    host = where.rpartition(":")[0]
    rec.event(0, "live", f"serving the run to Foxglove on ws://{host}:{server.port}")
    return server


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
    if outcome.clock == "realtime":
        out.update(
            {
                "deadline_misses": str(outcome.result.misses),
                "longest_lag_steps": str(outcome.result.longest_lag),
                "jitter_p50_s": repr(t.jitter_p50),
                "jitter_max_s": repr(t.jitter_max),
                "age_p99_s": repr(outcome.age_p99),
                "gc_collections_in_loop": str(outcome.gc[0]),
                "gc_longest_s": repr(outcome.gc[1]),
                "loop_ended_monotonic_ns": str(outcome.result.ended_ns),
                "sched_fifo_priority": str(outcome.priority),
            }
        )
    out.update({f"auth_{k}": str(v) for k, v in outcome.security.items()})
    if outcome.events:
        out["notes"] = "; ".join(outcome.events)
    out.update({f"saturated_{k}": str(v) for k, v in outcome.saturated.items()})
    return out
