"""The RTHS loop: one fixed-step coordinator for all three clocks.

Each step ``k`` (covering ``[t_k, t_{k+1}]``, ``dt`` fixed)::

    c_k     = force_scale * F_k - device_force      # correction on the substructure's nominal
    device r       = substructure.step(filter(c_k))        # target at t_{k+1} (prototype scale)
    r_spec  = displacement_scale * r                # → specimen scale u_k     =
    compensator.step(r_spec, y_k)         # command held over the step y, F    = link.exchange(k,
    t_{k+1}, u_k)        # the specimen answers (in process / zenoh) sink(record)
    # publish; never I/O beyond that

The same loop serves the three clocks; only the pacer and the link differ:

``fast``      in-process link to an :class:`plants.lab.EmulatedLab`, no pacing (batch, Monte Carlo);
``lockstep``  zenoh link, the specimen advances exactly one step per command (deterministic, CI);
``realtime``  wall-clock pacer; the specimen steps once per command and answers at once; the loop
              waits for the answer until the step's deadline (synchronous real time, as a
              lab's controller board runs).  A missed deadline uses the last sample, is counted
              and logged (``lag`` > 0); more than ``max_lag`` steps without a fresh measurement
              stop the run (the measurement watchdog).

Compiled path.  On the ``fast`` clock, when every component offers a compiled step
(:mod:`rths.core.compiled`), the loop runs blocks of steps inside one numba kernel
(:mod:`rths.runtime.fastpath`, :mod:`rths.runtime.fused_kernel`) that writes the same rows bit for
bit; any step that would stop the run is rolled back and taken by the Python path below, so stops
and messages are the same.  A stop request is then honoured between blocks (at most 256 steps
later).  ``Loop.compiled = False`` keeps the Python path throughout.

Scale factors are explicit (:class:`Scaling`): the specimen sees ``displacement_scale`` times the
prototype interface displacement, and the prototype receives ``force_scale`` times the specimen
force; so a specimen inertance ``m`` acts on the prototype as ``force_scale*displacement_scale*m``.

A safety interlock stops the run (as a lab's would) when the command leaves the actuator stroke,
any signal stops being finite or the measurement is older than ``max_lag`` steps; the run's
record then ends with the reason.  After every stop -- the end of the run included -- the link is
asked for a controlled ramp-down (``safe_stop``): the specimen side drives the actuator back to
zero at its ramp velocity (:class:`rths.runtime.guard.CommandGuard`), never with a jump.

Logging.  The loop's channels (:data:`LOOP_CHANNELS`), the compensator's (``ctrl_*``) and the
substructure's (``sub_*``) are declared once; each step writes floats into a row of a
preallocated :class:`rths.core.channels.RowBlock`, and full blocks go to the sink.  Nothing is
encoded on the loop thread.

Force correction.  Feeding the measured force of a stiff or heavy specimen straight back into a
flexible structure is unstable: with any lag (one loop step, the actuator's residual delay ``tau``)
a delayed stiffness ``k`` acts as a negative damper ``k tau``, a delayed inertance turns into
negative damping above ``omega tau = pi``, and a string's driving-point impedance is only ``2 sqrt(T
m)``. For the seed cable and the S0 Type II IMD (internal stiffness 6.4e7 N/m at prototype scale)
the tolerable residual delay is far below a millisecond.  So, as in the operator-splitting method of
pseudo-dynamic testing, the substructure carries a *nominal model of the device* implicitly at the
interface (:attr:`plants.base.Substructure.device_force`), and the loop feeds back only the
correction ``force_scale * F - device_force``, optionally low-pass filtered (``force_filter``).  In
band the correction is small and the structure feels the measured force; out of band, where the
actuator cannot follow, the nominal device takes over and keeps the loop stable.  With no device the
correction is the whole measured force (plain RTHS).
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

from controllers.base import Compensator
from plants.base import Substructure
from rths.core.channels import Channel, RowBlock, prefixed
from rths.core.errors import (
    NumericalError,
    ParameterError,
    RTHSError,
    check_positive_int,
)
from rths.core.scaling import Scaling
from rths.runtime.clocks import FreeRunning, Pacer, TimingStats
from rths.runtime.fastpath import FusedPlan
from rths.runtime.links import InProcessLink, LinkSample, SpecimenLink

__all__ = [
    "LOOP_CHANNELS",
    "InProcessLink",
    "InterlockTripped",
    "LinkSample",
    "Loop",
    "LoopResult",
    "SpecimenLink",
]

#: The loop's own channels on ``rths/loop`` (each row also carries the integer ``seq`` = k).
LOOP_CHANNELS: tuple[Channel, ...] = (
    Channel("t", "s", "simulated time at the end of the step, t_(k+1) = (k+1) dt"),
    Channel("target", "m", "target displacement of the specimen end from the substructure"),
    Channel("target_velocity", "m/s", "target velocity of the specimen end"),
    Channel("target_acceleration", "m/s^2", "target acceleration of the specimen end"),
    Channel("command", "m", "actuator command held over the step, after compensation"),
    Channel("measured", "m", "measured displacement of the specimen end"),
    Channel("force", "N", "measured restoring force of the specimen"),
    Channel("correction", "N", "force correction fed to the substructure, prototype scale"),
    Channel("age", "s", "wall-clock age of the measurement when used (0 off the wall clock)"),
    Channel("lag", "1", "steps the measurement used lags behind the step (0: fresh; >0: missed)"),
    Channel("late", "s", "lateness of the step's start behind the wall-clock schedule"),
)

#: Rows per block handed to the sink.
BLOCK_ROWS = 256


class InterlockTripped(RTHSError, RuntimeError):
    """The loop stopped a run because a signal left its safe range."""


@dataclass(frozen=True)
class LoopResult:
    """Outcome of :meth:`Loop.run`: steps completed, timing figures, why it stopped early
    (``None`` when it ran to the end), and the deadline misses (measurements not there by the
    step's deadline; the longest lag in ``longest_lag`` steps) and when the loop ended on the
    pacer's clock (``ended_ns``).

    Attributes
    ----------
    steps : int
        Steps completed.
    timing : rths.runtime.clocks.TimingStats
        Lateness and work-time figures of the pacer.
    stopped : str or None
        Why the loop stopped early (a stop request, an interlock, the watchdog); None (default)
        when it ran to the end.
    misses : int
        Deadline misses: steps whose measurement was not there by the deadline (default 0).
    longest_lag : int
        Longest lag of the measurement behind the command [steps] (default 0).
    ended_ns : int
        The pacer's clock when the last step ended [ns] (default 0).
    link_mean : float
        Mean time per step in ``link.exchange`` (the round trip) [s] (default 0).
    cpu_mean : float
        Mean CPU time of the loop thread per step [s] (load-independent; default 0).
    """

    steps: int
    timing: TimingStats
    stopped: str | None = None
    misses: int = 0
    longest_lag: int = 0
    ended_ns: int = 0  #: the pacer's clock when the last step ended [ns] (fault timing)
    link_mean: float = 0.0  #: mean time per step in ``link.exchange`` [s] (the round trip)
    cpu_mean: float = 0.0  #: mean CPU time of the loop thread per step [s] (load-independent)

    @property
    def work_mean(self) -> float:
        """Mean work per step [s] outside the link (busy time less the round trip)."""
        return max(self.timing.busy_mean - self.link_mean, 0.0)


Sink = Callable[[RowBlock], None]


class Loop:
    """Fixed-step RTHS coordinator (see the module docstring for the step).

    Parameters
    ----------
    substructure
        Numerical substructure (prototype scale); owns its external load.
    compensator
        Turns target + measurement into the actuator command (specimen scale).
    link
        Reaches the specimen.
    scaling
        Prototype↔specimen scale factors.
    n_steps
        Number of steps to run.
    pacer
        Real-time pacing and timing accounting (default: free running).
    sink
        Receives each full :class:`RowBlock` of rows (and the last, partial one); must not block
        (enqueue).  The block is the sink's from then on.
    command_limit
        Interlock: stop when ``|command|`` exceeds this [m] (the actuator stroke).
    force_filter
        Optional per-sample filter applied to the force correction before it enters the
        substructure (a low-pass that keeps sensor noise and the out-of-band correction out of
        the numerical model; see the module docstring).
    max_lag
        Measurement watchdog: stop when the newest measurement lags the step by more than this
        many steps (consecutive deadline misses); before the first fresh measurement, 0.1 s is
        allowed for the specimen to start.
    block_rows
        Rows per block.
    """

    def __init__(
        self,
        substructure: Substructure,
        compensator: Compensator,
        link: SpecimenLink,
        scaling: Scaling,
        n_steps: int,
        pacer: Pacer | None = None,
        sink: Sink | None = None,
        command_limit: float = math.inf,
        force_filter: Callable[[float], float] | None = None,
        max_lag: int = 5,
        block_rows: int = BLOCK_ROWS,
    ) -> None:
        if not math.isclose(substructure.dt, compensator.dt, rel_tol=1e-12):
            raise RTHSError(
                f"substructure and compensator time steps differ: {substructure.dt} s vs "
                f"{compensator.dt} s"
            )
        self.substructure = substructure
        self.compensator = compensator
        self.link = link
        self.scaling = scaling
        self.n_steps = check_positive_int(n_steps, "number of steps")
        self.dt = substructure.dt
        self.pacer = pacer or FreeRunning(self.dt, self.n_steps)
        self.sink: Sink = sink or (lambda block: None)
        if not (isinstance(command_limit, int | float) and command_limit > 0):
            raise ParameterError(
                f"command limit must be positive (inf: none); got {command_limit!r}"
            )
        self.command_limit = float(command_limit)
        self.force_filter = force_filter
        self.max_lag = check_positive_int(max_lag, "max_lag (watchdog steps)")
        self.block_rows = check_positive_int(block_rows, "block_rows")
        comp_channels = prefixed("ctrl_", compensator.channels())
        sub_channels = prefixed("sub_", substructure.channels())
        self.channels: tuple[Channel, ...] = LOOP_CHANNELS + comp_channels + sub_channels
        n0 = len(LOOP_CHANNELS)
        self._comp_cols = (n0, n0 + len(comp_channels))
        self._sub_cols = (self._comp_cols[1], len(self.channels))
        RowBlock(self.channels, 1)  # names unique
        self.safe_stop_steps = 0  #: steps the ramp-down after the run took (in-process links)
        #: Run blocks of steps compiled when every part offers it (:mod:`rths.runtime.fastpath`);
        #: False keeps the Python path (the reference the compiled one is tested against).
        self.compiled = True
        self.compiled_steps = 0  #: steps the last run took on the compiled path
        self._stop = threading.Event()
        self._stop_reason = "stopped by request"

    def stop(self, reason: str = "stopped by request") -> None:
        """Ask the loop to stop after the current step (thread-safe); ``reason`` is reported."""
        self._stop_reason = reason
        self._stop.set()

    def run(self, progress: Callable[[int], None] | None = None) -> LoopResult:
        """Run the steps; ``progress(k)`` is called every 256 steps from the loop thread."""
        pacer, link = self.pacer, self.link
        block = RowBlock(self.channels, self.block_rows)
        tally = _Tally()
        cpu_start = time.thread_time_ns()
        pacer.start()
        k, i, carried, stopped = 0, 0, (0.0, 0.0, 0.0), None
        plan = FusedPlan.of(self) if self.compiled else None
        if plan is not None:
            k, block, i, carried, stopped = plan.run(self, block, progress, pacer.account)
        self.compiled_steps = k
        if stopped is None and k < self.n_steps:
            k, block, i, stopped = self._run_python(k, block, i, carried, tally, progress)
        ended = pacer.now_ns()
        cpu = time.thread_time_ns() - cpu_start
        if i:
            block.count = i
            self.sink(block)
        if progress is not None:
            progress(k)
        safe_stop = getattr(link, "safe_stop", None)
        if safe_stop is not None:
            self.safe_stop_steps = safe_stop(stopped or "run complete") or 0
        return LoopResult(
            steps=k,
            timing=pacer.stats(),
            stopped=stopped,
            misses=tally.misses,
            longest_lag=tally.longest,
            ended_ns=ended,
            link_mean=tally.in_link * 1e-9 / max(k, 1),
            cpu_mean=cpu * 1e-9 / max(k, 1),
        )

    def _run_python(
        self,
        k0: int,
        block: RowBlock,
        i: int,
        carried: tuple[float, float, float],
        tally: _Tally,
        progress: Callable[[int], None] | None,
    ) -> tuple[int, RowBlock, int, str | None]:
        """The steps from ``k0`` on, one Python call per component (the reference path).

        Parameters
        ----------
        k0
            First step.
        block, i
            The row block being filled and its next row (the loop's own columns of the rows
            before ``i`` are already in it).
        carried
            The measurement [m], force [N] and correction [N] step ``k0`` uses.
        tally
            Deadline misses and time in the link (updated).
        progress
            As for :meth:`run`.

        Returns
        -------
        tuple
            The next step, the row block being filled, its next row and the stop reason.
        """
        sub, comp, link, pacer = self.substructure, self.compensator, self.link, self.pacer
        lam_u, lam_f = self.scaling.displacement, self.scaling.force
        channels, rows = self.channels, self.block_rows
        c0, c1 = self._comp_cols
        s0, s1 = self._sub_cols
        n0 = len(LOOP_CHANNELS)
        record_comp, record_sub = comp.write_channels, sub.write_channels
        dt_s = self.dt
        values, seqs, times = block.values, block.seq, block.t_ns
        # the loop's own columns go into the row as one tuple per step (0.4 µs): converting a
        # block's 256 tuples at once cost 67 µs median (8 ms once) inside the block's last step
        measured, force, fed = carried
        misses, run_of_misses, longest = tally.misses, 0, tally.longest
        # until the first fresh measurement (start-up of the specimen's thread), allow 0.1 s
        fresh, start_lag = k0 > 0, max(self.max_lag, round(0.1 / dt_s))
        now, in_link = pacer.now_ns, 0
        stopped: str | None = None
        k = k0
        for k in range(k0, self.n_steps):
            if self._stop.is_set():
                stopped = self._stop_reason
                break
            pacer.wait(k)
            try:
                target = sub.step(fed).scaled(lam_u)
                command = comp.step(target, measured)
            except NumericalError as exc:  # a diverged model stops the run like the interlock
                stopped = f"interlock: {exc}"
                break
            if not abs(command) <= self.command_limit:  # also catches NaN
                stopped = (
                    f"interlock: command {command:.6g} m outside the stroke "
                    f"±{self.command_limit:g} m at t = {(k + 1) * dt_s:.4f} s"
                )
                break
            t_ns = round((k + 1) * dt_s * 1e9)  # exact to 1 ns, no accumulated rounding
            sent = now()
            sample = link.exchange(k, t_ns, command)
            in_link += now() - sent
            lag = k - sample.specimen_seq
            if lag:
                misses += 1
                run_of_misses += 1
                if lag > longest:
                    longest = lag
                if lag > (self.max_lag if fresh else start_lag):
                    stopped = (
                        f"watchdog: no fresh measurement for {lag} steps "
                        f"({lag * dt_s * 1e3:.2f} ms > {self.max_lag} steps) at "
                        f"t = {t_ns * 1e-9:.4f} s; holding and ramping down"
                    )
                    break
            else:
                run_of_misses = 0
                fresh = True
            measured, force = sample.displacement, sample.force
            if not (math.isfinite(measured) and math.isfinite(force)):
                stopped = f"interlock: non-finite measurement at t = {t_ns * 1e-9:.4f} s"
                break
            fed = lam_f * force - sub.device_force
            if self.force_filter is not None:
                fed = self.force_filter(fed)
            row = values[i]
            row[:n0] = (
                t_ns * 1e-9,
                target.displacement,
                target.velocity,
                target.acceleration,
                command,
                measured,
                force,
                fed,
                sample.age_ns * 1e-9,
                lag,
                pacer.lateness_ns(k) * 1e-9,
            )
            if c1 > c0:
                record_comp(row[c0:c1])
            if s1 > s0:
                record_sub(row[s0:s1])
            seqs[i] = k
            times[i] = t_ns
            i += 1
            if i == rows:
                block.count = i
                self.sink(block)
                block = RowBlock(channels, rows)
                values, seqs, times = block.values, block.seq, block.t_ns
                i = 0
            pacer.done(k)
            if progress is not None and k % 256 == 255:
                progress(k + 1)
        else:
            k = self.n_steps
        tally.misses, tally.longest, tally.in_link = misses, longest, in_link
        return k, block, i, stopped


@dataclass
class _Tally:
    """What the Python path counts across a run: deadline misses, the longest lag [steps] and
    the time spent in the link [ns]."""

    misses: int = 0
    longest: int = 0
    in_link: int = 0
