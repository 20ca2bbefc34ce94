"""Whole-record simulation kernels of the nonlinear candidate effects (numba).

The per-interval integrator is the project's own IMD kernel,
:func:`plants.imd.kernels.advance_flywheel` (S0 Eq.12 with a backlash dead zone in series, RK4
on a Hermite drive), so the candidate is exactly the emulated lab's model; this module only loops
it over a record inside numba, which removes the per-sample Python call (~1 us each).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from plants.imd.kernels import advance_flywheel, advance_flywheel_jit

__all__ = ["series_force_per_mass", "series_force_per_mass_py"]

#: Largest ``omega * dt_sub`` [rad] per RK4 sub-step (as plants.imd.models.MAX_STEP_PHASE).
_MAX_STEP_PHASE = 0.2


def _loop(advance, u, v, dt, damping_per_mass, omega, half_gap):
    """Reference loop (plain Python); :func:`_run_jit` is the same with the numba kernel."""
    n = u.size
    out = np.empty(n)
    stiffness = omega * omega
    rate = max(omega, np.max(damping_per_mass))
    n_sub = max(1, int(math.ceil(rate * dt / _MAX_STEP_PHASE)))
    x = u[0]
    w = v[0]
    out[0] = 0.0
    for i in range(1, n):
        x, w, f = advance(
            x,
            w,
            u[i - 1],
            v[i - 1],
            u[i],
            v[i],
            dt,
            n_sub,
            1.0,
            damping_per_mass[i],
            stiffness,
            0.0,
            half_gap,
        )
        out[i] = f
    return out


@njit(cache=True)
def _run_jit(u, v, dt, damping_per_mass, omega, half_gap):
    n = u.size
    out = np.empty(n)
    stiffness = omega * omega
    rate = max(omega, np.max(damping_per_mass))
    n_sub = max(1, int(math.ceil(rate * dt / _MAX_STEP_PHASE)))
    x = u[0]
    w = v[0]
    out[0] = 0.0
    for i in range(1, n):
        x, w, f = advance_flywheel_jit(
            x,
            w,
            u[i - 1],
            v[i - 1],
            u[i],
            v[i],
            dt,
            n_sub,
            1.0,
            damping_per_mass[i],
            stiffness,
            0.0,
            half_gap,
        )
        out[i] = f
    return out


def _damping_array(damping_per_mass: float | NDArray[np.float64], n: int) -> NDArray:
    d = np.asarray(damping_per_mass, dtype=float)
    return np.ascontiguousarray(np.broadcast_to(d, (n,)) if d.ndim == 0 else d)


def series_force_per_mass(
    u: NDArray[np.float64],
    v: NDArray[np.float64],
    dt: float,
    damping_per_mass: float | NDArray[np.float64],
    omega: float,
    gap: float,
) -> NDArray[np.float64]:
    """Force per unit inertance [m/s^2] through a series spring (+ dead zone) to a flywheel.

    .. math::

        \\ddot x_i + (c/m)\\dot x_i = \\omega^2\\,\\mathrm{dz}(u - x_i, g/2), \\qquad
        F/m = \\omega^2\\,\\mathrm{dz}(u - x_i, g/2)

    (S0 Eq.12 divided by the inertance ``m``, with ``omega^2 = k/m``; the force is linear in
    ``m`` for fixed ``omega``, ``c/m``, ``g``).  The flywheel starts where the drive starts.

    Parameters
    ----------
    u, v
        Drive displacement [m] and velocity [m/s], shape ``(n,)``.
    dt
        Sample period [s].
    damping_per_mass
        ``c/m`` [1/s] on the flywheel: a number, or one value per sample (held over the
        interval ending at it), e.g. an amplitude-dependent damping (S0 Eq.18).
    omega
        ``sqrt(k/m)`` [rad/s] of the series spring.
    gap
        Total clearance [m] (0: internal stiffness only).
    """
    return _run_jit(
        np.ascontiguousarray(u),
        np.ascontiguousarray(v),
        float(dt),
        _damping_array(damping_per_mass, len(u)),
        float(omega),
        0.5 * float(gap),
    )


def series_force_per_mass_py(
    u: NDArray[np.float64],
    v: NDArray[np.float64],
    dt: float,
    damping_per_mass: float | NDArray[np.float64],
    omega: float,
    gap: float,
) -> NDArray[np.float64]:
    """Plain-Python reference of :func:`series_force_per_mass` (same source, no numba)."""
    return _loop(
        advance_flywheel,
        np.asarray(u, float),
        np.asarray(v, float),
        float(dt),
        _damping_array(damping_per_mass, len(u)),
        float(omega),
        0.5 * float(gap),
    )
