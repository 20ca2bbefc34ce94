"""Validation of the records every metric takes (private to :mod:`rths.metrics`)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rths.core.errors import DataError

#: Fewest samples a record (and the overlap left by the J1 lag search) may have.
MIN_SAMPLES: int = 16

#: Default half-width [s] of the J1 lag search; servo-hydraulic delays are a few to 30 ms.
DEFAULT_MAX_DELAY: float = 0.05


def _record(values: ArrayLike, name: str, n: int | None = None) -> NDArray[np.float64]:
    """``values`` as a finite 1-D float array of at least MIN_SAMPLES (and ``n``) samples."""
    try:
        x = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise DataError(f"{name} must be a numeric 1-D array; got {values!r:.60}") from None
    if x.ndim != 1:
        raise DataError(f"{name} must be a 1-D array; got shape {x.shape}")
    if n is not None and x.size != n:
        raise DataError(f"{name} must have the target's length {n}; got {x.size}")
    if x.size < MIN_SAMPLES:
        raise DataError(f"{name} must have at least {MIN_SAMPLES} samples; got {x.size}")
    bad = np.flatnonzero(~np.isfinite(x))
    if bad.size:
        raise DataError(
            f"{name} must be finite; got {float(x[bad[0]])!r} at index {bad[0]} "
            f"({bad.size} non-finite samples)"
        )
    return x


def _pair(
    target: ArrayLike, measured: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Validated (target, measured); the target must not be identically zero."""
    x_t = _record(target, "target")
    x_m = _record(measured, "measured", x_t.size)
    if not np.any(x_t):
        raise DataError("target must not be identically zero (its RMS normalises the errors)")
    return x_t, x_m


def _rms(x: NDArray[np.float64]) -> float:
    """RMS computed on ``x`` scaled by its peak, so that neither 1e-300 nor 1e300 under- or
    overflows in the square."""
    peak = float(np.max(np.abs(x))) if x.size else 0.0
    if peak == 0.0 or not np.isfinite(peak):
        return peak
    return peak * float(np.sqrt(np.mean((x / peak) ** 2)))
