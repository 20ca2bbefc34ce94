"""Box-constrained ridge least squares: the variable projection's linear solve when some of a
model's linear parameters are NOMINAL.toml's own, re-calibrated within a stated tolerance.

A model's :meth:`rths.diagnose.effects.model.Model.tolerance` gives, per linear parameter
``beta_j``, a relative tolerance ``t_j`` (NaN: free).  The bound is

* ``|beta_j - p_j| <= t_j |p_j|`` around the nominal value ``p_j`` when it is not zero;
* ``|beta_j| <= t_j min_b sqrt(E_y,b / E_j,b)`` when the nominal sets the parameter to zero:
  the term the nominal leaves out may be re-calibrated to at most ``t_j`` of the observation
  in every octave band ``b`` where its column acts (:mod:`rths.diagnose.effects.zero_terms`:
  ``E`` the band energies about the means, record offsets being nuisance terms).

The quadratic ``0.5 z' G z - b' z`` on unit-norm columns is minimised over the box by a small
active-set loop (the Gram matrix is a few columns wide): free variables solved, the worst
violator clamped, clamped ones released when the gradient points into the box.  A model may
also order two of its parameters, ``beta_i <= beta_j`` (a body's inertance behind a series
element and the total: the mass ahead of the element is not negative): a solution that
violates the order is solved again with ``beta_i = beta_j`` -- one more linear constraint on a
convex problem, so an optimum that violates it lies on its boundary (:func:`ridge_box_lstsq`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = ["box_bounds", "box_solve", "ridge_box_lstsq"]


def box_bounds(
    prior: NDArray[np.float64],
    tolerance: NDArray[np.float64],
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    zero_scale: NDArray[np.float64] | None = None,
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
    zero_scale
        Per column, :func:`rths.diagnose.effects.zero_terms.zero_term_scale` of the column
        and the observation over their records (shape ``(p,)``; used where the nominal sets
        the parameter to zero); None: one band, ``RMS(y) / RMS(X_j)`` over the stacked rows.
    """
    lo = np.full(prior.size, -np.inf)
    hi = np.full(prior.size, np.inf)
    y_rms = float(np.std(y)) if y.size else 0.0  # about its mean: offsets are no force
    for j in np.flatnonzero(np.isfinite(tolerance)):
        t, p = float(tolerance[j]), float(prior[j])
        if p != 0.0:
            lo[j], hi[j] = p - t * abs(p), p + t * abs(p)
        else:
            if zero_scale is not None:
                half = t * float(zero_scale[j])
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
        # a box of zero width (a calibration switched off: lo = hi) is never released
        release = fixed & (lo < hi) & (((z <= lo) & (grad < 0.0)) | ((z >= hi) & (grad > 0.0)))
        if not np.any(release):
            return z
        j = int(np.flatnonzero(release)[np.argmax(np.abs(grad[release]))])
        fixed[j] = False
    return np.clip(z, lo, hi)


def ridge_box_lstsq(
    x: NDArray[np.float64],
    o: NDArray[np.float64],
    target: NDArray[np.float64],
    ridge: tuple[NDArray[np.float64], float | NDArray[np.float64]],
    bounds: tuple[NDArray[np.float64], NDArray[np.float64]],
    ordered: tuple[tuple[int, int], ...] = (),
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(beta, offsets)`` minimising ``||target - x beta - o offsets||^2 + ||sqrt(r) d (beta -
    prior)||^2`` over ``lo <= beta <= hi`` and the ordered pairs (module docstring), ``d``
    the column norms of ``x``; the nuisance terms ``offsets`` are free and unpenalised.  Solved
    by :func:`box_solve` on unit-norm columns.

    Parameters
    ----------
    x, o
        Model columns (shape ``(n, p)``) and nuisance columns (shape ``(n, q)``).
    target
        The observation less the model's fixed part (shape ``(n,)``).
    ridge
        ``(prior, r)``: nominal values of ``beta`` (shape ``(p,)``) and the ridge weight, one
        for all or one per parameter (shape ``(p,)``; 0: not pulled).
    bounds
        ``(lo, hi)`` of ``beta`` (``-inf``/``inf`` where free), shape ``(p,)`` each.
    ordered
        Pairs ``(i, j)`` with ``beta_i <= beta_j``, each parameter in at most one pair; the
        answer is exact for one pair (the series chain's), a sequence of merges for more.
    """
    prior, r_all = ridge
    r = np.broadcast_to(np.asarray(r_all, dtype=float), prior.shape)
    lo, hi = bounds
    beta, off = _ridge_box(x, o, target, (prior, r, None), lo, hi)
    for i, j in ordered:
        if beta[i] <= beta[j]:
            continue
        d = np.linalg.norm(x, axis=0)  # only when a pair is merged (the search's hot path)
        keep = [k for k in range(beta.size) if k != i]
        m = keep.index(j)
        t = np.eye(beta.size)[:, keep]
        t[i, m] = 1.0  # beta = t @ gamma: beta_i = beta_j
        lo_m, hi_m = lo[keep].copy(), hi[keep].copy()
        lo_m[m], hi_m[m] = max(lo[i], lo[j]), min(hi[i], hi[j])
        # the two ridge terms on one value: their weights add, their priors average
        d_m, prior_m = d[keep].copy(), prior[keep].copy()
        d_m[m] = math.hypot(d[i], d[j])
        if d_m[m] > 0.0:
            prior_m[m] = (d[i] ** 2 * prior[i] + d[j] ** 2 * prior[j]) / d_m[m] ** 2
        r_m = r[keep].copy()
        r_m[m] = max(r[i], r[j])
        gamma, off = _ridge_box(x @ t, o, target, (prior_m, r_m, d_m), lo_m, hi_m)
        beta = t @ gamma
    return beta, off


def _ridge_box(x, o, target, ridge, lo, hi):
    """:func:`ridge_box_lstsq` without order; ``ridge = (prior, r, d)``, ``d`` the ridge's
    column scales (None: the column norms; a merged pair: the root sum of squares of its
    two)."""
    prior, r, d = ridge
    p = x.shape[1]
    a = np.hstack([x, o])
    norms = np.linalg.norm(a, axis=0)
    norms[norms == 0.0] = 1.0
    an = a / norms
    gram = an.T @ an
    rhs = an.T @ target
    prior_n = np.concatenate([prior, np.zeros(o.shape[1])]) * norms
    # unit-norm columns carry the plain weight r; a merged pair its summed ridge terms' weight
    scale = np.ones(p) if d is None else np.where(d > 0.0, d, 1.0) / norms[:p]
    weight = np.concatenate([r * scale**2, np.zeros(o.shape[1])])
    gram[np.diag_indices_from(gram)] += weight + 1e-12
    free = np.full(o.shape[1], np.inf)
    lo_n = np.concatenate([lo, -free]) * norms
    hi_n = np.concatenate([hi, free]) * norms
    sol = box_solve(gram, rhs + weight * prior_n, lo_n, hi_n) / norms
    return sol[:p], sol[p:]
