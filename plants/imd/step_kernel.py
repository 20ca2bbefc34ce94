"""The IMD models' whole loop step compiled with numba, for the loop's fused kernel.

:meth:`plants.imd.models.InternalStiffnessIMD.compiled_step` and
:meth:`plants.imd.models.SimplifiedIMD.compiled_step` pack a model into the two arrays below
(:class:`rths.core.compiled.CompiledStep`); :func:`imd_step` is then ``Specimen.step`` with the
model's ``_step_impl`` -- the sub-step count, the flywheel (:func:`advance_flywheel_jit`), the
friction, the online amplitude estimate (:mod:`plants.imd.amplitude`) and the damping law (S0
Eq.18) -- as the same operations in the same order, so it agrees with the Python path bit for
bit (``tests/test_fastpath.py``).  Where the Python path would raise (a non-finite drive or
force, a drive beyond ``-l_f``) :func:`imd_step` returns False instead and leaves the step to it.

Layouts
-------
``c`` (constants, :data:`CONSTANTS`) and ``s`` (state, :data:`STATE`), float64.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

from plants.imd.kernels import advance_flywheel_jit
from rths.core.compiled import CompiledStep

__all__ = ["CONSTANTS", "STATE", "imd_channels", "imd_step", "pack"]

#: Constants: 1.0 for the series model (else the simplified one), ``m_e`` [kg], ``k0`` [N/m],
#: ``l_f`` [m] (<= 0: constant), ``h_d/2`` [m], friction ``F_r`` [N], ``v_eps`` [m/s], largest
#: phase per sub-step [rad], 1.0 with a damping law, the law's ``k0`` [N/m], ``c1``, ``c2`` [mm],
#: small amplitude [mm], small-amplitude ratio, reversal tolerance [m] and fraction.
CONSTANTS = (
    "series", "m", "k0", "lf", "half_gap", "friction", "v_eps", "max_phase", "law", "law_k0",
    "c1", "c2", "small_mm", "small_ratio", "tolerance", "fraction",
)  # fmt: skip
#: State: flywheel ``x`` [m], ``x'`` [m/s], last drive ``u`` [m], ``v`` [m/s], ``a`` [m/s^2],
#: spring force [N], force [N], ``c_d`` [N s/m], the cached sub-step key ``(dt, c_d)`` and count,
#: the amplitude tracker (amplitude [m], direction, extremum [m], last turn [m], 1.0 once there
#: is one) and the step count.
STATE = (
    "x", "w", "u", "v", "a", "spring", "force", "damping", "key_dt", "key_cd", "count",
    "amplitude", "direction", "extremum", "last_turn", "has_turn", "steps",
)  # fmt: skip


def pack(model: Any, series: bool) -> CompiledStep:
    """The compiled step of an IMD model (its attributes exported; ``commit`` writes back).

    Parameters
    ----------
    model
        A :class:`plants.imd.models.InternalStiffnessIMD` (``series``) or
        :class:`plants.imd.models.SimplifiedIMD`.
    series
        Which of the two.
    """
    p = model.parameters
    law, tracker = p.damping_law, model._tracker
    c = np.zeros(len(CONSTANTS))
    c[0], c[1] = float(series), p.inertance
    c[5], c[6] = model._friction, model._v_eps
    if series:
        c[2], c[3], c[4], c[7] = model._k0, model._lf, model._half_gap, model.max_step_phase
    if law is not None:
        c[8], c[9] = 1.0, float(p.stiffness)
        c[10], c[11] = law.c1, law.c2
        c[12], c[13] = law.small_amplitude_mm, law.small_amplitude_ratio
        c[14], c[15] = tracker.tolerance, tracker.fraction
    s = np.zeros(len(STATE))
    if series:
        s[0:7] = model._x, model._w, model._u, model._v, model._a, model._spring, model._force
        s[8], s[9] = model._substep_key
        s[10] = model._substep_count
    s[7] = model._damping
    if tracker is not None:
        s[11], s[12], s[13] = tracker.amplitude, tracker._direction, tracker._extremum
        if tracker._last_turn is not None:
            s[14], s[15] = tracker._last_turn, 1.0
    s[16] = model._steps

    def commit() -> None:
        if series:
            model._x, model._w, model._u, model._v, model._a = s[0:5].tolist()
            model._spring, model._force = float(s[5]), float(s[6])
            model._substep_key = (float(s[8]), float(s[9]))
            model._substep_count = int(s[10])
        model._damping = float(s[7])
        if tracker is not None:
            tracker.amplitude, tracker._extremum = float(s[11]), float(s[13])
            tracker._direction = int(s[12])
            tracker._last_turn = float(s[14]) if s[15] else None
        model._steps = int(s[16])

    return CompiledStep("imd_internal" if series else "imd_simplified", (c,), (s,), commit)


@njit(cache=True)
def _observe(c: NDArray[np.float64], s: NDArray[np.float64], u: float) -> None:
    """``_DampingMixin._observe_drive``: the amplitude tracker, then S0 Eq.18 at a reversal."""
    if c[8] == 0.0:
        return
    tol = max(c[14], c[15] * s[11])
    direction = s[12]
    if direction == 0.0:
        if abs(u - s[13]) > tol:
            s[12] = 1.0 if u > s[13] else -1.0
            s[13] = u
        return
    if (u - s[13]) * direction >= 0.0:
        s[13] = u
        return
    if abs(u - s[13]) <= tol:
        return
    turn = s[13]
    s[12] = -direction
    s[13] = u
    had, previous = s[15], s[14]
    s[14], s[15] = turn, 1.0
    if had == 0.0:
        return
    s[11] = 0.5 * abs(turn - previous)
    mm = 1e3 * s[11]
    ratio = c[13] if mm <= c[12] else c[10] / (mm + c[11])
    s[7] = 2.0 * ratio * math.sqrt(c[9] * c[1])


@njit(cache=True)
def _substeps(c: NDArray[np.float64], damping: float, dt: float, k: float) -> int:
    rate = max(math.sqrt(k / c[1]), damping / c[1])
    return max(1, math.ceil(rate * dt / c[7]))


@njit(cache=True)
def imd_step(
    c: NDArray[np.float64], s: NDArray[np.float64], u: float, v: float, a: float, dt: float
) -> bool:  # pragma: no cover - compiled; covered through the cross-check with the Python path
    """One ``Specimen.step(u, v, a, dt)``; False (nothing changed) where Python would raise.

    Parameters
    ----------
    c, s
        :data:`CONSTANTS` and :data:`STATE`.
    u, v, a
        Drive displacement [m], velocity [m/s], acceleration [m/s^2] at the end of the step.
    dt
        Step [s].
    """
    if not math.isfinite(u + v + a):
        return False
    m, damping = c[1], s[7]
    if c[0] == 0.0:  # SimplifiedIMD
        force = m * a + damping * v
        if c[5] > 0.0:
            force += c[5] * math.tanh(v / c[6])
        if not math.isfinite(force):
            return False
        s[6] = force  # (scratch for the simplified model: not one of its attributes)
        _observe(c, s, u)
        s[16] += 1.0
        return True
    k0, lf = c[2], c[3]
    if lf > 0.0:
        low = min(s[2], u)
        if low <= -lf:
            return False
        n_sub = _substeps(c, damping, dt, k0 * lf / (lf + low))
    else:
        if dt != s[8] or damping != s[9]:
            n_sub = _substeps(c, damping, dt, k0)
        else:
            n_sub = int(s[10])
    x, w, spring = advance_flywheel_jit(
        s[0], s[1], s[2], s[3], u, v, dt, n_sub, m, damping, k0, lf, c[4]
    )
    force = spring
    if c[5] > 0.0:
        force += c[5] * math.tanh(v / c[6])
    if not math.isfinite(force):
        return False
    if lf <= 0.0:
        s[8], s[9], s[10] = dt, damping, n_sub
    s[0], s[1], s[5], s[6] = x, w, spring, force
    s[2], s[3], s[4] = u, v, a
    _observe(c, s, u)
    s[16] += 1.0
    return True


@njit(cache=True)
def imd_channels(
    c: NDArray[np.float64], s: NDArray[np.float64], out: NDArray[np.float64]
) -> None:  # pragma: no cover - compiled; covered through the cross-check with the Python path
    """The model's ``write_channels`` (9 values for the series model, else 2) into ``out``."""
    if c[0] == 0.0:
        out[0], out[1] = s[7], s[11]
        return
    m, k0, lf, half_gap = c[1], c[2], c[3], c[4]
    out[0], out[1], out[2] = s[0], s[1], s[5]
    out[3] = s[6] - s[5]
    out[4] = s[5] - m * s[4] - s[7] * s[3]
    out[5] = 1.0 if half_gap > 0.0 and abs(s[2] - s[0]) <= half_gap else 0.0
    out[6] = k0 if lf <= 0.0 else k0 * lf / (lf + s[2])
    out[7], out[8] = s[7], s[11]
