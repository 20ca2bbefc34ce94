"""The interface of every servo-hydraulic transfer system: :class:`Actuator` owns its specimen,
the pure delay and the rate limiter of the command path, and checks and counts each step (the
time alignment and sign conventions are :mod:`plants.base`'s).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from plants.base import Specimen, check_finite_input, check_finite_output
from plants.lines import DelayLine, RateLimiter
from rths.core.channels import Channel
from rths.core.errors import ParameterError, check_nonnegative, check_positive
from rths.core.kinematics import Kinematics

__all__ = ["Actuator"]


class Actuator(ABC):
    """A servo-hydraulic transfer system: command [m] in, motion of the specimen end out.

    The actuator owns the coupling to its specimen (control-structure interaction, CSI): the
    specimen's force acts back on the actuator's moving mass and hydraulics.

    The base class owns the shared work: the specimen, the pure delay on the command path
    (:class:`plants.lines.DelayLine`) and the rate (flow) limiter
    (:class:`plants.lines.RateLimiter`, which the subclass applies where its dynamics
    put it); :meth:`step` checks the command, delays it, calls ``_step_impl``, checks the result
    and counts the step; :meth:`reset` resets the lines, the specimen and the count and calls
    ``_reset_impl``; :meth:`state` reports the delayed command, the limiter and the specimen.

    Parameters
    ----------
    specimen : Specimen
        The device the actuator drives; it is reset with the actuator.
    dt : float
        Fixed step [s], > 0, at which :meth:`step` is called (the loop period).
    delay : float, default 0.0
        Pure transport delay [s], >= 0, on the command path (:class:`plants.lines.DelayLine`;
        a delay that is not a whole number of steps is interpolated linearly).  0 means none.
    velocity_limit : float or None, default None
        Largest actuator velocity [m/s] (the servo-valve flow limit), applied by
        :class:`plants.lines.RateLimiter` as a largest displacement change of
        ``velocity_limit * limiter_step`` per limiter step.  None means no limit.
    limiter_step : float or None, default None
        Step [s] at which the subclass applies the rate limiter (e.g. its internal sub-step);
        None means ``dt``.

    Subclass contract
    -----------------
    * Call ``super().__init__(specimen, dt, delay=..., velocity_limit=..., limiter_step=...)``;
      ``dt`` [s] is fixed; internal sub-steps are the subclass's business (``limiter_step`` is
      the step the limiter is applied at, default ``dt``).
    * ``_step_impl(u)`` holds the *delayed* command ``u`` [m] over one step, applies
      :attr:`limiter` (when not None) to the displacement it produces, drives :attr:`specimen`
      and returns the kinematics of the specimen end and the specimen restoring force [N] at the
      end of the step.  These are the *true* values; converters, quantisation and noise live in
      the lab (``plants.lab``).
    * ``transfer_function()`` returns the linear command→displacement model (python-control
      ``TransferFunction``, continuous time) including the specimen's rigid part, for compensator
      design and for the diagnosis's nominal model; the :attr:`delay` is separate.
    * ``_reset_impl()`` returns the actuator's own state to rest; ``_state_impl()`` may add
      named variables to :meth:`state`.
    """

    #: Registry name used in scenario files (set by the registry decorator).
    kind: ClassVar[str] = ""

    def __init__(
        self,
        specimen: Specimen,
        dt: float,
        *,
        delay: float = 0.0,
        velocity_limit: float | None = None,
        limiter_step: float | None = None,
    ) -> None:
        self.dt: float = check_positive(dt, "time step dt")
        if not isinstance(specimen, Specimen):
            raise ParameterError(f"specimen must be a plants.base.Specimen; got {specimen!r}")
        self.specimen: Specimen = specimen
        self.delay: float = check_nonnegative(delay, "delay")
        self.velocity_limit: float | None = velocity_limit
        self._delay_line = DelayLine(self.delay, self.dt) if self.delay > 0.0 else None
        step = self.dt if limiter_step is None else limiter_step
        self.limiter: RateLimiter | None = (
            None if velocity_limit is None else RateLimiter(velocity_limit, step)
        )
        self._command = 0.0
        self._steps = 0

    @property
    def steps(self) -> int:
        """Steps taken since construction or the last :meth:`reset`."""
        return self._steps

    def reset(self) -> None:
        """Return to rest: the actuator, its delay line and rate limiter, and the specimen."""
        self._steps = 0
        self._command = 0.0
        if self._delay_line is not None:
            self._delay_line.reset()
        if self.limiter is not None:
            self.limiter.reset()
        self.specimen.reset()
        self._reset_impl()

    @abstractmethod
    def _reset_impl(self) -> None:
        """Return the actuator's own state to rest."""

    def step(self, command: float) -> tuple[Kinematics, float]:
        """Hold ``command`` [m] for one step; return (specimen-end kinematics, force [N]).

        Raises
        ------
        ParameterError
            If the command is not finite.
        NumericalError
            If the result is not finite.
        """
        u = check_finite_input(command, "actuator command")
        if self._delay_line is not None:
            u = self._delay_line.step(u)
        self._command = u
        kinematics, force = self._step_impl(u)
        self._steps += 1
        check_finite_output(kinematics, force, self, self._steps * self.dt)
        return kinematics, force

    @abstractmethod
    def _step_impl(self, command: float) -> tuple[Kinematics, float]:
        """Advance one step with the delayed command (see the class docstring)."""

    @abstractmethod
    def transfer_function(self):  # -> control.TransferFunction (import kept out of hot modules)
        """Linear continuous-time command→displacement model (python-control)."""

    def state(self) -> dict[str, float]:
        """Named variables for logging (SI): ``command_delayed`` [m], ``rate_limiting``
        (+1/-1/0), the subclass's own, and the specimen's as ``specimen.<name>``."""
        own = {
            "command_delayed": self._command,
            "rate_limiting": 0.0 if self.limiter is None else float(self.limiter.limiting),
        }
        own |= self._state_impl()
        return own | {f"specimen.{k}": v for k, v in self.specimen.state().items()}

    def _state_impl(self) -> dict[str, float]:
        """The subclass's named variables for :meth:`state`; none by default."""
        return {}

    def channels(self) -> tuple[Channel, ...]:
        """The logged channels of :meth:`state`, in order: ``command_delayed`` [m],
        ``rate_limiting`` [1], the subclass's (:meth:`_channels_impl`), the specimen's as
        ``specimen.<name>``."""
        own = (
            Channel("command_delayed", "m", "command after the actuator's pure delay"),
            Channel("rate_limiting", "1", "+1/-1 while the flow limit is active, else 0"),
        )
        spec = tuple(
            Channel("specimen." + c.name, c.unit, c.description) for c in self.specimen.channels()
        )
        return own + self._channels_impl() + spec

    def _channels_impl(self) -> tuple[Channel, ...]:
        """Declared channels of :meth:`_state_impl` (default: its keys, no unit declared)."""
        return tuple(Channel(name, "?", "actuator state") for name in self._state_impl())

    def write_channels(self, out: NDArray[np.float64]) -> None:
        """Write the values of :meth:`channels` into ``out`` (no dict: the base's two, the
        subclass's through :meth:`_write_own`, then the specimen's)."""
        n = getattr(self, "_own_count", None)
        if n is None:
            n = self._own_count = 2 + len(self._channels_impl())
        out[0] = self._command
        out[1] = 0.0 if self.limiter is None else float(self.limiter.limiting)
        if n > 2:
            self._write_own(out[2:n])
        if out.size > n:
            self.specimen.write_channels(out[n:])

    def _write_own(self, out: NDArray[np.float64]) -> None:
        """Write :meth:`_state_impl`'s values into ``out`` (override to avoid the dict)."""
        out[:] = tuple(self._state_impl().values())
