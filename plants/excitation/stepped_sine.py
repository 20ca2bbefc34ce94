"""Stepped-sine excitation of a shaking table (private; used by
:mod:`rths.experiments.s1_shake_table.sweep`).

S1 §2.3: a sine sweep over [1 Hz, 10 Hz] "with stepped frequency changes at 0.05 Hz near system
resonant frequencies and at 0.1 Hz away from resonant frequencies", up and down, "20 full cycles
of excitation" per step.  Here the signal is defined in continuous time: step ``k`` plays
frequency ``f_k`` [Hz] for exactly ``cycles / f_k`` seconds starting at ``t_k``, with phase zero
at the start of each step, so each step ends where the next begins with zero displacement and
acceleration (the velocity changes by the ratio of the amplitudes).  Sampling at any rate does not
alter the frequencies.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rths.core.errors import ParameterError, check_positive, check_positive_int

__all__ = [
    "STANDARD_GRAVITY",
    "SteppedSine",
    "SteppedSineOptions",
    "frequency_grid",
    "stepped_sine_acceleration",
]

#: Standard gravity [m/s²], the unit of a PGA given in g.
STANDARD_GRAVITY: Final[float] = 9.80665

_DIGITS = 9  # grid frequencies are rounded to 1 nHz so that lattice points compare equal


def _lattice(lo: float, hi: float, step: float) -> NDArray[np.float64]:
    """Multiples of ``step`` inside ``[lo, hi]`` (with a tolerance of 1e-9 step)."""
    first = math.ceil(lo / step - 1e-9)
    last = math.floor(hi / step + 1e-9)
    return np.round(np.arange(first, last + 1) * step, _DIGITS)


def frequency_grid(
    f_start: float,
    f_stop: float,
    coarse_step: float,
    fine_step: float,
    centres: Sequence[float] = (),
    band: tuple[float, float] = (0.75, 1.15),
) -> NDArray[np.float64]:
    """Ascending step frequencies [Hz]: coarse everywhere, fine "near resonance".

    The grid is the union of the multiples of ``coarse_step`` in ``[f_start, f_stop]`` (plus the
    end points) and the multiples of ``fine_step`` in ``[band[0] f_c, band[1] f_c]`` for each
    centre ``f_c`` (clipped to ``[f_start, f_stop]``).  The centres are the small-amplitude
    (``k1``) natural frequencies of the models swept
    (:func:`plants.tmdi.structure.linearised_frequencies`); the band reaches further below them than
    above because the HDRBs soften (S1 §3.1: ``f1`` falls by 32 % from 0.05 g to 0.15 g).

    Parameters
    ----------
    f_start, f_stop
        Sweep range [Hz], ``0 < f_start < f_stop``.
    coarse_step, fine_step
        Frequency steps [Hz] away from and near resonance (S1: 0.1 and 0.05).
    centres
        Resonance frequencies [Hz] around which the fine step applies.
    band
        ``(lo, hi)`` factors, ``0 < lo <= 1 <= hi``, defining "near" a centre.
    """
    f_start = check_positive(f_start, "f_start")
    f_stop = check_positive(f_stop, "f_stop")
    if f_stop <= f_start:
        raise ParameterError(f"f_stop must exceed f_start = {f_start!r} Hz; got {f_stop!r}")
    coarse_step = check_positive(coarse_step, "coarse_step")
    fine_step = check_positive(fine_step, "fine_step")
    lo, hi = (float(x) for x in band)
    if not (0.0 < lo <= 1.0 <= hi and math.isfinite(hi)):
        raise ParameterError(f"fine band must satisfy 0 < lo <= 1 <= hi; got {band!r}")
    parts = [_lattice(f_start, f_stop, coarse_step), np.array([f_start, f_stop])]
    for centre in centres:
        c = check_positive(centre, "resonance centre")
        parts.append(_lattice(max(lo * c, f_start), min(hi * c, f_stop), fine_step))
    return np.unique(np.round(np.concatenate(parts), _DIGITS))


@dataclass(frozen=True)
class SteppedSine:
    """A stepped sine: ``frequencies`` [Hz] in playing order, ``cycles`` whole cycles each.

    Attributes
    ----------
    frequencies
        Step frequencies [Hz], shape ``(n,)``, all positive, in the order they are played.
    cycles
        Whole cycles per step (S1: 20).
    """

    frequencies: NDArray[np.float64]
    cycles: int = 20

    def __post_init__(self) -> None:
        f = np.array(self.frequencies, dtype=float)
        if f.ndim != 1 or f.size == 0 or not np.all(np.isfinite(f)) or np.any(f <= 0.0):
            raise ParameterError(
                f"step frequencies must be a non-empty 1-D array of positive numbers; got {f!r}"
            )
        check_positive_int(self.cycles, "cycles per step")
        f.setflags(write=False)
        object.__setattr__(self, "frequencies", f)

    @classmethod
    def sweep(cls, grid: ArrayLike, direction: str, cycles: int = 20) -> SteppedSine:
        """A sweep over a frequency grid.

        Parameters
        ----------
        grid
            Step frequencies [Hz], any order.
        direction
            ``"up"`` (ascending) or ``"down"`` (descending).
        cycles
            Whole cycles per step.
        """
        f = np.sort(np.asarray(grid, dtype=float))
        if direction == "up":
            return cls(f, cycles)
        if direction == "down":
            return cls(f[::-1].copy(), cycles)
        raise ParameterError(f"sweep direction must be 'up' or 'down'; got {direction!r}")

    @property
    def boundaries(self) -> NDArray[np.float64]:
        """Start times [s] of the steps and the end time, shape ``(n + 1,)``."""
        return np.concatenate([[0.0], np.cumsum(self.cycles / self.frequencies)])

    @property
    def duration(self) -> float:
        """Total duration [s]."""
        return float(np.sum(self.cycles / self.frequencies))

    def sample_times(self, dt: float) -> NDArray[np.float64]:
        """Sample times ``t_n = n dt`` [s] from 0 to the first sample at or after the end.

        Parameters
        ----------
        dt
            Sampling step [s], > 0.
        """
        dt = check_positive(dt, "time step dt")
        return np.arange(math.ceil(self.duration / dt - 1e-9) + 1, dtype=np.float64) * dt

    def signal(self, t: ArrayLike, amplitudes: ArrayLike) -> NDArray[np.float64]:
        """``a_k sin(2π f_k (t - t_k))`` during step ``k`` and 0 outside the sweep.

        Parameters
        ----------
        t
            Times [s], any shape.
        amplitudes
            One amplitude per step (any unit), shape ``(n,)``, or a scalar for all.
        """
        t = np.asarray(t, dtype=float)
        amp = np.broadcast_to(np.asarray(amplitudes, dtype=float), self.frequencies.shape)
        bounds = self.boundaries
        k = np.searchsorted(bounds, t, side="right") - 1
        inside = (k >= 0) & (k < self.frequencies.size)
        kk = np.clip(k, 0, self.frequencies.size - 1)
        phase = 2.0 * np.pi * self.frequencies[kk] * (t - bounds[kk])
        return np.where(inside, amp[kk] * np.sin(phase), 0.0)

    def function(self, amplitudes: ArrayLike) -> Callable[[float], float]:
        """:meth:`signal` as a scalar function of time [s] (e.g. a substructure's ``ü_G(t)``).

        Parameters
        ----------
        amplitudes
            One amplitude per step, or a scalar for all.
        """
        amp = np.broadcast_to(np.asarray(amplitudes, dtype=float), self.frequencies.shape)
        bounds = self.boundaries.tolist()
        freqs = self.frequencies.tolist()
        values = amp.tolist()
        n = len(freqs)

        def value(t: float) -> float:
            k = bisect.bisect_right(bounds, t) - 1
            if k < 0 or k >= n:
                return 0.0
            return values[k] * math.sin(2.0 * math.pi * freqs[k] * (t - bounds[k]))

        return value


def stepped_sine_acceleration(
    frequencies: ArrayLike, pga: float, cycles: int = 20, direction: str | None = None
) -> Callable[[float], float]:
    """Ground acceleration ``ü_G(t)`` [m/s²] of a stepped sine at ``pga`` [g] (perfect table).

    ``PGA g sin(2π f_k (t - t_k))`` during step ``k`` and 0 after the sweep: the excitation a
    :class:`plants.tmdi.structure.TMDISubstructure` owns in an RTHS of the S1 shake-table test.

    Parameters
    ----------
    frequencies
        Step frequencies [Hz] in playing order, or the grid when ``direction`` is given.
    pga
        Peak acceleration [g], > 0.
    cycles
        Whole cycles per step.
    direction
        ``"up"`` or ``"down"`` to sort ``frequencies``; None plays them as given.
    """
    amplitude = check_positive(pga, "PGA") * STANDARD_GRAVITY
    if direction is None:
        sine = SteppedSine(np.asarray(frequencies, dtype=float), cycles)
    else:
        sine = SteppedSine.sweep(frequencies, direction, cycles)
    return sine.function(amplitude)


@dataclass(frozen=True)
class SteppedSineOptions:
    """A stepped sine of the shaking table (the ``excitation`` table of a scenario).

    Parameters
    ----------
    pga
        Peak ground acceleration [g], > 0.
    frequencies
        Step frequencies [Hz], > 0, in playing order.
    cycles
        Whole cycles per step, >= 1 (S1 §2.3: 20).
    """

    pga: float
    frequencies: tuple[float, ...]
    cycles: int = 20

    def __post_init__(self) -> None:
        check_positive(self.pga, "PGA")
        if any(not f > 0 for f in self.frequencies):
            raise ParameterError(
                f"step frequencies must be positive; got {list(self.frequencies)!r}"
            )
        check_positive_int(self.cycles, "cycles per step")

    def acceleration(self) -> Callable[[float], float]:
        """Ground acceleration ``ü_G(t)`` [m/s²] (:func:`stepped_sine_acceleration`)."""
        return stepped_sine_acceleration(self.frequencies, self.pga, self.cycles)
