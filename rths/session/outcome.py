"""What a run leaves behind: its outcome, its metadata and the summary written at its end
(private to :mod:`rths.session.runner`).

:func:`finish_record` writes the end of a run into its log -- the ``stopped`` event, the
saturation events, the ``rths.summary`` metadata and the ``end`` event -- on *every* path that
can still write: a run that ended, one stopped by a signal, an interlock or a full disk, and one
ended by an exception (then ``stopped`` names the exception).  It never raises, so it can run in
a ``finally`` without hiding the error that ended the run.
"""

from __future__ import annotations

import signal
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rths import __version__
from rths.config import build
from rths.config.scenario import Scenario
from rths.core.channels import RowBlock
from rths.core.errors import DataError, Interrupted, ParameterError, RTHSError
from rths.log.recorder import Recorder, RecordingSummary
from rths.metrics import TrackingSummary, summarize
from rths.metrics.vrths import BenchmarkScores, evaluate
from rths.runtime.loop import LoopResult

__all__ = ["Collector", "RunOutcome", "benchmark_scores", "finish_record", "run_metadata"]


@dataclass
class RunOutcome:
    """What a run produced: the log, the loop result, metrics and the recording's counts.

    Attributes
    ----------
    path : pathlib.Path
        The run's MCAP log.
    run_id : str
        The run's id (:func:`rths.wire.keys.check_run_id`).
    clock : str
        ``"lockstep"``, ``"realtime"`` or ``"fast"``.
    result : rths.runtime.loop.LoopResult
        Steps, timing, deadline misses and why the loop stopped.
    metrics : rths.metrics.TrackingSummary or None
        Tracking metrics (J1 delay [s], J2, J3 and sync RMSE [-]); None if they could
        not be computed (the reason is in ``events``).
    recording : rths.log.recorder.RecordingSummary or None
        The recording's counts; None (default) until the log is closed.
    events : list of str
        Notes for the summary (e.g. why metrics were not computed); default empty.
    saturated : dict of str to int
        Samples at an ADC's extreme code, per channel (``"displacement"``, ``"force"``);
        default empty.
    age_p99 : float
        99th percentile of the measurement's age when the loop used it [s] (default 0).
    priority : int
        ``SCHED_FIFO`` priority of the run, 1..99; 0 (default): ordinary scheduling.
    cpu_latency : str
        The PM QoS CPU wake-up latency request held during a real-time run
        (:class:`rths.runtime.cpu_latency.CpuLatency`: ``"0 us"``, or why not); "" (default)
        on the other clocks.
    gc : tuple of (int, float)
        Garbage collections during the loop and the longest one [s] (default ``(0, 0.0)``).
    security : dict of str to int
        Messages ``"accepted"`` and dropped as ``"forged"`` or ``"replayed"`` (runs over zenoh);
        default empty.
    benchmark : rths.metrics.vrths.BenchmarkScores or None
        The vRTHS benchmark's J1 [ms] and J2-J9 [%] when the substructure has a reference
        response; None (default) otherwise.
    """

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
    cpu_latency: str = ""
    gc: tuple[int, float] = (0, 0.0)
    security: dict[str, int] = field(default_factory=dict)
    benchmark: BenchmarkScores | None = None

    def line(self) -> str:
        """The one-line summary the CLI prints (the vRTHS benchmark's J1-J9 when the
        substructure has a reference response, else the project's J1-J3)."""
        m, t, b = self.metrics, self.result.timing, self.benchmark
        parts = [f"{self.result.steps} steps"]
        if b is not None:
            parts.append(
                f"J1 {b.J1:.1f} ms, "
                + ", ".join(f"{k} {v:.2f} %" for k, v in list(b.to_dict().items())[1:])
            )
            if m is not None:
                parts.append(f"sync RMSE {100 * m.sync_rmse:.3f} %")
        elif m is not None:
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


class Collector:
    """Keeps target, measured, force and age (and the frame's floors, ``sub_x1..3``, when the
    substructure logs them) per step for the summary (preallocated; a block's
    columns are copied when the block is handed over, not per step;
    :data:`rths.session.budget.MEMORY_PER_STEP` bytes per step).

    Parameters
    ----------
    n
        Steps of the run.
    """

    def __init__(self, n: int) -> None:
        self.target, self.measured, self.force = np.zeros(n), np.zeros(n), np.zeros(n)
        self.age = np.zeros(n)
        self.floors = np.zeros((n, 3))
        self.count = 0

    def __call__(self, block: RowBlock) -> None:
        n = block.count
        if not n:
            return
        k0 = int(block.seq[0])
        for name in ("target", "measured", "force", "age"):
            getattr(self, name)[k0 : k0 + n] = block.column(name)
        if "sub_x3" in block.names:
            for j, name in enumerate(("sub_x1", "sub_x2", "sub_x3")):
                self.floors[k0 : k0 + n, j] = block.column(name)
        self.count = k0 + n


def benchmark_scores(
    reference: Callable[[int], np.ndarray],
    measured: np.ndarray,
    floors: np.ndarray,
    dt: float,
) -> BenchmarkScores:
    """The vRTHS benchmark's J1-J9 (``F4_evaluation.m``) of a run's rows ``t_1 .. t_n``.

    F4 scores records from ``t = 0``: the rest state is prepended before scoring against the
    substructure's ``reference(n + 1)`` (floors of the unpartitioned frame from ``t = 0``).

    Parameters
    ----------
    reference
        The substructure's ``reference_response(n)`` (floors [m], shape ``(n, 3)``).
    measured
        Measured specimen displacement [m] of rows ``t_1 .. t_n``.
    floors
        The numerical substructure's floors [m], shape ``(n, 3)``.
    dt
        Step [s].
    """
    x_m = np.concatenate([[0.0], measured])
    numerical = np.vstack([np.zeros((1, 3)), floors])
    return evaluate(x_m, numerical, reference(x_m.size), dt)


def run_metadata(
    scn: Scenario, run_id: str, clock: str, comp_kind: str, seed: int
) -> dict[str, dict[str, str]]:
    """The metadata records written at the start of a log (scenario, versions, run, scales).

    Parameters
    ----------
    scn
        The scenario (its text is stored whole).
    run_id
        The run's id.
    clock
        ``fast``, ``lockstep`` or ``realtime``.
    comp_kind
        The compensator kind that ran.
    seed
        The lab's noise seed.
    """
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


def describe(error: BaseException) -> str:
    """How an exception that ended a run reads in its summary's ``stopped``.

    Parameters
    ----------
    error
        The exception (``Interrupted`` and ``KeyboardInterrupt`` read "interrupted by ...").
    """
    if isinstance(error, Interrupted):
        return f"interrupted by {error}"
    if isinstance(error, KeyboardInterrupt):
        return f"interrupted by {signal.SIGINT.name}"
    if isinstance(error, RTHSError):
        return f"error: {error}"
    return f"error: {error!r}"


def finish_record(
    rec: Recorder,
    scn: Scenario,
    outcome: RunOutcome,
    collector: Collector,
    error: BaseException | None = None,
    *,
    reference: Callable[[int], np.ndarray] | None = None,
) -> None:
    """Write the run's end into ``rec`` (module docstring); fills ``outcome``; never raises.

    Parameters
    ----------
    rec
        The run's recorder (still open).
    scn
        The scenario (its step, its converters for the saturation counts).
    outcome
        Filled with the metrics, the saturation counts and notes.
    collector
        What the loop recorded.
    error
        The exception that ended the run, if one did.
    reference
        The substructure's ``reference_response`` (the vRTHS frame): F4's J1-J9 are computed.
    """
    dt = scn.run.dt
    k = collector.count
    t_end = round(max(outcome.result.steps, k) * dt * 1e9)
    stopped = outcome.result.stopped or (describe(error) if error is not None else "")
    try:
        if stopped:
            rec.event(t_end, "stopped", stopped)
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
        if callable(reference):  # the vRTHS benchmark frame: F4's J1-J9
            try:
                outcome.benchmark = benchmark_scores(
                    reference, collector.measured[:k], collector.floors[:k], dt
                )
            except (DataError, ParameterError) as exc:
                outcome.events.append(f"benchmark criteria not computed: {exc}")
        outcome.saturated = _saturations(scn, collector.measured[:k], collector.force[:k])
        for channel, count in outcome.saturated.items():
            if count:
                rec.event(
                    t_end,
                    "saturation",
                    f"{count} {channel} samples at the ADC's full scale: clipped",
                )
        summary = _summary(outcome)
        summary["steps"] = str(max(outcome.result.steps, k))
        summary["stopped"] = stopped
        rec.add_metadata("rths.summary", summary)
        rec.event(t_end, "end", f"{max(outcome.result.steps, k)} steps")
    except Exception as exc:  # the log's own trouble: say so, but never hide the run's error
        outcome.events.append(f"summary not written: {exc!r}")


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
    if outcome.benchmark is not None:
        out.update({k: repr(v) for k, v in outcome.benchmark.to_dict().items()})
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
                "cpu_latency": outcome.cpu_latency,
            }
        )
    out.update({f"auth_{k}": str(v) for k, v in outcome.security.items()})
    if outcome.events:
        out["notes"] = "; ".join(outcome.events)
    out.update({f"saturated_{k}": str(v) for k, v in outcome.saturated.items()})
    return out
