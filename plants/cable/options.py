"""Options of the ``cable`` substructure kind (the ``[substructure]`` table, S0 §5.1)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

from rths.core.errors import ParameterError, check_in_range, check_positive

__all__ = ["CableLoadOptions", "CableOptions"]


@dataclass(frozen=True)
class CableLoadOptions:
    """The distributed load ``p(x, t) = amplitude sin(mode π x / L) sin(2π frequency t)``, S0
    Eq.22 (the ``[substructure.load]`` table).

    Parameters
    ----------
    amplitude
        Load amplitude [N/m] (0: no load).
    mode
        Mode shape of the load, >= 1.
    frequency
        Load frequency [Hz]; default: the undamped cable's mode-``mode`` frequency.
    duration
        Time [s] after which the load stops and the cable vibrates freely (a free-decay test:
        ``rths study`` reads the modal damping from it); default: the load lasts the whole run.
    """

    amplitude: float = 0.0
    mode: int = 1
    frequency: float | None = None
    duration: float | None = None

    def __post_init__(self) -> None:
        if self.mode < 1:
            raise ParameterError(f"mode must be >= 1; got {self.mode!r}")
        if self.frequency is not None:
            check_positive(self.frequency, "frequency")
        if self.duration is not None:
            check_positive(self.duration, "load duration")


@dataclass(frozen=True)
class CableOptions:
    """A taut stay cable with a damper near the anchorage (S0 §5.1).

    Parameters
    ----------
    length
        Cable length L [m], > 0.
    tension
        Tension T [N], > 0.
    mass_per_length
        Mass per unit length m [kg/m], > 0.
    damper_position
        Damper location x_d / L in (0, 1), e.g. 0.02 in S0.
    elements
        Number of linear elements (>= 2) or ``"auto"``: the finest of 100 and what the nominal
        device's series stiffness needs (``plants.cable.elements_for``).
    intrinsic_damping
        Rayleigh damping ratio of the cable at modes 1 and 3 (0.001 = 0.1 %), in [0, 0.99].
    load
        The distributed load (``[substructure.load]``).
    """

    length: float
    tension: float
    mass_per_length: float
    damper_position: float
    elements: int | Literal["auto"] = "auto"
    intrinsic_damping: float = 0.001
    load: CableLoadOptions = field(default_factory=CableLoadOptions)

    def __post_init__(self) -> None:
        check_positive(self.length, "length")
        check_positive(self.tension, "tension")
        check_positive(self.mass_per_length, "mass_per_length")
        check_in_range(self.damper_position, "damper_position", 1e-6, 1.0 - 1e-6)
        if self.elements != "auto" and (isinstance(self.elements, bool) or self.elements < 2):
            raise ParameterError(
                f'elements must be an integer >= 2 or "auto"; got {self.elements!r}'
            )
        check_in_range(self.intrinsic_damping, "intrinsic_damping", 0.0, 0.99)
        slope = self.load.amplitude * self.length / self.tension
        if not slope <= 1.0:
            raise ParameterError(
                f"load amplitude {self.load.amplitude!r} N/m is too large for a taut string: "
                f"amplitude x length / tension = {slope:.3g} (the scale of the cable's slope) "
                "must stay below 1"
            )

    @property
    def excitation_period(self) -> float:
        """Period [s] of the load: ``1/frequency``, or the undamped cable's mode period."""
        if self.load.frequency is not None:
            return 1.0 / self.load.frequency
        wave_speed = math.sqrt(self.tension / self.mass_per_length)
        return 2.0 * self.length / (self.load.mode * wave_speed)
