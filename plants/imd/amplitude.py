"""Online estimate of the load amplitude of a drive, for the amplitude-dependent damping S0 Eq.18.

Rule: the amplitude is half the peak-to-peak excursion of the drive between its last two
reversals.  A reversal is declared when the drive has retreated from its running extremum by
more than a hysteresis: the larger of ``tolerance`` [m] and ``fraction`` times the current
amplitude estimate.  The relative part keeps wiggles that are small against the motion (a
compensator's command jitter, sensor noise in a replayed drive) from counting as load reversals
-- without it a 1 µm ripple on a 2 mm sine collapsed the estimate to 1 µm and the damping of
S0 Eq.18 jumped to its small-amplitude value.  Until two reversals have been seen the amplitude
is 0, so S0 Eq.18 gives its small-amplitude value (0.3) at the start of a test.  The estimate
is piecewise constant: it changes only at reversals, half a cycle late by construction.
"""

from __future__ import annotations

from rths.core.errors import check_nonnegative, check_positive

__all__ = ["AmplitudeTracker"]


class AmplitudeTracker:
    """Half the peak-to-peak drive displacement between the last two reversals [m].

    Parameters
    ----------
    tolerance
        Absolute hysteresis [m] a retreat from the running extremum must exceed to count as a
        reversal.
    fraction
        Relative hysteresis: a retreat must also exceed ``fraction * amplitude`` [-] (0: none).
    """

    def __init__(self, tolerance: float, fraction: float = 0.0) -> None:
        self.tolerance: float = check_positive(tolerance, "reversal tolerance")
        self.fraction: float = check_nonnegative(fraction, "reversal fraction")
        self.reset()

    def reset(self) -> None:
        """Forget all reversals (drive at rest at 0)."""
        self.amplitude: float = 0.0
        self._direction: int = 0  # +1 rising, -1 falling, 0 not yet moved
        self._extremum: float = 0.0  # running extremum in the current direction [m]
        self._last_turn: float | None = None  # displacement at the last reversal [m]

    def update(self, u: float) -> bool:
        """Take the drive displacement [m] at the next sample; return True at a new estimate."""
        tol = max(self.tolerance, self.fraction * self.amplitude)
        if self._direction == 0:
            if abs(u - self._extremum) > tol:
                self._direction = 1 if u > self._extremum else -1
                self._extremum = u
            return False
        if (u - self._extremum) * self._direction >= 0.0:
            self._extremum = u  # still moving away: a new extremum
            return False
        if abs(u - self._extremum) <= tol:
            return False
        turn = self._extremum  # the drive reversed at its running extremum
        self._direction = -self._direction
        self._extremum = u
        previous, self._last_turn = self._last_turn, turn
        if previous is None:
            return False
        self.amplitude = 0.5 * abs(turn - previous)
        return True
