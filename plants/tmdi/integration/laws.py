"""Constitutive laws of the S1 plants as compiled functions (numba; private): the HDRB springs and
amplitude-dependent dashpots (S1 Eq.8), the inerter's torque across its backlash gap and its
regularised rack friction (S1 Eq.9-11), the accelerations from equilibrium (S1 Eq.12) and the cubic
Hermite drive.  The unknowns, contact modes and scheme are described in
:mod:`plants.tmdi.integration.kernel`, which integrates them.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from plants.tmdi.integration.layout import (
    FORWARD,
    LAW_AHI,
    LAW_ALO,
    LAW_C0,
    LAW_N,
    LAW_TOL,
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
    S_U_I,
    S_U_T,
    S_V_I,
    S_V_T,
    TRK_DC,
    TRK_DIR,
    TRK_EXT,
    TRK_SEEN,
    TRK_TURN,
)


@njit(cache=True, error_model="numpy")
def hermite(u0: float, v0: float, u1: float, v1: float, dt: float, s: float) -> tuple:
    """Cubic Hermite interpolant of (u, v) over ``[0, dt]`` at the fraction ``s``: (u, v)."""
    s2 = s * s
    s3 = s2 * s
    u = (
        (2.0 * s3 - 3.0 * s2 + 1.0) * u0
        + (s3 - 2.0 * s2 + s) * dt * v0
        + (-2.0 * s3 + 3.0 * s2) * u1
        + (s3 - s2) * dt * v1
    )
    v = (
        (6.0 * s2 - 6.0 * s) * (u0 - u1) / dt
        + (3.0 * s2 - 4.0 * s + 1.0) * v0
        + (3.0 * s2 - 2.0 * s) * v1
    )
    return u, v


@njit(cache=True, error_model="numpy")
def spring(u: float, k1: float, k2: float, k3: float) -> tuple:
    """HDRB spring S1 Eq.8: force and tangent stiffness."""
    au = abs(u)
    return k1 * u + k2 * u * au + k3 * u * u * u, k1 + 2.0 * k2 * au + 3.0 * k3 * u * u


@njit(cache=True, error_model="numpy")
def dashpots(s: np.ndarray, p: np.ndarray) -> tuple:
    """Current dashpot coefficients ``(c_I, c_T)`` [N s/m] of the two HDRBs (S1 Eq.8)."""
    return (
        p[P_LAW_I + LAW_C0] * (1.0 + s[S_AMP_I + TRK_DC]),
        p[P_LAW_T + LAW_C0] * (1.0 + s[S_AMP_T + TRK_DC]),
    )


@njit(cache=True, error_model="numpy")
def track_amplitude(s: np.ndarray, block: int, u: float, p: np.ndarray, law: int) -> None:
    """Feed the deformation ``u`` [m] to the amplitude estimate at state ``block`` and update
    the dashpot of the damping law at parameter block ``law``.

    The rule of :class:`plants.imd.amplitude.AmplitudeTracker`: a reversal is a retreat of
    more than the tolerance from the running extremum; the amplitude is half the distance
    between the last two reversals (0 until two have been seen).  At each new amplitude ``A``
    the dashpot ratio ``c(A)/c(A_lo) = (clip(A, A_lo, A_hi)/A_lo)**(-n)`` is stored.
    """
    direction = s[block + TRK_DIR]
    extremum = s[block + TRK_EXT]
    if direction == 0.0:
        if abs(u - extremum) > p[law + LAW_TOL]:
            s[block + TRK_DIR] = 1.0 if u > extremum else -1.0
            s[block + TRK_EXT] = u
        return
    if (u - extremum) * direction >= 0.0:
        s[block + TRK_EXT] = u
        return
    if abs(u - extremum) <= p[law + LAW_TOL]:
        return
    s[block + TRK_DIR] = -direction
    s[block + TRK_EXT] = u
    if s[block + TRK_SEEN] != 0.0:
        amplitude = 0.5 * abs(extremum - s[block + TRK_TURN])
        s[block] = amplitude
        a = min(max(amplitude, p[law + LAW_ALO]), p[law + LAW_AHI])
        s[block + TRK_DC] = (a / p[law + LAW_ALO]) ** (-p[law + LAW_N]) - 1.0
    s[block + TRK_TURN] = extremum
    s[block + TRK_SEEN] = 1.0


@njit(cache=True, error_model="numpy")
def gap_offset(mode: int, p: np.ndarray) -> float:
    """Gap angle [rad] at contact in ``mode``: ``ε1`` forward, ``-ε2`` backward (S1 Eq.9-11)."""
    return p[P_EPS1] if mode == FORWARD else -p[P_EPS2]


@njit(cache=True, error_model="numpy")
def torque(s: np.ndarray, mode: int, p: np.ndarray) -> float:
    """Torque [N m] transmitted through the gap to the flywheel (0 while open), S1 Eq.9/11."""
    if mode == OPEN or p[P_RACK] == 0.0:
        return 0.0
    r = p[P_R]
    return p[P_KS] * (s[S_U_T] / r - s[S_TH_G] - gap_offset(mode, p)) + p[P_CS] * (
        s[S_V_T] / r - s[S_OM_G]
    )


@njit(cache=True, error_model="numpy")
def friction(v_t: float, p: np.ndarray) -> float:
    """Regularised Coulomb friction of the rack ``f_y tanh(v/v_eps)`` [N], S1 Eq.10."""
    if p[P_RACK] == 0.0 or p[P_FY] == 0.0:
        return 0.0
    return p[P_FY] * math.tanh(v_t / p[P_VEPS])


@njit(cache=True, error_model="numpy")
def accelerations(s: np.ndarray, ag: float, f_ext: float, p: np.ndarray) -> tuple:
    """Accelerations (a_I, a_T, α_G) from equilibrium (S1 Eq.12) at the state ``s``."""
    mode = int(s[S_MODE])
    c_i, c_t = dashpots(s, p)
    f_i = spring(s[S_U_I], p[P_K1_I], p[P_K2_I], p[P_K3_I])[0] + c_i * s[S_V_I]
    f_t = spring(s[S_U_T] - s[S_U_I], p[P_K1_T], p[P_K2_T], p[P_K3_T])[0] + c_t * (
        s[S_V_T] - s[S_V_I]
    )
    a_i = (-p[P_M_I] * ag - f_i + f_t) / p[P_M_I]
    m_t = p[P_M_T] + p[P_B]
    a_t = 0.0
    tq = torque(s, mode, p)
    if m_t > 0.0:
        f_rack = 0.0
        if p[P_RACK] != 0.0:
            f_rack = friction(s[S_V_T], p) + tq / p[P_R]
        f_rack += p[P_C_G] * s[S_V_T]
        a_t = (-p[P_M_T] * ag - f_t - f_rack - f_ext) / m_t
    alpha = 0.0
    if p[P_RACK] != 0.0:
        alpha = (tq - p[P_CB] * s[S_OM_G]) / p[P_J]
    return a_i, a_t, alpha
