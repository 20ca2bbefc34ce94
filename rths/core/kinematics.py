"""The motion of one point: the value type the substructure, the compensator and the specimen
exchange at the interface."""

from __future__ import annotations

from typing import NamedTuple

__all__ = ["Kinematics"]


class Kinematics(NamedTuple):
    """Displacement [m], velocity [m/s] and acceleration [m/s^2] of one point.

    Immutable; a named tuple rather than a frozen dataclass because three are built every loop
    step and a named tuple is built several times faster (no per-field ``object.__setattr__``).

    Attributes
    ----------
    displacement : float
        Displacement [m] (at the interface: the target or measured stroke).
    velocity : float
        Velocity [m/s].
    acceleration : float
        Acceleration [m/s^2].
    """

    displacement: float
    velocity: float
    acceleration: float

    def scaled(self, factor: float) -> Kinematics:
        """The same motion multiplied by ``factor`` (e.g. a prototype→specimen scale factor)."""
        return Kinematics(
            self.displacement * factor, self.velocity * factor, self.acceleration * factor
        )
