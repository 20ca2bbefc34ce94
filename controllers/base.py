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

from rths.core.errors import ParameterError, check_positive
from rths.core.kinematics import Kinematics

__all__ = ["Compensator"]


class Compensator(ABC):
    """Base class of compensators (template: ``step`` checks, ``_step_impl`` computes).

    Subclass contract
    -----------------
    * ``dt`` [s] is fixed at construction.
    * ``_step_impl(target, measured)`` returns the command [m] for the coming step.
    * ``state()`` returns named internal variables for logging (e.g. the feedforward and feedback
      parts of the command, estimated delay); may be empty.
    * ``reset()`` returns to the initial state.
    """

    #: Short registry name used in scenario files and on the CLI, e.g. ``"ff_lqg"``.
    kind: ClassVar[str] = ""

    def __init__(self, dt: float) -> None:
        self.dt: float = check_positive(dt, "time step dt")

    @abstractmethod
    def reset(self) -> None:
        """Return to the initial state."""

    def step(self, target: Kinematics, measured: float) -> float:
        """Command [m] for the next step from the target at its end and the latest measurement."""
        y = float(measured)
        if not math.isfinite(y):
            raise ParameterError(f"measured displacement must be finite; got {measured!r}")
        return self._step_impl(target, y)

    @abstractmethod
    def _step_impl(self, target: Kinematics, measured: float) -> float:
        """Compute the command (see the class docstring)."""

    def state(self) -> dict[str, float]:
        """Named internal variables for logging; empty unless a compensator has some."""
        return {}
