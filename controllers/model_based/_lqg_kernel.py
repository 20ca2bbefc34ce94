"""The LQG (and FF+LQG) compensator step compiled with numba (private to
controllers.model_based.lqg).

:meth:`controllers.model_based.lqg.LQGCompensator._step_impl` with its feedforward
(:meth:`controllers.model_based.feedforward.FeedforwardCompensator.command`) is plain Python on
small numpy
arrays: a dozen array operations and attribute look-ups per step.  Here the same arithmetic runs
as one compiled call on two flat arrays -- the constants ``P`` and the state ``S`` (layouts
below) -- so a step costs one dispatch.  ``tests/test_lqg.py`` checks it against the Python path
step for step.  :func:`ff_step` is the feedforward alone (the ``ff`` kind) for the loop's fused
kernel (:mod:`rths.core.compiled`), checked row by row in ``tests/test_fastpath.py``.

``P``: ``dt, k_z, 1/G(0), has_ff, hold, n, n_c, n_diff``, then ``A`` (n*n, row-major), ``b``,
``c``, ``K_e``, ``M`` (n each) and the feedforward coefficients ``c_ff`` (n_c).
``S``: ``z, r_prev, r_prev_ff, v_prev_ff, a_prev_ff``, then ``e_hat`` (n), the acceleration
history (n_diff + 1, newest first) and the six logged values (:data:`LOG_NAMES`).
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ["LOG_NAMES", "ff_step", "lqg_step", "pack", "pack_ff"]

#: The logged values at the end of ``S``, in order.
LOG_NAMES = (
    "feedforward",
    "feedback",
    "tracking_error",
    "predicted_error",
    "integral_error",
    "innovation",
)
_HEAD = 8
_STATE_HEAD = 5


def pack(
    dt: float,
    a: NDArray[np.float64],
    b: NDArray[np.float64],
    c: NDArray[np.float64],
    gain_state: NDArray[np.float64],
    gain_integral: float,
    filter_gain: NDArray[np.float64],
    inv_gain: float,
    ff_coefficients: list[float] | None,
    hold: bool,
    n_diff: int,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The constants ``P`` and a zero state ``S`` (see the module docstring)."""
    n = a.shape[0]
    cff = [] if ff_coefficients is None else list(ff_coefficients)
    head = [dt, gain_integral, inv_gain, float(ff_coefficients is not None), float(hold)]
    head += [float(n), float(len(cff)), float(n_diff)]
    p = np.concatenate(
        [head, a.ravel(), b, c, gain_state, filter_gain, np.asarray(cff, dtype=float)]
    ).astype(np.float64)
    s = np.zeros(_STATE_HEAD + n + n_diff + 1 + len(LOG_NAMES))
    return p, s


@njit(cache=True)
def lqg_step(
    p: NDArray[np.float64], s: NDArray[np.float64], r: float, v: float, acc: float, y: float
) -> float:  # pragma: no cover - compiled; covered through the cross-check with the Python path
    """One compensator step: target ``(r, v, acc)`` at ``t_{k+1}``, measurement ``y`` at
    ``t_k``; returns the command and updates ``S`` in place."""
    dt, kz, inv_gain = p[0], p[1], p[2]
    has_ff, hold = p[3] > 0.5, p[4] > 0.5
    n, nc, nd = int(p[5]), int(p[6]), int(p[7])
    oa = 8
    ob = oa + n * n
    oc = ob + n
    ok = oc + n
    om = ok + n
    off = om + n
    oe = 5
    oh = oe + n
    ol = oh + nd + 1
    # measurement update (current estimator) with the tracking error y_k - r_k
    error = y - s[1]
    ce = 0.0
    for i in range(n):
        ce += p[oc + i] * s[oe + i]
    innovation = error - ce
    e_now = np.empty(n)
    for i in range(n):
        e_now[i] = s[oe + i] + p[om + i] * innovation
    s[0] -= dt * error
    # feedforward
    if has_ff:
        if hold:
            t0 = 0.5 * (r + s[2])
            t1 = 0.5 * (v + s[3])
            t2 = 0.5 * (acc + s[4])
        else:
            t0, t1, t2 = r, v, acc
        for i in range(nd, 0, -1):  # acceleration history, newest first
            s[oh + i] = s[oh + i - 1]
        s[oh] = acc
        u_ff = 0.0
        for i in range(nc):
            if i == 0:
                term = t0
            elif i == 1:
                term = t1
            elif i == 2:
                term = t2
            elif i == 3:
                term = (s[oh] - s[oh + 1]) / dt
            elif i == 4:
                term = (s[oh] - 2.0 * s[oh + 1] + s[oh + 2]) / (dt * dt)
            else:
                term = (s[oh] - 3.0 * s[oh + 1] + 3.0 * s[oh + 2] - s[oh + 3]) / (dt * dt * dt)
            u_ff += p[off + i] * term
        s[2], s[3], s[4] = r, v, acc
    else:
        u_ff = r * inv_gain
    # LQR correction
    ke = 0.0
    for i in range(n):
        ke += p[ok + i] * e_now[i]
    u_fb = -ke - kz * s[0]
    # time update to t_{k+1}
    pe = 0.0
    for i in range(n):
        x = p[ob + i] * u_fb
        for j in range(n):
            x += p[oa + i * n + j] * e_now[j]
        s[oe + i] = x
    for i in range(n):
        pe += p[oc + i] * s[oe + i]
    s[1] = r
    s[ol] = u_ff
    s[ol + 1] = u_fb
    s[ol + 2] = error
    s[ol + 3] = pe
    s[ol + 4] = s[0]
    s[ol + 5] = innovation
    return u_ff + u_fb


def pack_ff(
    dt: float, coefficients: list[float], hold: bool, n_diff: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Constants and a zero state of :func:`ff_step` (the ``ff`` compensator alone).

    ``P``: ``dt, hold, n_diff, n_c, dt**2, dt**3`` (Python's powers: the reference divides by
    them), then the coefficients.  ``S``: the previous target ``r, v, a``, the acceleration
    history (``n_diff + 1``, newest first) and the command (the logged value).

    Parameters
    ----------
    dt
        Loop step [s].
    coefficients
        The inverse's coefficients ``c_i``.
    hold
        Evaluate the inverse at mid-step.
    n_diff
        Derivatives beyond the acceleration, from differences of its history.
    """
    head = [dt, float(hold), float(n_diff), float(len(coefficients)), dt**2, dt**3]
    p = np.array(head + list(coefficients), dtype=np.float64)
    return p, np.zeros(3 + n_diff + 1 + 1)


@njit(cache=True)
def ff_step(
    p: NDArray[np.float64], s: NDArray[np.float64], r: float, v: float, acc: float
) -> float:  # pragma: no cover - compiled; covered through the loop's compiled-path cross-check
    """``FeedforwardCompensator.command``: the inverse of the low-order model at the target
    ``(r, v, acc)`` [m, m/s, m/s^2]; returns the command [m] and updates ``S`` (:func:`pack_ff`)
    in place."""
    dt, hold, nd, nc = p[0], p[1] > 0.5, int(p[2]), int(p[3])
    oh = 3
    terms = np.empty(6)
    if hold:
        terms[0] = 0.5 * (r + s[0])
        terms[1] = 0.5 * (v + s[1])
        terms[2] = 0.5 * (acc + s[2])
    else:
        terms[0], terms[1], terms[2] = r, v, acc
    for i in range(nd, 0, -1):
        s[oh + i] = s[oh + i - 1]
    s[oh] = acc
    if nd >= 1:
        terms[3] = (s[oh] - s[oh + 1]) / dt
    if nd >= 2:
        terms[4] = (s[oh] - 2.0 * s[oh + 1] + s[oh + 2]) / p[4]
    if nd >= 3:
        terms[5] = (s[oh] - 3.0 * s[oh + 1] + 3.0 * s[oh + 2] - s[oh + 3]) / p[5]
    s[0], s[1], s[2] = r, v, acc
    u = 0.0
    for i in range(min(nc, 3 + nd)):
        u += p[6 + i] * terms[i]
    s[s.size - 1] = u
    return u
