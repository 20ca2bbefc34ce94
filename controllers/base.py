"""The interface every compensator implements.

A compensator turns the target displacement of the specimen end (specimen scale, with the
derivatives the numerical substructure provides) and the latest measured displacement into the
actuator command.  Time alignment (see :mod:`plants.base`): at loop step ``k`` the compensator
receives the target ``r_{k+1}`` for the end of the step and the measurement ``y_k`` from its start,
and returns the command ``u_k`` that the actuator holds over ``[t_k, t_{k+1}]``; the aim is
``y_{k+1} = r_{k+1}``.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from rths.core.channels import Channel
from rths.core.errors import NumericalError, ParameterError, check_positive
from rths.core.kinematics import Kinematics

__all__ = ["Compensator"]


class Compensator(ABC):
    """Base class of compensators (template: ``step`` checks and counts, ``_step_impl`` computes).

    The base class owns the shared work: :meth:`step` checks that the target and the measurement
    are finite, calls ``_step_impl``, checks the command is finite and counts the step;
    :meth:`reset` zeroes the count and calls ``_reset_impl``.

    Subclass contract
    -----------------
    * Call ``super().__init__(dt)``; ``dt`` [s] is fixed at construction.
    * ``_step_impl(target, measured)`` returns the command [m] for the coming step.
    * ``state()`` returns named internal variables for logging (e.g. the feedforward and feedback
      parts of the command, estimated delay); may be empty.
    * ``_reset_impl()`` returns to the initial state.

    Parameters
    ----------
    dt : float
        Loop step [s], > 0, fixed at construction.
    """

    #: Registry name used in scenario files and on the CLI, e.g. ``"ff_lqg"`` (set by the
    #: registry decorator).
    kind: ClassVar[str] = ""

    def __init__(self, dt: float) -> None:
        self.dt: float = check_positive(dt, "time step dt")
        self._steps = 0

    @property
    def steps(self) -> int:
        """Steps taken since construction or the last :meth:`reset`."""
        return self._steps

    def reset(self) -> None:
        """Return to the initial state."""
        self._steps = 0
        self._reset_impl()

    @abstractmethod
    def _reset_impl(self) -> None:
        """Return the compensator's own state to the initial state."""

    def step(self, target: Kinematics, measured: float) -> float:
        """Command [m] for the next step from the target at its end and the latest measurement.

        Raises
        ------
        ParameterError
            If the target or the measurement is not finite.
        NumericalError
            If the command is not finite.
        """
        y = float(measured)
        if not math.isfinite(y + target.displacement + target.velocity + target.acceleration):
            raise ParameterError(
                f"target and measured displacement must be finite; got {target!r} and {measured!r}"
            )
        command = self._step_impl(target, y)
        self._steps += 1
        if not math.isfinite(command):
            raise NumericalError(
                f"{type(self).__name__} produced a non-finite command {command!r} at step "
                f"{self._steps}"
            )
        return command

    @abstractmethod
    def _step_impl(self, target: Kinematics, measured: float) -> float:
        """Compute the command (see the class docstring)."""

    def state(self) -> dict[str, float]:
        """Named internal variables for logging; empty unless a compensator has some."""
        return {}

    def channels(self) -> tuple[Channel, ...]:
        """The logged channels, in the order :meth:`write_channels` writes them (default: the
        keys of :meth:`state`, no unit declared)."""
        return tuple(Channel(name, "?", "compensator state") for name in self.state())

    def write_channels(self, out: NDArray[np.float64]) -> None:
        """Write this step's values of :meth:`channels` into ``out`` (a slice of the loop's
        preallocated row).  Default: from :meth:`state` (slow: a dict per step)."""
        out[:] = tuple(self.state().values())
