"""The transducers' noise spectrum, read where the specimen is at rest.

The noise floor of every channel is built from white-noise levels estimated at the top of each
record's band (:func:`rths.diagnose.channels.signals.white_noise_rms`).  A conditioner's noise
is not always white: a low-passed share (an amplifier's or LVDT demodulator's own bandwidth,
1/f noise) raises the noise below its corner, where the specimen's gap is tested, and a
residual that is nothing but that noise was read as a significant gap (a displacement
conditioner's noise with a third of its variance below 25 Hz, propagated through a 570 kg
inertance: four times the white floor at 20-30 Hz).  Lab records usually start at rest (the
DAQ runs before the command moves): there the recorded displacement and force *are* the
noise, colour and all.

:func:`rest_spectra` finds each record's leading rest -- the samples before the command first
leaves its initial value, less :data:`REST_MARGIN` -- and, when the records hold enough of it
(:data:`MIN_REST` samples per record), the Welch PSD of each column there, pooled over records.
The colour is the ratio of that PSD to the white level (three neighbouring bins pooled),
kept only where it exceeds 1 by more than :data:`COLOUR_Z` standard deviations of the pooled
estimate and by at least :data:`MIN_COLOUR` (elsewhere the noise is white, and a ratio
below 1 is the estimate's scatter): :class:`NoiseShape`, a factor >= 1 on
the white PSD per frequency.  Records without a rest (a command that moves from the first
sample, a displacement used as its own command) keep the white floor.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import signal

from rths.diagnose.data.records import Record

__all__ = [
    "COLOUR_Z",
    "MIN_COLOUR",
    "MIN_REST",
    "REST_MARGIN",
    "NoiseShape",
    "leading_rest",
    "rest_spectra",
]

#: Samples [s] dropped at the end of a leading rest, before the command moves.
REST_MARGIN: float = 0.02
#: Least samples of rest a record must hold for its noise spectrum to count.
MIN_REST: int = 64
#: Standard deviations of the pooled PSD estimate by which the colour must exceed white.
COLOUR_Z: float = 3.0
#: Least factor on the white PSD taken for colour: a lesser one is within the noise floor's
#: stated uncertainty (:data:`rths.diagnose.residuals.FLOOR_MARGIN`, a factor of 2), and the
#: white level read at the top of the band is itself good to some per cent only.
MIN_COLOUR: float = 1.5
#: Longest Welch segment [samples] of the rest spectra.
_MAX_SEGMENT = 256


@dataclass(frozen=True)
class NoiseShape:
    """A column's noise colour: factor ``>= 1`` on its white PSD per frequency.

    Attributes
    ----------
    frequency
        Frequencies [Hz] of the estimate (equally spaced from 0).
    factor
        PSD of the noise at rest over the white level [-], >= 1.
    """

    frequency: NDArray[np.float64]
    factor: NDArray[np.float64]

    def at(self, f: NDArray[np.float64]) -> NDArray[np.float64]:
        """The factor at frequencies ``f`` [Hz] (linear interpolation, held beyond)."""
        return np.asarray(np.interp(f, self.frequency, self.factor), dtype=np.float64)


def leading_rest(record: Record) -> int:
    """Samples at the start of ``record`` before its command first leaves its initial value,
    less :data:`REST_MARGIN` (0 when the command moves at once).

    Parameters
    ----------
    record
        One record.
    """
    u = np.asarray(record.command, dtype=float)
    scale = float(np.max(np.abs(u))) if u.size else 0.0
    moved = np.flatnonzero(np.abs(u - u[0]) > 1e-9 * scale) if scale > 0.0 else np.empty(0)
    first = int(moved[0]) if moved.size else 0
    return max(0, first - int(round(REST_MARGIN / record.dt)))


def rest_spectra(records: list[Record], white: dict[str, float]) -> dict[str, NoiseShape]:
    """The colour of the ``measured`` and ``force`` noise from the records' leading rests
    (module docstring); a column is left out when the records hold too little rest or its
    noise is white.

    Parameters
    ----------
    records
        The records (one sampling rate).
    white
        White-noise RMS per column (``measured`` [m], ``force`` [N]).
    """
    rests = [(r, leading_rest(r)) for r in records]
    rests = [(r, n) for r, n in rests if n >= MIN_REST]
    if not rests:
        return {}
    # segments as long as the median rest allows (a record with a shorter rest is left out:
    # one short rest must not coarsen every record's resolution)
    nper = min(_MAX_SEGMENT, 2 ** int(math.log2(float(np.median([n for _, n in rests])))))
    rests = [(r, n) for r, n in rests if n >= nper]
    dt = records[0].dt
    out: dict[str, NoiseShape] = {}
    for key in ("measured", "force"):
        level = 2.0 * float(white.get(key, 0.0)) ** 2 * dt  # one-sided white PSD
        if level <= 0.0:
            continue
        acc, count, f = None, 0.0, None
        for r, n in rests:
            part = np.asarray(getattr(r, key), dtype=float)[:n]
            f, p = signal.welch(part, fs=1.0 / dt, nperseg=nper, detrend="constant")
            k = max(1.0, 2.0 * n / nper - 1.0)  # 50 % overlap
            acc = p * k if acc is None else acc + p * k
            count += k
        assert acc is not None and f is not None
        # a coloured noise is smooth in frequency: three neighbouring bins pooled (a third of
        # the scatter), so that one bin's chance excess is not taken for colour
        ratio = np.convolve(acc / count / level, np.ones(3) / 3.0, mode="same")
        ratio[[0, -1]] = (acc / count / level)[[0, -1]]
        coloured = ratio > max(1.0 + COLOUR_Z / math.sqrt(3.0 * count), MIN_COLOUR)
        if np.any(coloured[1:]):  # the DC bin is the rest's own offset
            factor = np.where(coloured, ratio, 1.0)
            factor[0] = factor[1]
            out[key] = NoiseShape(np.asarray(f, dtype=float), factor)
    return out
