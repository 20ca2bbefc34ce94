"""The bound of a term NOMINAL.toml sets to zero, band by band.

The baseline re-calibrates NOMINAL.toml's own parameters within a tolerance ``t``
(:data:`rths.diagnose.effects.specimen.NOMINAL_TOLERANCE`).  A parameter the nominal sets to
zero has no value to be a share of; its term may be at most ``t`` of the observation -- in
every octave band where the term acts, not of the observation's whole RMS.  A term's share
of the whole RMS does not carry from one excitation to another: on band-limited random drives
a device's force is mostly its inertance's at the top of the band, and a spring of 20 % of
that force's spread (90 kN/m beside a 760 kg, 10 kN s/m device of the emulated lab) was 68 %
of the force of a held-out 1.5 Hz sine, whose held-out NRMSE it took from the nominal's 16 %
to 59 %.  At one tone the two bounds are the same.

Used by the linear solve's box (:func:`rths.diagnose.search.bounded.box_bounds`) and by a
series chain's body terms (:mod:`rths.diagnose.effects.chain`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = ["ZERO_TERM_SHARE", "zero_term_scale"]

#: Share of a column's energy that makes an octave band one where the term acts (the bands in
#: which a term NOMINAL.toml sets to zero is bounded by the observation's).
ZERO_TERM_SHARE: float = 0.05


def _octave_energies(parts: list[NDArray[np.float64]], octaves: int) -> NDArray[np.float64]:
    """Energy of the parts (each about its mean, Hann-windowed) in ``octaves`` octave bands
    down from the Nyquist frequency (the lowest band holds what lies below), summed over the
    parts; one sample period for all parts."""
    out = np.zeros(octaves)
    for x in parts:
        if x.size < 4:
            continue
        spec = np.abs(np.fft.rfft((x - np.mean(x)) * np.hanning(x.size))) ** 2
        f = np.fft.rfftfreq(x.size)  # cycles per sample
        band = np.minimum(np.floor(-np.log2(np.maximum(f[1:], 1e-300) / 0.5)), octaves - 1)
        out += np.bincount(band.astype(int), weights=spec[1:], minlength=octaves)[:octaves]
    return out


def zero_term_scale(
    column: list[NDArray[np.float64]], observed: list[NDArray[np.float64]]
) -> float:
    """``min_b sqrt(E_y,b / E_c,b)`` over the octave bands ``b`` holding at least
    :data:`ZERO_TERM_SHARE` of the column's energy (module docstring): the largest coefficient
    whose term stays within the observation's size in every band where it acts, in the
    observation's unit per column unit; 0 when the column is zero.

    Parameters
    ----------
    column, observed
        The column and the observation, one array per contiguous part (a record's samples),
        one sample period for all.
    """
    longest = max((x.size for x in column), default=0)
    if longest < 4:
        return 0.0
    octaves = max(1, int(math.log2(longest)))
    e_c = _octave_energies(column, octaves)
    e_y = _octave_energies(observed, octaves)
    total = float(np.sum(e_c))
    if total <= 0.0:
        return 0.0
    acts = e_c >= ZERO_TERM_SHARE * total
    return float(np.sqrt(np.min(e_y[acts] / e_c[acts])))
