"""Decompose the gap: where it lies (channel), how big (NRMSE), in which band, where in the cycle.

Significance.  A channel's residual is compared with the noise floor a perfect model would leave
(:meth:`rths.diagnose.channels.Channel.floor_psd`, from the white-noise levels estimated on the
record itself) plus a modelling tolerance: :data:`MODEL_TOLERANCE` squared times the observed
signal's own PSD plus its variance spread evenly over the tested band (differencing,
discretisation and converter quantisation -- e.g. the command DAC's steps, invisible in a
recorded command -- stay far below any effect of interest: a model within 0.2 % RMS of the
observation counts as exact).
The held-out residual's Welch PSD is summed over bands of 1/6 octave and over the whole band; the
channel is significant when, in any of them, the ratio residual/floor exceeds
``1 + Z/sqrt(n) + FLOOR_MARGIN`` (``n`` independent PSD estimates in the band, :data:`Z_SCORE`
standard deviations of a chi-square ratio, and :data:`FLOOR_MARGIN` for the uncertainty of the
estimated floor).

Band.  The excess PSD (residual minus floor, clipped at 0) is grown around its peak, one bin at a
time towards the larger neighbour, until it holds :data:`BAND_ENERGY` of the total excess.

Phase.  With the drive displacement's analytic signal ``x = A cos(phi)`` (Hilbert transform),
samples with ``|sin phi| < 1/2`` are near reversals (displacement extrema), samples with
``|cos phi| < 1/2`` near zero crossings (peak velocity); each class holds a third of a
sinusoid.  The class whose mean excess power (residual^2 minus floor) is at least
:data:`PHASE_ENRICHMENT` times the overall mean names the phase, else ``broadband``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy import signal

__all__ = [
    "BAND_ENERGY",
    "FLOOR_MARGIN",
    "MODEL_TOLERANCE",
    "PHASE_ENRICHMENT",
    "Z_SCORE",
    "Decomposition",
    "decompose",
    "nrmse",
    "spectral_bands",
    "welch",
]

#: Relative accuracy below which a model counts as exact (fraction of the observed RMS, per
#: frequency): the resolution of the replay itself (differencing, discretisation, converter
#: quantisation), far below any effect of interest; 0.2 % of the signal.
MODEL_TOLERANCE: float = 0.002
#: Standard deviations of the band ratio under the null hypothesis (covers ~100 bands).
Z_SCORE: float = 5.0
#: Allowance for the uncertainty of the estimated noise floor (fraction of it): a white-noise
#: floor read off the top of the band misses coloured converter noise and quantisation by up
#: to a factor of about 2 in a band.
FLOOR_MARGIN: float = 1.0
#: Fraction of the excess residual energy the reported band must hold.
BAND_ENERGY: float = 0.5
#: Mean excess power in a cycle class over the overall mean that names the phase.
PHASE_ENRICHMENT: float = 1.4
#: Target Welch resolution [Hz].
_RESOLUTION = 0.5


def nrmse(residual: NDArray[np.float64], observed: NDArray[np.float64]) -> float:
    """``RMS(residual) / RMS(observed)`` [-] (NaN for an empty or zero observation).

    Parameters
    ----------
    residual
        Observed minus predicted, in the observation's unit.
    observed
        The observation.
    """
    den = float(np.sqrt(np.mean(observed**2))) if observed.size else 0.0
    return float(np.sqrt(np.mean(residual**2))) / den if den > 0.0 else math.nan


@dataclass(frozen=True)
class Decomposition:
    """Where a channel's (baseline) residual lies.

    Attributes
    ----------
    significant
        Whether the residual exceeds the noise floor (module docstring).
    ratio
        Largest band ratio residual/(floor + tolerance) and its threshold.
    band_hz
        ``[lo, hi]`` [Hz] holding :data:`BAND_ENERGY` of the excess energy.
    peak_hz
        Frequency [Hz] of the largest excess PSD.
    phase
        ``reversals``, ``zero_crossings`` or ``broadband``.
    windows
        ``[[t0, t1], ...]`` [s] in the first held-out part (record time) where the residual
        power, averaged over half a period of the peak frequency, exceeds both four times the
        floor and twice its own median: where the gap concentrates (at most 30, longest first).
    frequency, residual_psd, floor_psd
        Welch PSDs [unit^2/Hz] for the report.
    """

    significant: bool
    ratio: tuple[float, float]
    band_hz: tuple[float, float]
    peak_hz: float
    phase: str
    windows: list[tuple[float, float]] = field(default_factory=list)
    frequency: NDArray[np.float64] = field(default_factory=lambda: np.empty(0), repr=False)
    residual_psd: NDArray[np.float64] = field(default_factory=lambda: np.empty(0), repr=False)
    floor_psd: NDArray[np.float64] = field(default_factory=lambda: np.empty(0), repr=False)


def welch(parts: list[NDArray], dt: float) -> tuple[NDArray, NDArray, float]:
    """Length-weighted Welch PSD over records and the number of averaged segments.

    Held-out samples cut into short runs (a force-driven view scores only where a contact
    carries force: a rattling contact leaves runs of a few dozen samples) are joined, each run
    about its own mean, when the runs of at least 64 samples hold less than half of them: the
    joints add a little broadband leakage, where dropping the runs would leave nothing to
    test.

    Parameters
    ----------
    parts
        Signal parts (one unit), each at least a few samples long.
    dt
        Sample period [s].
    """
    long = [p for p in parts if p.size >= 64]
    total = sum(p.size for p in parts)
    if total >= 128 and sum(p.size for p in long) < 0.5 * total:
        long = [np.concatenate([p - np.mean(p) for p in parts if p.size])]
    if long:
        parts = long
        nper = max(64, min(int(round(1.0 / (_RESOLUTION * dt))), min(p.size for p in parts)))
    else:  # only scraps: one segment each, of the shortest length (equal frequency grids)
        nper = max(2, min(p.size for p in parts))
        parts = [p[-nper:] for p in parts if p.size >= 2]
    acc, count, f = None, 0.0, None
    for p in parts:
        f, s = signal.welch(p, fs=1.0 / dt, nperseg=nper, detrend="constant")
        k = max(1.0, 2.0 * p.size / nper - 1.0)  # 50 % overlap
        acc = s * k if acc is None else acc + s * k
        count += k
    assert f is not None and acc is not None
    return f, acc / count, count


def spectral_bands(f: NDArray, f_lo: float, f_hi: float) -> list[NDArray]:
    """Index sets of the 1/6-octave bands of ``f`` from ``f_lo`` to ``f_hi`` (each at least
    two bins wide).

    Parameters
    ----------
    f
        Equally spaced frequencies [Hz].
    f_lo, f_hi
        Lowest and highest band edge [Hz].
    """
    edges = [f_lo]
    while edges[-1] < f_hi:
        edges.append(max(edges[-1] * 2 ** (1 / 6), edges[-1] + 2 * (f[1] - f[0])))
    out = [np.flatnonzero((f >= a) & (f < b)) for a, b in zip(edges[:-1], edges[1:], strict=False)]
    return [b for b in out if b.size]


def _band_of_excess(f: NDArray, excess: NDArray) -> tuple[tuple[float, float], float]:
    total = float(np.sum(excess))
    if total <= 0.0:
        return (0.0, 0.0), 0.0
    peak = int(np.argmax(excess))
    lo = hi = peak
    held = float(excess[peak])
    while held < BAND_ENERGY * total:
        left = excess[lo - 1] if lo > 0 else -1.0
        right = excess[hi + 1] if hi + 1 < excess.size else -1.0
        if right >= left:
            hi += 1
            held += float(right)
        else:
            lo -= 1
            held += float(left)
    df = f[1] - f[0]
    return (float(max(f[lo] - df / 2, 0.0)), float(f[hi] + df / 2)), float(f[peak])


def _phase(drive: list[NDArray], residual: list[NDArray], floor_var: float) -> str:
    excess_all, rev, zc = [], [], []
    for x, r in zip(drive, residual, strict=True):
        phi = np.angle(signal.hilbert(x - np.mean(x)))
        e = r * r - floor_var
        excess_all.append(e)
        rev.append(e[np.abs(np.sin(phi)) < 0.5])
        zc.append(e[np.abs(np.cos(phi)) < 0.5])
    mean_all = float(np.mean(np.concatenate(excess_all)))
    if mean_all <= 0.0:
        return "broadband"
    m_rev = float(np.mean(np.concatenate(rev))) / mean_all
    m_zc = float(np.mean(np.concatenate(zc))) / mean_all
    if max(m_rev, m_zc) < PHASE_ENRICHMENT:
        return "broadband"
    return "reversals" if m_rev >= m_zc else "zero_crossings"


def _windows(r: NDArray, t: NDArray, dt: float, floor_var: float, width: float) -> list:
    n = max(1, int(round(width / dt)))
    power = np.convolve(r * r, np.ones(n) / n, mode="same")
    hot = power > max(4.0 * floor_var, 2.0 * float(np.median(power)))
    edges = np.flatnonzero(np.diff(np.concatenate([[0], hot.astype(int), [0]])))
    spans = [(t[a], t[b - 1] + dt) for a, b in zip(edges[::2], edges[1::2], strict=True)]
    spans.sort(key=lambda s: s[0] - s[1])
    return [(round(float(a), 6), round(float(b), 6)) for a, b in spans[:30]]


def decompose(
    residual: list[NDArray[np.float64]],
    observed: list[NDArray[np.float64]],
    drive: list[NDArray[np.float64]],
    times: list[NDArray[np.float64]],
    dt: float,
    floor: tuple[NDArray[np.float64], NDArray[np.float64]],
    f_max: float,
) -> Decomposition:
    """Significance, band, phase and windows of held-out residual parts (module docstring).

    Parameters
    ----------
    residual, observed, drive, times
        Held-out parts (one per record): residual, observation, drive displacement [m] and
        sample times [s].
    dt
        Sample period [s].
    floor
        ``(frequency [Hz], one-sided PSD)`` of the noise floor.
    f_max
        Highest frequency [Hz] tested (the specimen smoother passes nothing above ~1.5 f_c).
    """
    f, s_r, k = welch(residual, dt)
    _, s_o, _ = welch(observed, dt)
    f_lo = max(2.0 * (f[1] - f[0]), 0.1)
    f_hi = min(f_max, f[-1])
    variance = float(np.mean(np.concatenate(observed) ** 2))
    tolerance = MODEL_TOLERANCE**2 * (s_o + variance / (f_hi - f_lo))
    s_n = np.interp(f, floor[0], floor[1]) + tolerance
    floor_var = float(np.sum(np.interp(f, floor[0], floor[1])) * (f[1] - f[0]))
    score, best, threshold = -math.inf, 0.0, math.inf
    for idx in [*spectral_bands(f, f_lo, f_hi), np.flatnonzero((f >= f_lo) & (f <= f_hi))]:
        if idx.size == 0:
            continue
        ratio = float(np.sum(s_r[idx]) / np.sum(s_n[idx]))
        limit = 1.0 + Z_SCORE / math.sqrt(0.9 * k * idx.size) + FLOOR_MARGIN
        if ratio / limit > score:
            score, best, threshold = ratio / limit, ratio, limit
    significant = score > 1.0
    in_band = (f >= f_lo) & (f <= f_hi)
    excess = np.where(in_band, np.clip(s_r - s_n, 0.0, None), 0.0)
    band, peak = _band_of_excess(f, excess)
    phase = _phase(drive, residual, floor_var) if significant else "none"
    width = 0.5 / max(peak, 1.0)
    windows = _windows(residual[0], times[0], dt, floor_var, width) if significant else []
    return Decomposition(significant, (best, threshold), band, peak, phase, windows, f, s_r, s_n)
