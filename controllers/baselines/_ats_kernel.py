"""The ATS compensator's step as one compiled call (private to :mod:`controllers.baselines.ats`).

Per step :class:`controllers.baselines.ats.AdaptiveTimeSeries` low-passes the previous command and
the
measurement (two 6th-order Butterworths, three sections each), writes them into its moving
window and, every ``update_every`` steps, re-identifies ``(a0, a1, a2)`` by least squares over
the window (4096 samples at 4096 Hz).  In NumPy the update costs ~200 us (a dozen array
temporaries, an SVD for the condition number), ~12 us per step on average;
:func:`ats_step` does the whole step in one compiled call.

The filters, the window, the threshold test, the rate and bound clipping are the same scalar
operations as the Python path (bit for bit); the least-squares sums (column norms, the 3x3 normal
matrix) are summed left to right here and by NumPy/BLAS in other orders, so the identified
coefficients differ at round-off (``tests/test_ats_kernel.py`` states and checks the tolerance).
The Python path stays the reference (``AdaptiveTimeSeries(use_jit=False)``).

Layouts
-------
``sos``      shape ``(sections, 6)``: the Butterworth's second-order sections (both filters).
``zf``       shape ``(2, sections, 2)``: the command's and the measurement's filter states.
``window``   shape ``(2, n)``: the filtered commands and measurements (a ring).
``counters`` int64 ``[next slot, samples recorded, updates]``.
``state``    ``[a0, a1, a2, previous command]``.
``consts``   :data:`CONSTS` in order.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ["CONSTS", "ats_step"]

#: Constants (``consts``), in order: ``2 dt`` [s], ``dt**2`` [s^2], the amplitude threshold [m],
#: 1.0 when the low-pass is on, ``update_every``, the lower bounds of ``a0..a2``, the upper
#: bounds, the largest change per update.
CONSTS = ("two_dt", "dt_squared", "threshold", "filtered", "update_every",
          "lo0", "lo1", "lo2", "hi0", "hi1", "hi2", "limit0", "limit1", "limit2")  # fmt: skip


@njit(cache=True)
def _filter(sos: NDArray[np.float64], z: NDArray[np.float64], x: float) -> float:
    for s in range(sos.shape[0]):  # pragma: no cover - compiled (rths.core.filters.LowPass)
        y = sos[s, 0] * x + z[s, 0]
        z[s, 0] = sos[s, 1] * x - sos[s, 4] * y + z[s, 1]
        z[s, 1] = sos[s, 2] * x - sos[s, 5] * y
        x = y
    return x


@njit(cache=True)
def _identify(
    window: NDArray[np.float64],
    start: int,
    state: NDArray[np.float64],
    consts: NDArray[np.float64],
) -> bool:  # pragma: no cover - compiled; covered through the cross-check with the Python path
    n = window.shape[1]
    u = np.empty(n)
    y = np.empty(n)
    peak = 0.0
    for j in range(n):
        u[j] = window[0, (start + j) % n]
        y[j] = window[1, (start + j) % n]
        peak = max(peak, abs(y[j]))
    if peak < consts[2]:
        return False
    two_dt, dt_squared = consts[0], consts[1]
    x = np.empty((n - 2, 3))
    for j in range(1, n - 1):
        x[j - 1, 0] = y[j]
        x[j - 1, 1] = (y[j + 1] - y[j - 1]) / two_dt
        x[j - 1, 2] = (y[j + 1] - 2.0 * y[j] + y[j - 1]) / dt_squared
    scale = np.zeros(3)
    for j in range(n - 2):
        for p in range(3):
            scale[p] += x[j, p] * x[j, p]
    for p in range(3):
        if scale[p] == 0.0:
            return False
        scale[p] = np.sqrt(scale[p])
    normal = np.zeros((3, 3))
    rhs = np.zeros(3)
    for j in range(n - 2):
        s0, s1, s2 = x[j, 0] / scale[0], x[j, 1] / scale[1], x[j, 2] / scale[2]
        normal[0, 0] += s0 * s0
        normal[0, 1] += s0 * s1
        normal[0, 2] += s0 * s2
        normal[1, 1] += s1 * s1
        normal[1, 2] += s1 * s2
        normal[2, 2] += s2 * s2
        rhs[0] += s0 * u[j + 1]
        rhs[1] += s1 * u[j + 1]
        rhs[2] += s2 * u[j + 1]
    normal[1, 0], normal[2, 0], normal[2, 1] = normal[0, 1], normal[0, 2], normal[1, 2]
    if np.linalg.cond(normal) > 1e12:  # e.g. a single sine: a0 and a2 not separable
        return False
    a = np.linalg.solve(normal, rhs)
    for p in range(3):
        step = min(max(a[p] / scale[p] - state[p], -consts[11 + p]), consts[11 + p])
        state[p] = min(max(state[p] + step, consts[5 + p]), consts[8 + p])
    return True


@njit(cache=True)
def ats_step(
    sos: NDArray[np.float64],
    zf: NDArray[np.float64],
    window: NDArray[np.float64],
    counters: NDArray[np.int64],
    state: NDArray[np.float64],
    consts: NDArray[np.float64],
    displacement: float,
    velocity: float,
    acceleration: float,
    measured: float,
) -> float:  # pragma: no cover - compiled; covered through the cross-check with the Python path
    """One ATS step; returns the command [m] (module docstring for the arrays).

    Parameters
    ----------
    sos, zf, window, counters, state, consts
        The compensator's arrays (module docstring); ``zf``, ``window``, ``counters`` and
        ``state`` are updated in place.
    displacement, velocity, acceleration
        The target for the end of the step [m, m/s, m/s^2].
    measured
        The latest measured displacement [m].
    """
    u_prev, y = state[3], measured
    if consts[3] != 0.0:
        u_prev, y = _filter(sos, zf[0], u_prev), _filter(sos, zf[1], y)
    n = window.shape[1]
    i = counters[0]
    window[0, i], window[1, i] = u_prev, y
    counters[0] = (i + 1) % n
    counters[1] += 1
    count, every = counters[1], int(consts[4])
    if count >= n and count % every == 0:
        if _identify(window, counters[0], state, consts):
            counters[2] += 1
    u = state[0] * displacement + state[1] * velocity + state[2] * acceleration
    state[3] = u
    return u
