"""Newmark average-acceleration step for a tridiagonal system (private to plants.cable.model).

With ``gamma = 1/2``, ``beta = 1/4`` and a fixed step ``h`` [s] the update from ``(u, v, a)`` at
``t_k`` to ``t_{k+1}`` under the nodal force ``f_{k+1}`` [N] is::

    (K + 2/h C + 4/h^2 M) u1 = f_{k+1} + M (4/h^2 u + 4/h v + a) + C (2/h u + v)
    v1 = 2/h (u1 - u) - v
    a1 = 4/h^2 (u1 - u) - 4/h v - a

The effective matrix is factorised once (banded Cholesky, ``L L^T`` with ``L`` lower
bidiagonal), so a step costs O(N).  :func:`step_reference` is the readable NumPy/SciPy version;
:func:`step_kernel` is the same arithmetic fused into one compiled pass for the real-time loop,
including the condensed flywheel of a series device branch (whose reference arithmetic is
:class:`plants.cable.device.SeriesCondensation`).  Both are tested against each other.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from numba import njit
from numpy.typing import NDArray

from plants.cable.fe import Tridiagonal

__all__ = ["NewmarkOperator", "newmark_operator", "step_kernel", "step_reference"]


@dataclass(frozen=True, slots=True)
class NewmarkOperator:
    """Matrices of one fixed-step Newmark-AA integrator and the factor of its effective matrix.

    Attributes
    ----------
    dt : float
        Time step ``h`` [s].
    mass : Tridiagonal
        Mass matrix ``M`` [kg] over the free nodes (needed for the right-hand side).
    damping : Tridiagonal
        Damping matrix ``C`` [N s/m] over the free nodes.
    factor : numpy.ndarray
        Lower banded Cholesky factor of the effective matrix ``K + 2/h C + 4/h^2 M`` [N/m] in the
        storage of :func:`scipy.linalg.cholesky_banded`, shape ``(2, n)``: row 0 the diagonal,
        row 1 the sub-diagonal (units sqrt(N/m)).
    """

    dt: float
    mass: Tridiagonal
    damping: Tridiagonal
    factor: NDArray[np.float64]


def newmark_operator(
    stiffness: Tridiagonal, mass: Tridiagonal, damping: Tridiagonal, dt: float
) -> NewmarkOperator:
    """Factorise the effective matrix ``K + (2/h) C + (4/h^2) M`` once for step ``dt`` [s].

    Parameters
    ----------
    stiffness : Tridiagonal
        Stiffness ``K`` [N/m] (including any constant added to the damper node's diagonal, e.g.
        a condensed series branch).
    mass : Tridiagonal
        Mass ``M`` [kg].
    damping : Tridiagonal
        Damping ``C`` [N s/m].
    dt : float
        Time step ``h`` [s], > 0 (not checked here; the cable model validates it).

    Raises
    ------
    numpy.linalg.LinAlgError
        If the effective matrix is not positive definite.
    """
    effective = stiffness + damping.scaled(2.0 / dt) + mass.scaled(4.0 / dt**2)
    factor = sla.cholesky_banded(effective.banded_lower(), lower=True)
    return NewmarkOperator(dt, mass, damping, factor)


def step_reference(
    op: NewmarkOperator,
    u: NDArray[np.float64],
    v: NDArray[np.float64],
    a: NDArray[np.float64],
    force: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """One Newmark-AA step with nodal force ``force`` [N] at ``t_{k+1}``; returns ``(u, v, a)``.

    Parameters
    ----------
    op : NewmarkOperator
        The factorised integrator.
    u, v, a : numpy.ndarray
        Nodal displacement [m], velocity [m/s] and acceleration [m/s^2] at ``t_k``, shape
        ``(n,)``.
    force : numpy.ndarray
        Nodal force [N] at ``t_{k+1}``, shape ``(n,)``.

    Returns
    -------
    tuple of numpy.ndarray
        ``(u, v, a)`` at ``t_{k+1}`` [m, m/s, m/s^2], new arrays of shape ``(n,)``.
    """
    h = op.dt
    rhs = force + op.mass.matvec(4.0 / h**2 * u + 4.0 / h * v + a)
    rhs += op.damping.matvec(2.0 / h * u + v)
    u1 = sla.cho_solve_banded((op.factor, True), rhs)
    v1 = 2.0 / h * (u1 - u) - v
    a1 = 4.0 / h**2 * (u1 - u) - 4.0 / h * v - a
    return u1, v1, a1


@njit(cache=True)
def step_kernel(
    m_diag: NDArray[np.float64],
    m_off: NDArray[np.float64],
    c_diag: NDArray[np.float64],
    c_off: NDArray[np.float64],
    l_diag: NDArray[np.float64],
    l_sub: NDArray[np.float64],
    h: float,
    u: NDArray[np.float64],
    v: NDArray[np.float64],
    a: NDArray[np.float64],
    load_shape: NDArray[np.float64],
    load_scale: float,
    index: int,
    point_force: float,
    series: NDArray[np.float64],
    flywheel: NDArray[np.float64],
    u1: NDArray[np.float64],
    v1: NDArray[np.float64],
    a1: NDArray[np.float64],
    flywheel1: NDArray[np.float64],
) -> None:  # pragma: no cover - compiled; covered through the cross-check with step_reference
    """:func:`step_reference` with force ``load_scale*load_shape + point_force*e_index``.

    ``l_diag`` and ``l_sub`` are the factor's diagonal and sub-diagonal.  ``series = (k_s,
    m_s, c_s, D)`` describes a series branch condensed at ``index`` (its ``k_s (1 - k_s/D)``
    must already be in the factor); ``k_s = 0`` means none.  ``flywheel`` is its state ``(x,
    x', x'')`` at ``t_k``.  Writes the new state into ``u1, v1, a1`` and ``flywheel1`` (which
    must not alias the inputs).

    Two passes over the nodes: (1) the right-hand side ``f + M w + C z`` with ``w = c1 u + c2 v
    + a`` and ``z = c3 u + v`` formed on the fly, fused with the forward substitution ``L y =
    rhs`` (``y`` kept in ``a1``); (2) the back substitution ``L^T u1 = y`` fused with the
    velocity and acceleration updates.  The arithmetic of every entry is that of the former
    five-pass kernel, in the same order (bit-identical results), only with fewer passes over
    memory.
    """
    n = u.size
    c1 = 4.0 / (h * h)
    c2 = 4.0 / h
    c3 = 2.0 / h
    k_s = series[0]
    r_x = 0.0  # the flywheel row's right-hand side
    if k_s > 0.0:
        r_x = series[1] * (c1 * flywheel[0] + c2 * flywheel[1] + flywheel[2])
        r_x += series[2] * (c3 * flywheel[0] + flywheel[1])
    w_prev = z_prev = y = 0.0
    w = c1 * u[0] + c2 * v[0] + a[0]
    z = c3 * u[0] + v[0]
    w_next = z_next = 0.0
    for i in range(n):
        r = load_scale * load_shape[i] + m_diag[i] * w + c_diag[i] * z
        if i > 0:
            r += m_off[i - 1] * w_prev + c_off[i - 1] * z_prev
        if i < n - 1:
            w_next = c1 * u[i + 1] + c2 * v[i + 1] + a[i + 1]
            z_next = c3 * u[i + 1] + v[i + 1]
            r += m_off[i] * w_next + c_off[i] * z_next
        if i == index:
            r += point_force
            if k_s > 0.0:
                r += k_s * r_x / series[3]
        y = (r - l_sub[i - 1] * y) / l_diag[i] if i > 0 else r / l_diag[0]
        a1[i] = y
        w_prev, z_prev, w, z = w, z, w_next, z_next
    x = 0.0
    for i in range(n - 1, -1, -1):
        x = (a1[i] - l_sub[i] * x) / l_diag[i] if i < n - 1 else a1[i] / l_diag[i]
        u1[i] = x
        du = x - u[i]
        v1[i] = c3 * du - v[i]
        a1[i] = c1 * du - c2 * v[i] - a[i]
    if k_s > 0.0:
        x1 = (r_x + k_s * u1[index]) / series[3]
        dx = x1 - flywheel[0]
        flywheel1[0] = x1
        flywheel1[1] = c3 * dx - flywheel[1]
        flywheel1[2] = c1 * dx - c2 * flywheel[1] - flywheel[2]
