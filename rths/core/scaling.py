"""Prototype↔specimen scale factors of a run (explicit, and logged with every run)."""

from __future__ import annotations

from dataclasses import dataclass

from rths.core.errors import check_positive

__all__ = ["Scaling"]


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
        check_positive(self.displacement, "displacement scale factor")
        check_positive(self.force, "force scale factor")

    @property
    def impedance(self) -> float:
        """Factor by which a specimen impedance (inertance, damping, stiffness) acts on the
        prototype: ``force * displacement``."""
        return self.force * self.displacement
