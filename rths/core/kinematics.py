"""The motion of one point: the value type the substructure, the compensator and the specimen
exchange at the interface."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Kinematics"]


@dataclass(frozen=True, slots=True)
class Kinematics:
    """Displacement [m], velocity [m/s] and acceleration [m/s^2] of one point.

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
