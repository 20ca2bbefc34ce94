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
              only fills preallocated rows and publishes the command.  The MCAP writer runs in a
              process of its own at ordinary priority (:mod:`rths.log.writer.writer_process`), so
              encoding and compressing a block neither holds this process's GIL nor takes the
              loop's CPU; it finishes the log even if this process is killed.

Every clock computes with one BLAS thread (:mod:`rths.session.blas`).  Real-time runs keep the
garbage collector out of the loop (:class:`rths.runtime.clocks.QuietGC`) and lower the loop
thread's timer slack; collections, deadline misses and the measurement's age are counted and
written to the summary.

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
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rths.config import build
from rths.config.scenario import Scenario
from rths.core.channels import RowBlock
from rths.core.errors import ConfigError, check_positive
from rths.log.live import parse_where
from rths.log.recorder import LOOP_TOPIC, Recorder, block_schema
from rths.runtime.clocks import (
    SWITCH_INTERVAL,
    FreeRunning,
    Pacer,
    QuietGC,
    WallClock,
    realtime_priority,
    realtime_thread,
)
from rths.runtime.cpu_latency import CpuLatency
from rths.runtime.guard import CommandGuard
from rths.runtime.loop import InProcessLink, LinkSample, Loop, LoopResult
from rths.session.blas import one_blas_thread
from rths.session.budget import check_budget, step_cost
from rths.session.outcome import (
    Collector,
    RunOutcome,
    benchmark_scores,
    finish_record,
    run_metadata,
)
from rths.session.stopping import StopRequest
from rths.wire.auth import read_secret
from rths.wire.keys import check_run_id, new_run_id

__all__ = ["RunOptions", "RunOutcome", "StopRequest", "benchmark_scores", "run_scenario"]

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
    secret_file
        File holding the run secret (hex) for an external specimen; default: a fresh secret
        written to ``<log>.secret`` (mode 600) when the specimen is external.
    live
        Serve the run to Foxglove over WebSocket while it runs (``host:port``; None: no).
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
    secret_file: Path | None = None
    live: str | None = None
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


#: Items (row blocks) the fast clock lets wait for the recorder's writer thread: the compiled
#: loop can outrun the writer (one core for both), and what is queued when a nearly full disk
#: stops the run must fit the log's 8 MiB disk reserve (32 blocks of 256 rows: ~2 MB at 2048 Hz).
FAST_BACKLOG = 32


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

    def fused(self) -> tuple[Any, CommandGuard | None, Any]:
        """The lab, the guard and this link as the sink of the lab's rows (the compiled path
        fills :meth:`current` and calls :meth:`flush` when it is full)."""
        return self.lab, self.guard, self

    def current(self) -> RowBlock:
        """The block of the lab's rows being filled."""
        return self._block

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


@one_blas_thread()
def run_scenario(scn: Scenario, options: RunOptions | None = None) -> RunOutcome:
    """Run ``scn`` (see the module docstring); the MCAP log is always finished.

    Parameters
    ----------
    scn : rths.config.scenario.Scenario
        The parsed scenario.
    options : RunOptions or None
        The CLI's flags (clock, log path, compensator, endpoints, seed, ...); None (default):
        :class:`RunOptions` defaults, i.e. the scenario's own choices.

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
    if opts.live:
        parse_where(opts.live)
    if opts.secret_file is not None:
        read_secret(opts.secret_file)  # unreadable, shared with others or not a secret: now
    path = opts.out or Path("runs") / f"{run_id}.mcap"
    _check_out(path)
    n, dt = scn.run.steps, scn.run.dt
    substructure = build.substructure(scn)
    compensator = build.compensator(scn, opts.compensator)
    # built on every clock: what the specimen process would refuse is refused before it starts
    lab = build.lab(scn, seed)
    substructure.predict(0.0)  # compile kernels before the clock starts
    check_budget(scn, clock, step_cost(substructure, compensator, lab), log_dir=path.parent)
    stop = opts.stop or StopRequest()
    quiet = QuietGC() if clock == "realtime" else None
    priority = realtime_priority() if clock == "realtime" else 0  # opt-in: RTHS_RT_PRIORITY
    # real time: idle CPUs poll instead of halting while the run lasts (RTHS_CPU_LATENCY_US)
    latency = CpuLatency() if clock in ("realtime", "lockstep") else None
    pacer: Pacer = WallClock(dt, n) if clock == "realtime" else FreeRunning(dt, n)
    if quiet is not None:
        pacer.idle = quiet.idle
    collector = Collector(n)
    progress = _Progress(opts.progress, n) if opts.progress else None
    outcome = RunOutcome(path, run_id, clock, LoopResult(0, pacer.stats()), None)
    outcome.priority = priority
    # bound before the log is opened: a port in use is refused with nothing left behind
    live = _live_server(opts.live) if opts.live else None
    with (
        _closing(live),
        Recorder(
            path,
            topics={},
            metadata=run_metadata(scn, run_id, clock, comp_kind, seed),
            on_fault=lambda message: stop.request(f"recording: {message}", fault=True),
            # off this process's GIL and CPU share when the loop runs against a wall clock or a
            # peer; the fast clock keeps the cheaper thread
            writer="thread" if clock == "fast" else "process",
        ) as rec,
    ):
        rec.event(0, "start", f"run {run_id}: {scn.run.name}, clock {clock}, {n} steps")
        if live is not None:
            host = opts.live.rpartition(":")[0] if opts.live else ""
            rec.event(0, "live", f"serving the run to Foxglove on ws://{host}:{live.port}")

        def make_loop(link: Any, extra_sink: Callable[[RowBlock], None] | None = None) -> Loop:
            def sink(block: RowBlock) -> None:
                collector(block)
                if clock == "fast":  # the compiled loop can outrun the writer thread
                    rec.throttle(FAST_BACKLOG)
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
            stop.attach(loop)
            return loop

        def on_progress(k: int) -> None:
            if progress is not None:
                progress.done = k

        if progress is not None:
            progress.start()
        switch = sys.getswitchinterval()
        # see rths.runtime.clocks.SWITCH_INTERVAL; on the fast clock the compiled path releases
        # the GIL to the writer thread during each block and takes it back right after
        sys.setswitchinterval(SWITCH_INTERVAL)
        error: BaseException | None = None
        try:
            if clock == "fast":
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

                specimen_channels = lab.channels()
                del lab  # the specimen process builds its own
                realtime_thread()
                with (
                    quiet if quiet is not None else _nothing(),
                    latency if latency is not None else _nothing(),
                ):
                    if latency is not None:
                        outcome.cpu_latency = latency.describe()
                    outcome.result, outcome.security = run_over_zenoh(
                        scn,
                        opts,
                        clock,
                        run_id,
                        rec,
                        make_loop,
                        on_progress,
                        lambda: round(collector.count * dt * 1e9),
                        seed,
                        live,
                        specimen_channels,
                    )
                if quiet is not None:
                    outcome.gc = (quiet.collections, quiet.longest)
        except BaseException as exc:
            error = exc
            raise
        finally:
            stop.detach()
            sys.setswitchinterval(switch)
            if progress is not None:
                progress.finish()
            finish_record(
                rec,
                scn,
                outcome,
                collector,
                error,
                reference=getattr(substructure, "reference_response", None),
            )
    outcome.recording = rec.summary
    return outcome


@contextmanager
def _nothing() -> Iterator[None]:
    yield


@contextmanager
def _closing(live: Any) -> Iterator[None]:
    """Close the live server (if any) when the block ends, however it ends."""
    try:
        yield
    finally:
        if live is not None:
            live.close()


def _live_server(where: str) -> Any:
    """The Foxglove WebSocket server of ``--live HOST:PORT`` (imported only when asked)."""
    from rths.log.live import LiveServer

    return LiveServer.start(where)
