"""The inner loop of the IMD models with a series element (internal stiffness and/or backlash).

One function, :func:`advance_flywheel`, integrates the flywheel over one drive interval; it is
plain Python on floats so that the same source is both the readable reference and, compiled with
``numba.njit``, the fast path (:data:`advance_flywheel_jit`).  Tests check the two agree.

Model (S0 Eq.12 as intended, with Eq.4 and a backlash dead zone in series, cf. S1 Eq.11)::

    delta   = u_d - x_i                                    relative deflection [m]
    stretch = deadzone(delta, g) = delta - g*sign(delta) if |delta| > g else 0
    F_s     = k_e(u_d) * stretch,   k_e = k0 l_f/(l_f + u_d)  (or k0 when l_f <= 0)
    m_e x_i'' + c_d x_i' = F_s                             flywheel (coasts when F_s = 0)

Integration: classical fourth-order Runge-Kutta with ``n_sub`` equal sub-steps; the drive
``u_d(t)`` between the two drive states is the cubic Hermite interpolant of ``(u0, v0)`` and
``(u1, v1)``, which is exact for cubic motion and O(dt^4) otherwise.  The force is continuous in
the state, so RK4 stays fourth order away from gap edges and second order across one.
"""

from __future__ import annotations

import math

from numba import njit

__all__ = ["advance_flywheel", "advance_flywheel_jit", "regularised_sign"]


def regularised_sign(velocity: float, velocity_scale: float) -> float:
    """``tanh(v/v_eps)``: a smooth stand-in for ``sign(v)`` in Coulomb friction [-].

    Used for the friction term ``F_r sign(u')`` of S0 Eq.1.

    Parameters
    ----------
    velocity : float
        Velocity ``v`` [m/s] whose sign is wanted.
    velocity_scale : float
        Regularisation velocity ``v_eps`` [m/s], > 0 (not checked here: this is the hot path;
        ``IMDParameters.friction_velocity`` validates it): below it the friction acts like a
        viscous damper of coefficient ``F_r / v_eps``.

    Returns
    -------
    float
        ``tanh(v / v_eps)`` in ``(-1, 1)`` [-].
    """
    return math.tanh(velocity / velocity_scale)


def advance_flywheel(
    x: float,
    w: float,
    u0: float,
    v0: float,
    u1: float,
    v1: float,
    dt: float,
    n_sub: int,
    inertance: float,
    damping: float,
    stiffness: float,
    free_length: float,
    half_gap: float,
) -> tuple[float, float, float]:
    """Advance the flywheel over one drive interval.

    Parameters
    ----------
    x, w
        Flywheel displacement ``x_i`` [m] and velocity [m/s] at the start of the interval.
    u0, v0, u1, v1
        Drive displacement [m] and velocity [m/s] at the start and end of the interval.
    dt
        Interval length [s].
    n_sub
        Number of equal RK4 sub-steps.
    inertance, damping, stiffness
        ``m_e`` [kg], ``c_d`` [N s/m] (on the flywheel, S0 Eq.12), ``k0`` [N/m].
    free_length
        ``l_f`` [m] of S0 Eq.4; ``<= 0`` means constant stiffness.
    half_gap
        Half the backlash clearance, ``h_d/2`` [m]; 0 for none.

    Returns
    -------
    tuple of float
        ``(x, w, F_s)`` at the end of the interval; ``F_s`` [N] is the force through the series
        spring (the restoring force without friction).
    """

    def spring_force(xi: float, u: float) -> float:
        delta = u - xi
        if delta > half_gap:
            stretch = delta - half_gap
        elif delta < -half_gap:
            stretch = delta + half_gap
        else:
            return 0.0
        if free_length > 0.0:
            return stiffness * free_length / (free_length + u) * stretch
        return stiffness * stretch

    def drive(s: float) -> float:
        s2 = s * s
        s3 = s2 * s
        return (
            (2.0 * s3 - 3.0 * s2 + 1.0) * u0
            + (s3 - 2.0 * s2 + s) * dt * v0
            + (3.0 * s2 - 2.0 * s3) * u1
            + (s3 - s2) * dt * v1
        )

    def acceleration(xi: float, wi: float, u: float) -> float:
        return (spring_force(xi, u) - damping * wi) / inertance

    h = dt / n_sub
    for i in range(n_sub):
        ua = drive(i / n_sub)
        um = drive((i + 0.5) / n_sub)
        ub = drive((i + 1.0) / n_sub)
        k1x = w
        k1w = acceleration(x, w, ua)
        k2x = w + 0.5 * h * k1w
        k2w = acceleration(x + 0.5 * h * k1x, k2x, um)
        k3x = w + 0.5 * h * k2w
        k3w = acceleration(x + 0.5 * h * k2x, k3x, um)
        k4x = w + h * k3w
        k4w = acceleration(x + h * k3x, k4x, ub)
        x += h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x)
        w += h / 6.0 * (k1w + 2.0 * k2w + 2.0 * k3w + k4w)
    return x, w, spring_force(x, u1)


#: :func:`advance_flywheel` compiled with numba (same source, same results to round-off).
advance_flywheel_jit = njit(cache=True)(advance_flywheel)
