"""Tracking errors of an RTHS record: normalised RMS (J2, the sync-subspace RMSE), peak error (J3)
and delay (J1) of the measured displacement behind the target.

References
----------
Silva, Gomez, Maghareh, Dyke & Spencer (2020), "Benchmark control problem for real-time hybrid
simulation", Mech. Syst. Signal Process. 135, 106381 (J1-J3).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike
from scipy import signal

from rths.core.errors import DataError, ParameterError, check_positive
from rths.metrics._records import MIN_SAMPLES, _pair, _rms

__all__ = [
    "DEFAULT_MAX_DELAY",
    "normalised_peak_error",
    "normalised_rms_error",
    "sync_subspace_rmse",
    "tracking_delay",
]

#: Default half-width [s] of the J1 lag search; servo-hydraulic delays are a few to 30 ms.
DEFAULT_MAX_DELAY: float = 0.05


def normalised_rms_error(target: ArrayLike, measured: ArrayLike) -> float:
    """Benchmark criterion J2: normalised RMS tracking error [-].

    .. math:: J_2 = \\sqrt{\\textstyle\\sum_i (x_{m,i} - x_{t,i})^2 \\big/ \\sum_i x_{t,i}^2}

    By definition the same number as :func:`sync_subspace_rmse`.  The benchmark's released
    MATLAB evaluation divides standard deviations (means removed) instead of RMS values; the two
    agree for zero-mean records, as RTHS records that start and end at rest are.

    Parameters
    ----------
    target, measured
        Displacements [m], shape ``(n,)``.
    """
    x_t, x_m = _pair(target, measured)
    return _rms(x_m - x_t) / _rms(x_t)


def sync_subspace_rmse(target: ArrayLike, measured: ArrayLike) -> float:
    """RMS of measured minus target displacement over the target RMS [-].

    The index S0 reports beside its synchronisation subspace plot (1.13 %, S0 Fig. 33).
    Identical by definition to J2 (:func:`normalised_rms_error`); both names are in use.

    Parameters
    ----------
    target, measured
        Displacements [m], shape ``(n,)``.
    """
    return normalised_rms_error(target, measured)


def normalised_peak_error(target: ArrayLike, measured: ArrayLike) -> float:
    """Benchmark criterion J3: peak tracking error over peak target [-].

    .. math:: J_3 = \\max_i |x_{m,i} - x_{t,i}| \\big/ \\max_i |x_{t,i}|

    Parameters
    ----------
    target, measured
        Displacements [m], shape ``(n,)``.
    """
    x_t, x_m = _pair(target, measured)
    return float(np.max(np.abs(x_m - x_t)) / np.max(np.abs(x_t)))


def tracking_delay(
    target: ArrayLike, measured: ArrayLike, dt: float, max_delay: float = DEFAULT_MAX_DELAY
) -> float:
    """Benchmark criterion J1: delay [s] of the measured behind the target displacement.

    The lag ``k`` (samples, ``|k| <= L = ceil(max_delay/dt)``) maximising the Pearson
    correlation of the fixed window ``x_m[L : n-L]`` with the shifted window
    ``x_t[L-k : n-L-k]`` is found, as in the benchmark's evaluation (which searches
    ``0 <= k < 50``).  A parabola through the correlation at ``k-1, k, k+1`` refines it to a
    fraction of a sample: for a sine of ``P`` samples per period its bias is below
    ``(2 pi / P)^2 / 12`` of the fractional part.  The correlation is mean-removed and
    normalised, so offsets and amplitude errors do not move the estimate.

    Parameters
    ----------
    target, measured
        Displacements [m], shape ``(n,)``.
    dt
        Sampling step [s].
    max_delay
        Half-width [s] of the lag search.  Keep it below half the shortest significant period
        of the target, or a periodic record may lock onto a neighbouring cycle.

    Returns
    -------
    float
        Delay [s]; positive when the measured displacement lags, negative when it leads.

    Raises
    ------
    DataError
        Invalid records, a constant window, or a correlation peak at the search limit (the
        delay exceeds ``max_delay`` or the records are unrelated).
    ParameterError
        ``dt`` or ``max_delay`` not positive, or ``max_delay`` leaves too short an overlap.
    """
    x_t, x_m = _pair(target, measured)
    dt = check_positive(dt, "sampling step dt")
    max_delay = check_positive(max_delay, "max_delay")
    n = x_t.size
    lags = math.ceil(max_delay / dt - 1e-9)
    m = n - 2 * lags
    if m < MIN_SAMPLES:
        raise ParameterError(
            f"max_delay must leave at least {MIN_SAMPLES} overlapping samples; got "
            f"{max_delay!r} s = {lags} samples for a record of {n} samples"
        )
    window = x_m[lags : n - lags] - np.mean(x_m[lags : n - lags])
    shifted = x_t - np.mean(x_t)
    # cross[j] = sum_i shifted[i + j] * window[i] is lag k = lags - j: reverse to index by k.
    cross = signal.correlate(shifted, window, mode="valid")[::-1]
    csum = np.concatenate(([0.0], np.cumsum(shifted)))
    csq = np.concatenate(([0.0], np.cumsum(shifted * shifted)))
    start = np.arange(2 * lags, -1, -1)  # first target index of the segment for k = -L..L
    seg_sum = csum[start + m] - csum[start]
    seg_var = np.maximum(csq[start + m] - csq[start] - seg_sum**2 / m, 0.0)
    norm = np.sqrt(seg_var * float(window @ window))
    if not np.all(norm > 0.0):
        raise DataError("target and measured must vary within the J1 window; one is constant")
    rho = cross / norm
    i = int(np.argmax(rho))
    if i == 0 or i == 2 * lags:
        raise DataError(
            f"J1 correlation peak lies at the search limit {(i - lags) * dt:+.6g} s; the delay "
            f"exceeds max_delay={max_delay!r} s or the records are unrelated"
        )
    before, peak, after = rho[i - 1], rho[i], rho[i + 1]
    curvature = before - 2.0 * peak + after
    offset = 0.5 * (before - after) / curvature if curvature < 0.0 else 0.0
    return float((i - lags + offset) * dt)
