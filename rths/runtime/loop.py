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
``realtime``  wall-clock pacer, the specimen free-runs; the link returns the newest sample and its
              age, which the loop logs with the overruns and jitter.

Scale factors are explicit (:class:`Scaling`): the specimen sees ``displacement_scale`` times the
prototype interface displacement, and the prototype receives ``force_scale`` times the specimen
force; so a specimen inertance ``m`` acts on the prototype as ``force_scale*displacement_scale*m``.

A safety interlock stops the run (as a lab's would) when the command leaves the actuator stroke or
any signal stops being finite; the run's record then ends with the reason.

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
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from controllers.base import Compensator
from plants.base import Substructure
from rths.core.errors import (
    NumericalError,
    ParameterError,
    RTHSError,
    check_positive_int,
)
from rths.core.scaling import Scaling
from rths.runtime.clocks import FreeRunning, Pacer, TimingStats

__all__ = [
    "InProcessLink",
    "InterlockTripped",
    "LinkSample",
    "Loop",
    "LoopResult",
    "SpecimenLink",
]


class InterlockTripped(RTHSError, RuntimeError):
    """The loop stopped a run because a signal left its safe range."""


@dataclass(frozen=True, slots=True)
class LinkSample:
    """What the specimen answers: measured displacement [m], force [N] (specimen scale), the age
    of the sample when the loop uses it [ns] (0 in lockstep/fast) and the specimen's step number."""

    displacement: float
    force: float
    age_ns: int = 0
    specimen_seq: int = -1


class SpecimenLink(Protocol):
    """How the loop reaches the specimen (in process, or over zenoh in lockstep or real time)."""

    def exchange(self, seq: int, t_ns: int, command: float) -> LinkSample:
        """Send command ``seq`` (to be held until ``t_ns``, simulated ns); return the measurement
        the loop should use for the end of the step."""
        ...


class _Lab(Protocol):
    def step(self, command: float) -> tuple[float, float]: ...

    def truth(self) -> dict[str, float]: ...


class InProcessLink:
    """The ``fast`` clock's link: calls an emulated lab directly in this process."""

    def __init__(self, lab: _Lab) -> None:
        self.lab = lab

    def exchange(self, seq: int, t_ns: int, command: float) -> LinkSample:
        displacement, force = self.lab.step(command)
        return LinkSample(displacement, force, 0, seq)


@dataclass(frozen=True)
class LoopResult:
    """Outcome of :meth:`Loop.run`: steps completed, timing figures and why it stopped early
    (``None`` when it ran to the end)."""

    steps: int
    timing: TimingStats
    stopped: str | None = None


Record = dict[str, float]


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
        Receives one record (a flat ``dict``) per step; must not block (publish or enqueue).
    command_limit
        Interlock: stop when ``|command|`` exceeds this [m] (the actuator stroke).
    force_filter
        Optional per-sample filter applied to the force correction before it enters the
        substructure (a low-pass that keeps sensor noise and the out-of-band correction out of
        the numerical model; see the module docstring).
    """

    def __init__(
        self,
        substructure: Substructure,
        compensator: Compensator,
        link: SpecimenLink,
        scaling: Scaling,
        n_steps: int,
        pacer: Pacer | None = None,
        sink: Callable[[Record], None] | None = None,
        command_limit: float = math.inf,
        force_filter: Callable[[float], float] | None = None,
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
        self.sink = sink or (lambda record: None)
        if not (isinstance(command_limit, int | float) and command_limit > 0):
            raise ParameterError(
                f"command limit must be positive (inf: none); got {command_limit!r}"
            )
        self.command_limit = float(command_limit)
        self.force_filter = force_filter
        self._stop = threading.Event()
        self._stop_reason = "stopped by request"

    def stop(self, reason: str = "stopped by request") -> None:
        """Ask the loop to stop after the current step (thread-safe); ``reason`` is reported."""
        self._stop_reason = reason
        self._stop.set()

    def run(self, progress: Callable[[int], None] | None = None) -> LoopResult:
        """Run the steps; ``progress(k)`` is called every 256 steps from the loop thread."""
        sub, comp, link, sink, pacer = (
            self.substructure,
            self.compensator,
            self.link,
            self.sink,
            self.pacer,
        )
        lam_u, lam_f = self.scaling.displacement, self.scaling.force
        measured, force, fed = 0.0, 0.0, 0.0
        stopped: str | None = None
        pacer.start()
        k = 0
        for k in range(self.n_steps):
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
                    f"±{self.command_limit:g} m at t = {(k + 1) * self.dt:.4f} s"
                )
                break
            t_ns = round((k + 1) * self.dt * 1e9)  # exact to 1 ns, no accumulated rounding
            sample = link.exchange(k, t_ns, command)
            measured, force = sample.displacement, sample.force
            if not (math.isfinite(measured) and math.isfinite(force)):
                stopped = f"interlock: non-finite measurement at t = {t_ns * 1e-9:.4f} s"
                break
            fed = lam_f * force - sub.device_force
            if self.force_filter is not None:
                fed = self.force_filter(fed)
            record: Record = {
                "seq": k,
                "t": t_ns * 1e-9,
                "target": target.displacement,
                "target_velocity": target.velocity,
                "target_acceleration": target.acceleration,
                "command": command,
                "measured": measured,
                "force": force,
                "correction": fed,
                "age": sample.age_ns * 1e-9,
            }
            for name, value in comp.state().items():
                record["ctrl_" + name] = value
            for name, value in sub.outputs().items():
                record["sub_" + name] = value
            sink(record)
            pacer.done(k)
            if progress is not None and k % 256 == 255:
                progress(k + 1)
        else:
            k = self.n_steps
        if progress is not None:
            progress(k)
        return LoopResult(steps=k, timing=pacer.stats(), stopped=stopped)
