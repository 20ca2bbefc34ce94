"""The specimen side's own interlock: what the actuator may be commanded, whoever asks.

A lab's servo-controller never trusts its outer loop.  :class:`CommandGuard` sits between the
received command and the actuator and enforces, every step:

* **stroke** -- ``|u| <= stroke``; a command beyond it (or not finite) trips the guard;
* **velocity** -- the change per step is clamped to ``max_velocity * dt`` (counted); if the
  command keeps asking for more than that for ``trip_after`` [s], the guard trips;
* **ramp-down** -- once tripped (also on a stop request, or when commands stop coming) the guard
  ignores every further command and drives the actuator back to zero at ``ramp_velocity``: a
  controlled ramp, never a jump.  The trip is latched, as a lab's interlock is.

It also keeps the figures a safety review asks for: the largest command step it executed and
how many commands it clamped.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rths.core.compiled import CompiledStep
from rths.core.errors import ParameterError, check_positive

__all__ = ["CommandGuard", "GuardLimits"]


@dataclass(frozen=True, slots=True)
class GuardLimits:
    """Limits of a :class:`CommandGuard`.

    Parameters
    ----------
    stroke
        Largest ``|command|`` [m] (the actuator's stroke).
    max_velocity
        Largest command rate [m/s]; the per-step change is clamped to ``max_velocity * dt``.
    ramp_velocity
        Rate [m/s] of the ramp back to zero after a trip or a stop.
    trip_after
        Time [s] the command may keep asking for more than ``max_velocity`` before the guard
        trips.
    """

    stroke: float = math.inf
    max_velocity: float = 0.5
    ramp_velocity: float = 0.05
    trip_after: float = 0.05

    def __post_init__(self) -> None:
        for name in ("stroke", "max_velocity", "ramp_velocity", "trip_after"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and value > 0):  # inf allowed, NaN not
                raise ParameterError(f"guard {name} must be positive; got {value!r}")
        if self.ramp_velocity > self.max_velocity:
            raise ParameterError(
                f"guard ramp_velocity must not exceed max_velocity {self.max_velocity!r} m/s; "
                f"got {self.ramp_velocity!r}"
            )


class CommandGuard:
    """Applies :class:`GuardLimits` to each command before the actuator sees it.

    Parameters
    ----------
    limits
        The limits.
    dt
        Step [s] at which commands are executed.

    Attributes
    ----------
    tripped : str or None
        Why the guard tripped (latched), None while it follows commands.
    limited : int
        Commands whose change was clamped to ``max_velocity * dt``.
    ignored : int
        Commands received after the trip (not executed).
    largest_step : float
        Largest ``|u_k - u_{k-1}|`` [m] executed so far (ramp included).
    last : float
        The last command executed [m].
    """

    def __init__(self, limits: GuardLimits, dt: float) -> None:
        self.limits = limits
        self.dt = check_positive(dt, "time step dt")
        self._max_step = limits.max_velocity * self.dt
        self._ramp_step = limits.ramp_velocity * self.dt
        self._trip_steps = max(1, math.ceil(limits.trip_after / self.dt))
        self.tripped: str | None = None
        self.limited = 0
        self.ignored = 0
        self.largest_step = 0.0
        self.last = 0.0
        self._run = 0  # consecutive clamped commands

    def _execute(self, u: float) -> float:
        step = abs(u - self.last)
        if step > self.largest_step:
            self.largest_step = step
        self.last = u
        return u

    def trip(self, reason: str) -> None:
        """Latch the trip (the first reason is kept); from now on :meth:`apply` ramps down.

        Parameters
        ----------
        reason
            Why (reported in the log).
        """
        if self.tripped is None:
            self.tripped = reason

    def apply(self, command: float) -> float:
        """The command to execute this step.

        Parameters
        ----------
        command
            The command received [m].
        """
        if self.tripped is not None:
            self.ignored += 1
            return self.ramp()
        lim = self.limits
        if not abs(command) <= lim.stroke:  # also NaN
            self.trip(f"command {command:.6g} m outside the stroke ±{lim.stroke:g} m")
            return self.ramp()
        change = command - self.last
        if abs(change) > self._max_step:
            self.limited += 1
            self._run += 1
            if self._run >= self._trip_steps:
                self.trip(
                    f"command rate above {lim.max_velocity:g} m/s for {self._run} steps "
                    f"({self._run * self.dt * 1e3:.1f} ms)"
                )
                return self.ramp()
            command = self.last + math.copysign(self._max_step, change)
        else:
            self._run = 0
        return self._execute(command)

    def compiled_step(self) -> CompiledStep | None:
        """This guard for the loop's fused kernel (family ``"guard"``: constants and state of
        :data:`rths.runtime.fused_kernel.GUARD_CONSTANTS` / ``GUARD_STATE``); None once
        tripped (the ramp-down is the Python path's)."""
        if self.tripped is not None:
            return None
        c = np.array([self.limits.stroke, self._max_step, self._trip_steps, self._ramp_step])
        s = np.array([self.last, self.largest_step, self.limited, self._run, self.ignored], float)

        def commit() -> None:
            self.last, self.largest_step = float(s[0]), float(s[1])
            self.limited, self._run, self.ignored = int(s[2]), int(s[3]), int(s[4])

        return CompiledStep("guard", (c,), (s,), commit)

    def ramp(self) -> float:
        """The next command of the ramp to zero (zero once there)."""
        u = self.last
        if abs(u) <= self._ramp_step:
            return self._execute(0.0)
        return self._execute(u - math.copysign(self._ramp_step, u))

    @property
    def at_rest(self) -> bool:
        """Whether the last executed command is zero."""
        return self.last == 0.0

    def ramp_steps(self) -> int:
        """Steps the ramp from the last command to zero takes."""
        return math.ceil(abs(self.last) / self._ramp_step) if self.last else 0

    def summary(self) -> dict[str, float | int | str]:
        """Figures for the log: trip reason, clamped and ignored commands, largest step [m]."""
        return {
            "guard_tripped": self.tripped or "",
            "guard_limited": self.limited,
            "guard_ignored": self.ignored,
            "largest_command_step": self.largest_step,
        }
