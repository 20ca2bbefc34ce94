"""Fixed-step integration kernel shared by the S1 plants (numba; private); the constitutive laws
it integrates are :mod:`plants.tmdi.integration.laws`.

One kernel integrates the TMDI structure of S1 Eq.12 together with the rack-and-pinion inerter of
S1 Eq.9-11, or the inerter alone with the rack displacement prescribed (the specimen), so the
inerter physics exists once.

Unknowns and state
------------------
Degrees of freedom ``x = [u_I, u_T, θ_G]`` (primary and secondary displacement relative to the
ground [m], flywheel angle [rad]) with velocities ``[v_I, v_T, ω_G]``, plus the massless node
angle ``θ_S`` [rad] between the series visco-elastic element and the backlash gap, and the contact
mode of the gap ``g = θ_S - θ_G ∈ [-ε2, ε1]``:

* ``OPEN`` (0): no torque crosses the gap (``T = 0``); the node relaxes,
  ``k_S(θ_P - θ_S) + c_S(θ̇_P - θ̇_S) = 0`` (time constant ``c_S/k_S``), and the flywheel
  coasts, ``J_B ω̇ = -c_B ω``.
* ``FORWARD`` (+1): ``g = ε1``, the node pushes the flywheel forward, ``T >= 0``.
* ``BACKWARD`` (-1): ``g = -ε2``, ``T <= 0``.

In contact ``T = k_S(θ_P - θ_G - δ) + c_S(θ̇_P - ω_G)`` with ``δ = ε1`` or ``-ε2`` and
``J_B ω̇_G + c_B ω_G = T``; the rack feels ``F_B = f_y tanh(v_T / v_eps) + T / r_P``.

Each HDRB (S1 Eq.8) may carry an amplitude-dependent dashpot ``c(A)``
(:class:`plants.tmdi.hdrb.AmplitudeDamping`); its amplitude estimate (half the distance between the
last two reversals of the bearing deformation ``u_I`` or ``u_TI``) and the dashpot it implies
live in the state and are updated once per loop step, after the step (:func:`track_amplitude`),
so ``c`` is constant within a step and the Newton iteration is unchanged.  The state stores
``c/c(A_lo) - 1``, so the all-zero state is the rest state with the small-amplitude dashpot and
reading ``c`` costs one multiplication.

Between ``u_T`` and the ground the secondary DOF may also carry a rigid inertance ``b`` [kg] (the
ideal inerter of :class:`plants.tmdi.structure.TMDIStructure`, or the nominal device of
:class:`plants.tmdi.structure.TMDISubstructure`) and a viscous ``c_G`` [N s/m] (nominal device
only); both join the implicit system, adding ``b ü_T + c_G u̇_T`` to ``F_B``.

Scheme
------
Trapezoidal rule (Newmark average acceleration, ``γ = 1/2, β = 1/4``) on every DOF with full
Newton iterations on the nonlinear HDRB springs and the regularised friction.  The start-of-step
accelerations are recomputed from equilibrium, so the force discontinuities of contact switches
and of a zero-order-held interface force do not pollute the next step.  Each loop step is cut into
``n_sub`` equal sub-steps; inside a sub-step a mode change is located by linear interpolation of
the gap (open → contact) or of the torque (contact → open), the sub-step is split there and
continued in the new mode.  With the rack prescribed (specimen use), the drive between loop samples
is the cubic Hermite interpolant of ``(u, v)``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from plants.tmdi.integration.laws import (
    accelerations,
    dashpots,
    friction,
    gap_offset,
    hermite,
    spring,
    torque,
    track_amplitude,
)
from plants.tmdi.integration.layout import (
    BACKWARD,
    FORWARD,
    I_AG0,
    I_AG1,
    I_DRIVEN,
    I_FEXT,
    I_U0,
    I_U1,
    I_V0,
    I_V1,
    N_INPUT,
    N_OUTPUT,
    N_STATE,
    O_A_I_TOT,
    O_A_T,
    O_A_T_TOT,
    O_C_I,
    O_C_T,
    O_F_B,
    O_F_I,
    O_F_T,
    O_MODE,
    O_OM_G,
    O_TH_G,
    O_TH_S,
    O_TORQUE,
    O_U_I,
    O_U_T,
    O_U_TI,
    O_V_I,
    O_V_T,
    OPEN,
    P_B,
    P_C_G,
    P_CB,
    P_CS,
    P_EPS1,
    P_EPS2,
    P_FY,
    P_J,
    P_K1_I,
    P_K1_T,
    P_K2_I,
    P_K2_T,
    P_K3_I,
    P_K3_T,
    P_KS,
    P_LAW_I,
    P_LAW_T,
    P_M_I,
    P_M_T,
    P_R,
    P_RACK,
    P_VEPS,
    S_AMP_I,
    S_AMP_T,
    S_MODE,
    S_OM_G,
    S_TH_G,
    S_TH_S,
    S_U_I,
    S_U_T,
    S_V_I,
    S_V_T,
)
from rths.core.errors import RTHSError

MAX_EVENTS = 8  # mode changes resolved per sub-step before falling back to projection
MAX_NEWTON = 30
NEWTON_TOL = 1e-13  # [m] displacement increment (flywheel angle scaled by r_P)
GAP_TOL = 1e-13  # [rad] penetration tolerated before a contact event is declared


class IntegrationError(RTHSError, ArithmeticError):
    """An implicit step did not converge (non-finite input or a non-monotonic spring)."""


@njit(cache=True, error_model="numpy")
def _solve3(a: np.ndarray, b: np.ndarray) -> None:
    """Solve the symmetric positive definite 3x3 system ``a x = b`` in place (x in ``b``)."""
    for k in range(3):
        for i in range(k + 1, 3):
            f = a[i, k] / a[k, k]
            for j in range(k, 3):
                a[i, j] -= f * a[k, j]
            b[i] -= f * b[k]
    for k in range(2, -1, -1):
        acc = b[k]
        for j in range(k + 1, 3):
            acc -= a[k, j] * b[j]
        b[k] = acc / a[k, k]


@njit(cache=True, error_model="numpy")
def _advance(
    s0: np.ndarray,
    s1: np.ndarray,
    mode: int,
    sig0: float,
    sig1: float,
    dt: float,
    inp: np.ndarray,
    p: np.ndarray,
    work: np.ndarray,
) -> bool:
    """Trapezoidal step of the given contact mode from ``s0`` (loop-step fraction ``sig0``) to
    ``s1`` (fraction ``sig1``); ``work`` is a ``(7, 3)`` scratch array.  Returns False if Newton
    did not converge."""
    h = (sig1 - sig0) * dt
    for k in range(N_STATE):
        s1[k] = s0[k]
    s1[S_MODE] = mode
    if h <= 0.0:
        return True
    driven = inp[I_DRIVEN] != 0.0
    rack = p[P_RACK] != 0.0
    contact = rack and mode != OPEN
    has_t = (p[P_M_T] + p[P_B]) > 0.0
    ag1 = inp[I_AG0] + sig1 * (inp[I_AG1] - inp[I_AG0])
    ag0 = inp[I_AG0] + sig0 * (inp[I_AG1] - inp[I_AG0])
    f_ext = inp[I_FEXT]
    r = p[P_R]
    a0 = accelerations(s0, ag0, f_ext, p)
    x0 = (s0[S_U_I], s0[S_U_T], s0[S_TH_G])
    v0 = (s0[S_V_I], s0[S_V_T], s0[S_OM_G])
    x, v, a, res, jac = work[0], work[1], work[2], work[3], work[4:7]
    for k in range(3):
        x[k] = x0[k] + h * v0[k] + 0.5 * h * h * a0[k]
    u_drv, v_drv = 0.0, 0.0
    if driven:
        u_drv, v_drv = hermite(inp[I_U0], inp[I_V0], inp[I_U1], inp[I_V1], dt, sig1)
        x[0] = 0.0
        x[1] = u_drv
    ci, mi = 2.0 / h, 4.0 / (h * h)
    c_i, c_t = dashpots(s0, p)  # the amplitude estimates change only between loop steps
    delta = gap_offset(mode, p) if contact else 0.0
    ok = False
    for _ in range(MAX_NEWTON):
        for k in range(3):
            v[k] = ci * (x[k] - x0[k]) - v0[k]
            a[k] = mi * (x[k] - x0[k]) - 2.0 * ci * v0[k] - a0[k]
        if driven:
            v[1] = v_drv
        f_ei, k_i = spring(x[0], p[P_K1_I], p[P_K2_I], p[P_K3_I])
        f_et, k_t = spring(x[1] - x[0], p[P_K1_T], p[P_K2_T], p[P_K3_T])
        f_i = f_ei + c_i * v[0]
        f_t = f_et + c_t * (v[1] - v[0])
        tq, dfric = 0.0, 0.0
        f_rack = 0.0
        if rack:
            th = math.tanh(v[1] / p[P_VEPS])
            dfric = p[P_FY] / p[P_VEPS] * (1.0 - th * th)
            if contact:
                tq = p[P_KS] * (x[1] / r - x[2] - delta) + p[P_CS] * (v[1] / r - v[2])
            f_rack = p[P_FY] * th + tq / r
        res[0] = p[P_M_I] * (a[0] + ag1) + f_i - f_t
        res[1] = p[P_M_T] * (a[1] + ag1) + p[P_B] * a[1] + f_t + f_rack + f_ext
        res[1] += p[P_C_G] * v[1]
        jac[0, 0] = p[P_M_I] * mi + (c_i + c_t) * ci + k_i + k_t
        jac[0, 1] = jac[1, 0] = -c_t * ci - k_t
        jac[1, 1] = (p[P_M_T] + p[P_B]) * mi + (c_t + p[P_C_G]) * ci + k_t + dfric * ci
        jac[0, 2] = jac[2, 0] = 0.0
        if rack:
            res[2] = p[P_J] * a[2] + p[P_CB] * v[2] - tq
            jac[2, 2] = p[P_J] * mi + p[P_CB] * ci
            jac[1, 2] = jac[2, 1] = 0.0
            if contact:
                jac[1, 1] += (p[P_CS] * ci + p[P_KS]) / (r * r)
                jac[1, 2] = jac[2, 1] = -(p[P_CS] * ci + p[P_KS]) / r
                jac[2, 2] += p[P_CS] * ci + p[P_KS]
        else:
            res[2] = 0.0
            jac[2, 2] = 1.0
            jac[1, 2] = jac[2, 1] = 0.0
        if driven or not has_t:  # u_T prescribed (or absent): freeze its row and column
            res[1] = 0.0
            jac[1, 0] = jac[0, 1] = jac[1, 2] = jac[2, 1] = 0.0
            jac[1, 1] = 1.0
        if driven:  # u_I is irrelevant for the specimen alone
            res[0] = 0.0
            jac[0, 0] = 1.0
            jac[0, 1] = jac[1, 0] = 0.0
        _solve3(jac, res)
        incr = max(abs(res[0]), abs(res[1]), abs(res[2]) * (r if rack else 1.0))
        for k in range(3):
            x[k] -= res[k]
        if incr <= NEWTON_TOL:
            ok = True
            break
    s1[S_U_I] = x[0]
    s1[S_U_T] = x[1]
    s1[S_TH_G] = x[2]
    s1[S_V_I] = ci * (x[0] - x0[0]) - v0[0]
    s1[S_V_T] = v_drv if driven else ci * (x[1] - x0[1]) - v0[1]
    s1[S_OM_G] = ci * (x[2] - x0[2]) - v0[2]
    if not rack:
        return ok
    if contact:
        s1[S_TH_S] = x[2] + delta
    elif p[P_CS] == 0.0:
        s1[S_TH_S] = x[1] / r
    else:  # open gap: k_S(θ_P-θ_S) + c_S(θ̇_P-θ̇_S) = 0, trapezoidal
        q = 0.5 * h * p[P_KS] / p[P_CS]
        rhs = s0[S_TH_S] + 0.5 * h * (s0[S_V_T] + s1[S_V_T]) / r
        rhs += q * (s0[S_U_T] / r - s0[S_TH_S] + x[1] / r)
        s1[S_TH_S] = rhs / (1.0 + q)
    return ok


@njit(cache=True, error_model="numpy")
def _crossing(y0: float, y1: float, level: float) -> float:
    """Fraction of a segment where the linear interpolant from ``y0`` to ``y1`` meets ``level``
    (0 if ``y0`` is already there or beyond)."""
    if (level - y0) * (y1 - y0) <= 0.0:
        return 0.0
    return min((level - y0) / (y1 - y0), 1.0)


@njit(cache=True, error_model="numpy")
def _event(s0: np.ndarray, s1: np.ndarray, mode: int, p: np.ndarray) -> tuple:
    """(fraction of the segment where the mode changes, new mode); fraction < 0: no change."""
    if p[P_RACK] == 0.0:
        return -1.0, mode
    if mode == OPEN:
        g0 = s0[S_TH_S] - s0[S_TH_G]
        g1 = s1[S_TH_S] - s1[S_TH_G]
        if g1 > p[P_EPS1] + GAP_TOL:
            return _crossing(g0, g1, p[P_EPS1]), FORWARD
        if g1 < -p[P_EPS2] - GAP_TOL:
            return _crossing(g0, g1, -p[P_EPS2]), BACKWARD
        return -1.0, OPEN
    if p[P_EPS1] + p[P_EPS2] <= 0.0:  # no clearance: the gap never opens
        return -1.0, mode
    t1 = torque(s1, mode, p)
    if t1 * mode < 0.0:
        return _crossing(torque(s0, mode, p), t1, 0.0), OPEN
    return -1.0, mode


@njit(cache=True, error_model="numpy")
def _enter(s: np.ndarray, mode: int, p: np.ndarray) -> None:
    s[S_MODE] = mode
    if mode != OPEN:  # the massless node sits on the contact face
        s[S_TH_S] = s[S_TH_G] + gap_offset(mode, p)


@njit(cache=True, error_model="numpy")
def step(s: np.ndarray, dt: float, n_sub: int, inp: np.ndarray, p: np.ndarray) -> int:
    """Advance the state ``s`` in place over one loop step ``dt`` [s] with ``n_sub`` sub-steps.

    Returns the number of segments whose Newton iteration did not converge (0 normally).
    """
    trial = np.empty(N_STATE)
    start = np.empty(N_STATE)
    work = np.empty((7, 3))
    failures = 0
    for j in range(n_sub):
        sig = j / n_sub
        sig_end = (j + 1) / n_sub
        resolved = False
        for _ in range(MAX_EVENTS):
            mode = int(s[S_MODE])
            if not _advance(s, trial, mode, sig, sig_end, dt, inp, p, work):
                failures += 1
            frac, new_mode = _event(s, trial, mode, p)
            if frac < 0.0:
                s[:] = trial
                resolved = True
                break
            sig_ev = sig + frac * (sig_end - sig)
            start[:] = s
            if not _advance(start, s, mode, sig, sig_ev, dt, inp, p, work):
                failures += 1
            _enter(s, new_mode, p)
            sig = sig_ev
            if sig >= sig_end:
                resolved = True
                break
        if not resolved:  # chattering: finish in the current mode and project onto the gap
            mode = int(s[S_MODE])
            if not _advance(s, trial, mode, sig, sig_end, dt, inp, p, work):
                failures += 1
            s[:] = trial
            g = s[S_TH_S] - s[S_TH_G]
            if mode == OPEN and (g > p[P_EPS1] or g < -p[P_EPS2]):
                _enter(s, FORWARD if g > 0.0 else BACKWARD, p)
            elif mode != OPEN and torque(s, mode, p) * mode < 0.0:
                s[S_MODE] = OPEN
    if p[P_LAW_I] != 0.0:
        track_amplitude(s, S_AMP_I, s[S_U_I], p, P_LAW_I)
    if p[P_LAW_T] != 0.0:
        track_amplitude(s, S_AMP_T, s[S_U_T] - s[S_U_I], p, P_LAW_T)
    return failures


@njit(cache=True, error_model="numpy")
def outputs(s: np.ndarray, ag: float, f_ext: float, p: np.ndarray, out: np.ndarray) -> None:
    """S1 Eq.7 response quantities (and internal states) at the state ``s`` into ``out``."""
    a_i, a_t, _ = accelerations(s, ag, f_ext, p)
    mode = int(s[S_MODE])
    u_ti = s[S_U_T] - s[S_U_I]
    out[O_U_I] = s[S_U_I]
    out[O_A_I_TOT] = a_i + ag
    c_i, c_t = dashpots(s, p)
    out[O_F_I] = spring(s[S_U_I], p[P_K1_I], p[P_K2_I], p[P_K3_I])[0] + c_i * s[S_V_I]
    out[O_U_TI] = u_ti
    out[O_A_T_TOT] = a_t + ag
    out[O_F_T] = spring(u_ti, p[P_K1_T], p[P_K2_T], p[P_K3_T])[0] + c_t * (s[S_V_T] - s[S_V_I])
    out[O_U_T] = s[S_U_T]
    out[O_A_T] = a_t
    tq = torque(s, mode, p)
    f_b = p[P_B] * a_t + p[P_C_G] * s[S_V_T] + f_ext
    if p[P_RACK] != 0.0:
        f_b += friction(s[S_V_T], p) + tq / p[P_R]
    out[O_F_B] = f_b
    out[O_V_I] = s[S_V_I]
    out[O_V_T] = s[S_V_T]
    out[O_TH_S] = s[S_TH_S]
    out[O_TH_G] = s[S_TH_G]
    out[O_OM_G] = s[S_OM_G]
    out[O_TORQUE] = tq
    out[O_MODE] = mode
    out[O_C_I] = c_i
    out[O_C_T] = c_t


@njit(cache=True, error_model="numpy")
def simulate(ag: np.ndarray, dt: float, n_sub: int, p: np.ndarray, s: np.ndarray) -> tuple:
    """Run the structure from the state ``s`` through the ground acceleration samples ``ag``.

    Returns (outputs of shape ``(len(ag), N_OUTPUT)``, number of non-converged segments).
    """
    n = ag.size
    out = np.empty((n, N_OUTPUT))
    inp = np.zeros(N_INPUT)
    outputs(s, ag[0], 0.0, p, out[0])
    failures = 0
    for i in range(1, n):
        inp[I_AG0] = ag[i - 1]
        inp[I_AG1] = ag[i]
        failures += step(s, dt, n_sub, inp, p)
        outputs(s, ag[i], 0.0, p, out[i])
    return out, failures
