"""Parameters of the S1 Eq.12 structure without the inerter (private; re-exported by
:mod:`plants.tmdi.structure`, which documents the model)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final

from plants.tmdi.hdrb import HDRB, S1_PRIMARY
from rths.core.errors import ParameterError, check_nonnegative, check_positive

__all__ = ["PRIMARY_MASS", "SECONDARY_MASSES", "TMDIParameters"]

#: Primary mass m_I [kg], S1 §2.2.
PRIMARY_MASS: Final[float] = 125.0
#: Secondary masses m_T [kg] of S1 Table 1 (μ = m_T / m_I = 0.048, 0.080, 0.160).
SECONDARY_MASSES: Final[dict[str, float]] = {"SM": 6.0, "IM": 10.0, "LM": 20.0}


@dataclass(frozen=True, slots=True)
class TMDIParameters:
    """The structure of S1 Eq.12 without the inerter.

    Parameters
    ----------
    primary_mass
        ``m_I`` [kg].
    primary_isolator
        Primary HDRB (S1 Eq.8).
    secondary_mass
        ``m_T`` [kg]; 0 for the uncontrolled primary structure (PS).
    secondary_isolator
        Secondary HDRB; required when ``secondary_mass > 0``, ignored otherwise.
    """

    primary_mass: float = PRIMARY_MASS
    primary_isolator: HDRB = S1_PRIMARY
    secondary_mass: float = 0.0
    secondary_isolator: HDRB | None = None

    def __post_init__(self) -> None:
        check_positive(self.primary_mass, "primary mass m_I")
        check_nonnegative(self.secondary_mass, "secondary mass m_T")
        if not isinstance(self.primary_isolator, HDRB):
            raise ParameterError(
                f"primary isolator must be an HDRB; got {type(self.primary_isolator).__name__}"
            )
        if self.secondary_mass > 0.0 and not isinstance(self.secondary_isolator, HDRB):
            raise ParameterError(
                "secondary isolator must be an HDRB when the secondary mass is "
                f"{self.secondary_mass!r} kg; got {self.secondary_isolator!r}"
            )

    @property
    def has_tmd(self) -> bool:
        """True when a secondary mass (TMD/TMDI) is attached."""
        return self.secondary_mass > 0.0

    @property
    def mass_ratio(self) -> float:
        """``μ = m_T / m_I`` [-]."""
        return self.secondary_mass / self.primary_mass

    def linear(self) -> TMDIParameters:
        """The same structure with linear isolators (``k2 = k3 = 0``, constant dashpots ``c``)."""
        iso = self.secondary_isolator.linear() if self.secondary_isolator is not None else None
        return TMDIParameters(
            self.primary_mass, self.primary_isolator.linear(), self.secondary_mass, iso
        )
