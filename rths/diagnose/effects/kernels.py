"""Whole-record simulation kernels of the effects (numba).

``loop_rate_limited``
    A motion whose speed a servo loop's flow limit caps (the actuator's ``rate_limit``): the
    output follows the linear response and recovers a deficit through the loop's pole.

``friction_operator``
    Normalised force ``phi`` in [-1, 1] of a friction element driven by a displacement: a
    presliding spring that saturates at the friction level (elasto-plastic, Prandtl's stop
    operator of yield displacement ``delta``), optionally behind a clearance ``gap`` (a dead
    zone: the element is unloaded while the clearance is crossed).  Rate independent and exact
    per sample; the force is ``F_c phi``.
``reversal_amplitude``
    The load amplitude of a cyclic test read per half cycle: half the excursion between the
    drive's last two reversals, a reversal being a retreat from the running extremum by more
    than a hysteresis (an absolute floor and a share of the current amplitude, so that noise
    and small ripples on a large motion do not count as load reversals).  Piecewise constant,
    0 until two reversals.
``series_chain``
    Force per unit inertance of a drive -> [clearance] -> Kelvin-Voigt element -> body chain:
    the body (inertance ``m``) carries a viscous damping (per sample, e.g. amplitude
    dependent), a spring and an elasto-plastic friction; the element is a series spring with
    its own damping (``gap = 0``: internal stiffness) or a contact of finite stiffness and
    damping after a clearance that only pushes (``gap > 0``: backlash).  The contact law is
    general: ``e = w^2 p`` + ``c_e p'`` for ``n = 1`` (the Kelvin-Voigt element) and
    ``e = (p/p_r)^(n-1) (w^2 p + c_e (p/p_r) p')`` for ``n > 1`` (a Hertz contact for ``n =
    3/2``, Johnson, Contact Mechanics, Eq. 4.23, with Hunt and Crossley's damping, J. Appl.
    Mech. 42 (1975) 440: ``k p^n (1 + alpha p')``, ``alpha = c_e/(w^2 p_r)``, which vanishes
    at first touch) for a penetration ``p > 0``; ``w^2``, ``c_e`` are its stiffness and
    damping per mass at the reference penetration ``p_r``.  Newmark average
    acceleration (trapezoidal rule) with a scalar Newton iteration per sub-step on the
    piecewise-linear forces (return mapping for the friction), the drive interpolated between
    samples by cubic Hermite polynomials.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = [
    "MAX_SUBSTEPS",
    "friction_operator",
    "loop_rate_limited",
    "reversal_amplitude",
    "series_chain",
]

#: Largest ``omega * h`` [rad] per sub-step of the chain (trapezoidal phase error < 2 %).
_MAX_STEP_PHASE = 0.5
#: Cap on the sub-steps per sample.
MAX_SUBSTEPS: int = 48


@njit(cache=True)
def _friction_operator(x, delta, half_gap):  # pragma: no cover - numba
    n = x.size
    out = np.empty(n)
    s = x[0]  # slider position: the element is unloaded at the start
    for i in range(n):
        r = x[i] - s
        reach = half_gap + delta
        if r > reach:
            s = x[i] - reach
            out[i] = 1.0
        elif r < -reach:
            s = x[i] + reach
            out[i] = -1.0
        elif r > half_gap:
            out[i] = (r - half_gap) / delta
        elif r < -half_gap:
            out[i] = (r + half_gap) / delta
        else:
            out[i] = 0.0
    return out


@njit(cache=True)
def _loop_rate_limited(y, decay, max_change):  # pragma: no cover - numba
    out = np.empty_like(y)
    x_prev = 0.0
    y_prev = 0.0
    for i in range(y.size):
        step = (y[i] - y_prev) + (y_prev - x_prev) * decay
        if step > max_change:
            step = max_change
        elif step < -max_change:
            step = -max_change
        x_prev += step
        y_prev = y[i]
        out[i] = x_prev
    return out


def loop_rate_limited(
    y: NDArray[np.float64], pole: float, velocity_limit: float, dt: float
) -> NDArray[np.float64]:
    """The motion [m] of a servo loop whose speed is capped at ``velocity_limit`` [m/s],
    given its linear (unlimited) response ``y`` [m] sampled every ``dt`` [s], shape ``(n,)``.

    The loop's last stage is first order, ``x' = p (z - x)`` (``p`` = ``pole`` [rad/s], the
    servo-valve's flow setting the speed: Merritt, Hydraulic Control Systems, Sec. 8.3), so
    its linear response obeys ``y' = p (z - y)`` and the speed demanded of a lagging piston
    is ``y' + p (y - x)``.  Exact per sample for a linear step, the deficit ``y - x`` decays
    by ``exp(-p dt)``, and the flow limit clips the step::

        x_k = x_{k-1} + clip((y_k - y_{k-1}) + (1 - exp(-p dt)) (y_{k-1} - x_{k-1}),
                             +/- v_max dt)

    ``x = y`` while the limit is idle; ``pole = inf`` is the Simulink rate limiter on the
    output (:func:`plants.lines.rate_limited`), which recovers a deficit within one sample.
    Starts at rest.

    Parameters
    ----------
    y
        Linear response [m], shape ``(n,)``.
    pole
        The loop's pole ``p`` [rad/s], > 0 (``inf``: recovery within a sample).
    velocity_limit
        ``v_max`` [m/s], > 0.
    dt
        Sample period [s], > 0.
    """
    decay = 1.0 - math.exp(-pole * dt) if math.isfinite(pole) else 1.0
    return _loop_rate_limited(np.ascontiguousarray(y, dtype=float), decay, velocity_limit * dt)


def friction_operator(x: NDArray[np.float64], delta: float, gap: float = 0.0) -> NDArray:
    """Normalised elasto-plastic friction force (module docstring), shape ``(n,)``.

    Parameters
    ----------
    x
        Drive displacement [m], shape ``(n,)``.
    delta
        Presliding (yield) displacement ``F_c / k`` [m], > 0.
    gap
        Total clearance [m] before the element (0: none).
    """
    return _friction_operator(np.ascontiguousarray(x, dtype=float), float(delta), 0.5 * gap)


@njit(cache=True)
def _reversal_amplitude(d, floor, share):  # pragma: no cover - numba
    out = np.zeros(d.size)
    amp, direction, extremum, last, turns = 0.0, 0, d[0], 0.0, 0
    for k in range(d.size):
        u = d[k]
        tol = max(floor, share * amp)
        if direction == 0:
            if abs(u - extremum) > tol:
                direction = 1 if u > extremum else -1
                extremum = u
        elif (u - extremum) * direction >= 0.0:
            extremum = u
        elif abs(u - extremum) > tol:
            if turns > 0:
                amp = 0.5 * abs(extremum - last)
            last, turns, direction, extremum = extremum, turns + 1, -direction, u
        out[k] = amp
    return out


def reversal_amplitude(x: NDArray[np.float64], floor: float, share: float) -> NDArray:
    """Half the excursion between the last two reversals of ``x`` [m] (module docstring),
    shape ``(n,)``.

    Parameters
    ----------
    x
        Drive displacement [m], shape ``(n,)``.
    floor
        Absolute hysteresis [m], > 0: a retreat from the running extremum must exceed it.
    share
        Relative hysteresis [-]: the retreat must also exceed ``share`` times the amplitude.
    """
    return _reversal_amplitude(np.ascontiguousarray(x, dtype=float), float(floor), float(share))


@njit(cache=True)
def _element(d, dv, w2, ce, hg, pushes, n, pref):  # pragma: no cover - numba
    """Element force per mass, its derivatives w.r.t. the element's deflection and deflection
    rate, and whether it acts."""
    if d > hg:
        p, sgn = d - hg, 1.0
    elif d < -hg:
        p, sgn = -d - hg, -1.0
    else:
        return 0.0, 0.0, 0.0, False
    if n == 1.0:
        s, ps, q = 1.0, 0.0, 1.0
    else:
        s = (p / pref) ** (n - 1.0)
        ps = (n - 1.0) * s  # p ds/dp
        q = p / pref  # Hunt-Crossley: the damping grows as p^n, like the force
    f = s * (sgn * w2 * p + q * ce * dv)
    if pushes and sgn * f < 0.0:
        return 0.0, 0.0, 0.0, False
    return f, w2 * (s + ps), s * q * ce, True


@njit(cache=True)
def _chain(
    x, v, dt, w2, ce, hg, pushes, damp, kb, fc, kf, n_sub, n_exp, pref
):  # pragma: no cover - numba
    n = x.size
    out = np.empty(n)
    h = dt / n_sub
    xb, vb, ab, ff = x[0], v[0], 0.0, 0.0
    out[0] = 0.0
    for i in range(1, n):
        x0, v0, x1, v1 = x[i - 1], v[i - 1], x[i], v[i]
        c = damp[i]
        f_el = 0.0
        for j in range(1, n_sub + 1):
            s = j / n_sub
            # cubic Hermite drive at the sub-step end
            h00 = 2 * s**3 - 3 * s**2 + 1
            h10 = s**3 - 2 * s**2 + s
            h01 = -2 * s**3 + 3 * s**2
            h11 = s**3 - s**2
            xd = h00 * x0 + h10 * dt * v0 + h01 * x1 + h11 * dt * v1
            dh00 = (6 * s**2 - 6 * s) / dt
            dh10 = 3 * s**2 - 4 * s + 1
            dh01 = (-6 * s**2 + 6 * s) / dt
            dh11 = 3 * s**2 - 2 * s
            vd = dh00 * x0 + dh10 * v0 + dh01 * x1 + dh11 * v1
            # Newton on the body displacement at the sub-step end
            y = xb + h * vb + 0.25 * h * h * ab
            f_new = ff
            for _ in range(30):
                vy = 2.0 * (y - xb) / h - vb
                ay = 4.0 * (y - xb - h * vb) / (h * h) - ab
                fe, kd, cd, _c = _element(xd - y, vd - vy, w2, ce, hg, pushes, n_exp, pref)
                trial = ff + kf * (y - xb)
                if fc > 0.0 and trial > fc:
                    f_new, kt = fc, 0.0
                elif fc > 0.0 and trial < -fc:
                    f_new, kt = -fc, 0.0
                else:
                    f_new, kt = trial, kf
                r = ay + c * vy + kb * y + f_new - fe
                dr = 4.0 / (h * h) + 2.0 * c / h + kb + kt + kd + 2.0 * cd / h
                step = r / dr
                y -= step
                if abs(step) <= 1e-13 * (1.0 + abs(y)):
                    break
            vy = 2.0 * (y - xb) / h - vb
            ay = 4.0 * (y - xb - h * vb) / (h * h) - ab
            trial = ff + kf * (y - xb)
            ff = min(max(trial, -fc), fc) if fc > 0.0 else 0.0
            xb, vb, ab = y, vy, ay
            f_el = _element(xd - y, vd - vy, w2, ce, hg, pushes, n_exp, pref)[0]
        out[i] = f_el
    return out


def series_chain(
    x: NDArray[np.float64],
    v: NDArray[np.float64],
    dt: float,
    *,
    omega: float,
    zeta: float,
    gap: float,
    damping: float | NDArray[np.float64],
    stiffness: float = 0.0,
    friction: float = 0.0,
    presliding: float = 1.0,
    exponent: float = 1.0,
    reference: float = 1.0,
) -> NDArray[np.float64]:
    """Force per unit body inertance [m/s^2] of the series chain (module docstring).

    .. math::

        \\ddot x_b + c\\,\\dot x_b + k\\,x_b + f(x_b) = e, \\qquad
        e = \\omega^2\\,\\mathrm{dz}(x - x_b, g/2) + 2\\zeta\\omega\\,(\\dot x - \\dot x_b)

    (all per unit inertance; ``e`` clipped to push only when ``g > 0``; ``f`` elasto-plastic,
    ``|f| <= F_c/m`` with presliding stiffness ``F_c/(m delta)``).  The body starts at rest
    where the drive starts.

    Parameters
    ----------
    x, v
        Drive displacement [m] and velocity [m/s], shape ``(n,)``.
    dt
        Sample period [s].
    omega
        ``sqrt(k_e/m)`` [rad/s] of the element.
    zeta
        Element damping ratio ``c_e / (2 sqrt(k_e m))`` [-].
    gap
        Total clearance [m] (0: a series spring that also pulls).
    damping
        Body damping per unit inertance ``c/m`` [1/s]: a number or one value per sample.
    stiffness
        Body spring per unit inertance ``k/m`` [1/s^2].
    friction
        Friction level per unit inertance ``F_c/m`` [m/s^2] (0: none).
    presliding
        Presliding displacement ``delta`` [m] of the friction (its stiffness is
        ``F_c/delta``).
    exponent
        Contact-law exponent ``n`` [-] (1: linear; 3/2: Hertz), >= 1; only with ``gap > 0``.
    reference
        Reference penetration ``p_r`` [m] at which ``omega`` and ``zeta`` hold, > 0.
    """
    n = len(x)
    d = np.asarray(damping, dtype=float)
    damp = np.ascontiguousarray(np.broadcast_to(d, (n,)) if d.ndim == 0 else d)
    kf = friction / presliding if friction > 0.0 else 0.0
    rate = max(
        omega, math.sqrt(max(kf, 0.0)), float(np.max(np.abs(damp))), math.sqrt(abs(stiffness))
    )
    if exponent != 1.0:  # the contact stiffens beyond the reference penetration
        rate *= math.sqrt(exponent)
    n_sub = int(min(MAX_SUBSTEPS, max(1, math.ceil(rate * dt / _MAX_STEP_PHASE))))
    return _chain(
        np.ascontiguousarray(x, dtype=float),
        np.ascontiguousarray(v, dtype=float),
        float(dt),
        float(omega * omega),
        float(2.0 * zeta * omega),
        0.5 * float(gap),
        bool(gap > 0.0),
        damp,
        float(stiffness),
        float(friction),
        float(kf),
        n_sub,
        float(exponent) if gap > 0.0 else 1.0,
        float(reference),
    )
