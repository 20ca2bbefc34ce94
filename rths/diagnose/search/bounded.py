"""Box-constrained ridge least squares: the variable projection's linear solve when some of a
model's linear parameters are NOMINAL.toml's own, re-calibrated within a stated tolerance.

A model's :meth:`rths.diagnose.effects.model.Model.tolerance` gives, per linear parameter
``beta_j``, a relative tolerance ``t_j`` (NaN: free).  The bound is

* ``|beta_j - p_j| <= t_j |p_j|`` around the nominal value ``p_j`` when it is not zero;
* ``|beta_j| RMS(X_j) <= t_j RMS(y)`` when the nominal sets the parameter to zero: the term
  the nominal leaves out may be re-calibrated to at most ``t_j`` of the observation's RMS
  (its standard deviation: record offsets are nuisance terms).

The quadratic ``0.5 z' G z - b' z`` on unit-norm columns is minimised over the box by a small
active-set loop (the Gram matrix is a few columns wide): free variables solved, the worst
violator clamped, clamped ones released when the gradient points into the box.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["box_bounds", "box_solve"]


def box_bounds(
    prior: NDArray[np.float64],
    tolerance: NDArray[np.float64],
    x: NDArray[np.float64],
    y: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Lower and upper bounds of ``beta`` (module docstring; ``-inf, inf`` where free).

    Parameters
    ----------
    prior
        Nominal values ``p`` of ``beta`` (shape ``(p,)``).
    tolerance
        Relative tolerances ``t`` (NaN where free), shape ``(p,)``.
    x
        Design matrix ``X`` (shape ``(n, p)``).
    y
        The observation the model is fitted to (shape ``(n,)``), same unit as ``X beta``.
    """
    lo = np.full(prior.size, -np.inf)
    hi = np.full(prior.size, np.inf)
    y_rms = float(np.std(y)) if y.size else 0.0  # about its mean: offsets are no force
    for j in np.flatnonzero(np.isfinite(tolerance)):
        t, p = float(tolerance[j]), float(prior[j])
        if p != 0.0:
            lo[j], hi[j] = p - t * abs(p), p + t * abs(p)
        else:
            col = float(np.sqrt(np.mean(x[:, j] ** 2))) if x.shape[0] else 0.0
            half = t * y_rms / col if col > 0.0 else 0.0
            lo[j], hi[j] = -half, half
    return lo, hi


def box_solve(
    gram: NDArray[np.float64],
    rhs: NDArray[np.float64],
    lo: NDArray[np.float64],
    hi: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Minimiser of ``0.5 z' G z - rhs' z`` over ``lo <= z <= hi`` (``G`` positive definite).

    Parameters
    ----------
    gram
        ``G`` (shape ``(q, q)``).
    rhs
        ``rhs`` (shape ``(q,)``).
    lo, hi
        Bounds (``-inf``/``inf`` where free), shape ``(q,)``.
    """
    z = np.asarray(np.linalg.solve(gram, rhs), dtype=np.float64)
    if np.all(z >= lo) and np.all(z <= hi):
        return z
    q = rhs.size
    fixed = np.zeros(q, dtype=bool)
    value = np.zeros(q)
    for _ in range(4 * q + 4):
        free = ~fixed
        z = value.copy()
        if np.any(free):
            g_ff = gram[np.ix_(free, free)]
            b_f = rhs[free] - gram[np.ix_(free, fixed)] @ value[fixed]
            z[free] = np.linalg.solve(g_ff, b_f)
        below, above = free & (z < lo), free & (z > hi)
        if np.any(below | above):
            # clamp the worst violator (relative to its box), then solve again
            over = np.where(below, lo - z, np.where(above, z - hi, 0.0))
            width = np.where(np.isfinite(hi - lo), np.maximum(hi - lo, 1e-300), 1.0)
            j = int(np.argmax(over / width))
            fixed[j] = True
            value[j] = lo[j] if below[j] else hi[j]
            continue
        grad = gram @ z - rhs
        release = fixed & (((z <= lo) & (grad < 0.0)) | ((z >= hi) & (grad > 0.0)))
        if not np.any(release):
            return z
        j = int(np.flatnonzero(release)[np.argmax(np.abs(grad[release]))])
        fixed[j] = False
    return np.clip(z, lo, hi)
