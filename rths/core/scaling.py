"""Prototype↔specimen scale factors of a run (explicit, and logged with every run)."""

from __future__ import annotations

from dataclasses import dataclass

from rths.core.errors import check_in_range

__all__ = ["MAX_SCALE", "Scaling"]

#: Largest scale factor (and smallest: its inverse).  Real tests scale by 1:100 at most; beyond
#: 1:10^6 the specimen's force cannot reach the prototype in floating point.
MAX_SCALE = 1e6


@dataclass(frozen=True)
class Scaling:
    """Prototype↔specimen scale factors (both logged with every run).

    Attributes
    ----------
    displacement : float
        Specimen displacement / prototype displacement [-].
    force : float
        Prototype force / specimen force [-].
    """

    displacement: float = 1.0
    force: float = 1.0

    def __post_init__(self) -> None:
        check_in_range(self.displacement, "displacement scale factor", 1 / MAX_SCALE, MAX_SCALE)
        check_in_range(self.force, "force scale factor", 1 / MAX_SCALE, MAX_SCALE)

    @property
    def impedance(self) -> float:
        """Factor by which a specimen impedance (inertance, damping, stiffness) acts on the
        prototype: ``force * displacement``."""
        return self.force * self.displacement
