"""Exact discretisation of a linear structure driven by base acceleration and a held force.

Private helper of :mod:`plants.frame`.  For ``M x'' + C x' + K x = -M_g iota a_g(t) + f(t)``
written as ``z' = A z + B_g a_g + B_f f`` (``z = [x; x']``), one step of length ``h`` is

.. math::

    z_{k+1} = \\Phi z_k + \\Gamma_0 a_{g,k} + \\Gamma_1 a_{g,k+1} + \\Gamma_f f_k,

exact when ``a_g`` is linear and ``f`` constant over the step (first-order hold of the ground
acceleration, as MATLAB's ``lsim`` with ``'foh'`` and Simulink's *From File* interpolation; zero-
order hold of the interface force, which a loop feeds back once per step).  ``Phi`` and the
``Gamma`` come from one matrix exponential of the augmented generator (Van Loan's method):

.. math::

    \\exp\\left(h \\begin{bmatrix} A & B & 0 \\\\ 0 & 0 & I/h \\\\ 0 & 0 & 0 \\end{bmatrix}\\right)
    = \\begin{bmatrix} \\Phi & \\Gamma_a & \\Gamma_b \\\\ 0 & I & I \\\\ 0 & 0 & I \\end{bmatrix},
    \\quad \\Gamma_0 = \\Gamma_a - \\Gamma_b, \\ \\Gamma_1 = \\Gamma_b.

Unlike an explicit integrator this is unconditionally stable and has no period error: the
discrete eigenvalues are ``exp(lambda h)`` exactly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from numpy.typing import NDArray

from rths.core.errors import ParameterError, check_positive

__all__ = ["DiscreteStructure", "discretise_structure", "state_matrices"]

FloatArray = NDArray[np.float64]


def state_matrices(
    mass: FloatArray, damping: FloatArray, stiffness: FloatArray, ground_mass: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """First-order form ``z' = A z + B_g a_g + B_f f`` of ``M x'' + C x' + K x = -M_g 1 a_g + f``.

    Parameters
    ----------
    mass, damping, stiffness
        ``M`` [kg], ``C`` [N s/m], ``K`` [N/m] of the integrated structure, shape ``(n, n)``.
    ground_mass
        ``M_g`` [kg], shape ``(n, n)``: the mass that feels the ground acceleration (the whole
        reference mass even when part of it is a physical specimen, ``F1_input_file.m``
        ``B_ns = -(MN\\M) iota``).

    Returns
    -------
    tuple
        ``A`` (``(2n, 2n)``), ``B_g`` (``(2n,)``), ``B_f`` (``(2n, n)``, a force per DOF).
    """
    m = np.asarray(mass, dtype=float)
    n = m.shape[0]
    for name, mat in (("damping", damping), ("stiffness", stiffness), ("ground mass", ground_mass)):
        if np.shape(mat) != (n, n):
            raise ParameterError(f"{name} matrix must have shape {(n, n)}; got {np.shape(mat)}")
    try:
        m_inv = np.linalg.inv(m)
    except np.linalg.LinAlgError:
        raise ParameterError(f"mass matrix must be invertible; got {m.tolist()!r}") from None
    a = np.zeros((2 * n, 2 * n))
    a[:n, n:] = np.eye(n)
    a[n:, :n] = -m_inv @ np.asarray(stiffness, dtype=float)
    a[n:, n:] = -m_inv @ np.asarray(damping, dtype=float)
    b_g = np.concatenate([np.zeros(n), -m_inv @ np.asarray(ground_mass, dtype=float) @ np.ones(n)])
    b_f = np.vstack([np.zeros((n, n)), m_inv])
    return a, b_g, b_f


@dataclass(frozen=True)
class DiscreteStructure:
    """One exact step ``z+ = Phi z + g0 a_g,k + g1 a_g,k+1 + Gf f_k`` over ``step`` [s]."""

    phi: FloatArray
    g0: FloatArray
    g1: FloatArray
    gf: FloatArray
    step: float


def discretise_structure(
    a: FloatArray, b_g: FloatArray, b_f: FloatArray, step: float
) -> DiscreteStructure:
    """FOH (ground acceleration) and ZOH (force) discretisation of ``(A, B_g, B_f)``.

    Parameters
    ----------
    a, b_g, b_f
        From :func:`state_matrices`.
    step
        Step ``h`` [s], > 0.
    """
    h = check_positive(step, "time step")
    n = a.shape[0]
    inputs = np.column_stack([b_g, b_f])
    m = inputs.shape[1]
    gen = np.zeros((n + 2 * m, n + 2 * m))
    gen[:n, :n] = a
    gen[:n, n : n + m] = inputs
    gen[n : n + m, n + m :] = np.eye(m) / h
    e = sla.expm(gen * h)
    phi, g_a, g_b = e[:n, :n], e[:n, n : n + m], e[:n, n + m :]
    # the force is held: its ramp column is not used (ZOH = Gamma_a)
    return DiscreteStructure(
        phi=phi,
        g0=g_a[:, 0] - g_b[:, 0],
        g1=g_b[:, 0],
        gf=g_a[:, 1:],
        step=h,
    )
