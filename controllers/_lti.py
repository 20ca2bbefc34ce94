"""Private helpers shared by the compensators: checking nominal models, power series of their
inverse, and a well-conditioned state-space realisation.

The nominal model of a compensator is a python-control continuous-time SISO LTI system (a
``TransferFunction`` or ``StateSpace``) from the actuator command [m] to the measured displacement
[m].  A pure transport delay, if any, is given separately in seconds.
"""

from __future__ import annotations

import math

import control
import numpy as np
import scipy.linalg as sla
from numpy.typing import NDArray

from rths.core.errors import ParameterError

__all__ = [
    "balanced_realization",
    "dc_gain",
    "inverse_taylor",
    "siso_polynomials",
]

FloatArray = NDArray[np.float64]


def siso_polynomials(nominal: object, name: str = "nominal model") -> tuple[FloatArray, FloatArray]:
    """Numerator and denominator (descending powers of s) of a continuous-time SISO LTI model.

    Raises :class:`ParameterError` if ``nominal`` is not a python-control LTI system, is discrete,
    is not SISO, is improper, or has a pole in the closed right half-plane (an unstable model
    cannot serve as a nominal actuator model for an open-loop inverse).
    """
    if not isinstance(nominal, control.LTI):
        raise ParameterError(
            f"{name} must be a python-control TransferFunction or StateSpace; got {nominal!r}"
        )
    if nominal.dt not in (0, None):
        raise ParameterError(f"{name} must be continuous-time; got dt={nominal.dt!r}")
    if nominal.ninputs != 1 or nominal.noutputs != 1:
        raise ParameterError(
            f"{name} must be SISO; got {nominal.ninputs} inputs and {nominal.noutputs} outputs"
        )
    tf = control.tf(nominal)
    num = np.trim_zeros(np.atleast_1d(np.asarray(tf.num[0][0], dtype=float)), "f")
    den = np.trim_zeros(np.atleast_1d(np.asarray(tf.den[0][0], dtype=float)), "f")
    if num.size == 0 or not np.all(np.isfinite(num)) or not np.all(np.isfinite(den)):
        raise ParameterError(f"{name} must have a finite, non-zero transfer function; got {tf}")
    if num.size > den.size:
        raise ParameterError(
            f"{name} must be proper; got numerator degree {num.size - 1} > "
            f"denominator degree {den.size - 1}"
        )
    poles = np.roots(den)
    if poles.size and np.max(poles.real) >= 0.0:
        raise ParameterError(
            f"{name} must be stable; got a pole at {poles[np.argmax(poles.real)]:.6g}"
        )
    if num[-1] == 0.0:
        raise ParameterError(f"{name} must have a non-zero DC gain; got numerator {num.tolist()}")
    return num / den[0], den / den[0]


def dc_gain(num: FloatArray, den: FloatArray) -> float:
    """Static gain G(0) of ``num(s)/den(s)``."""
    return float(num[-1] / den[-1])


def inverse_taylor(num: FloatArray, den: FloatArray, order: int, delay: float = 0.0) -> FloatArray:
    r"""Taylor coefficients at s = 0 of the inverse model :math:`e^{s\tau}\,den(s)/num(s)`.

    Returns ``c`` (ascending powers, length ``order + 1``) such that

    .. math:: G^{-1}(s) = c_0 + c_1 s + c_2 s^2 + \dots + c_n s^n + O(s^{n+1}),

    i.e. the command :math:`u = \sum_i c_i\, r^{(i)}` inverts the model for slowly varying
    targets.  For an all-pole model ``b0/den(s)`` of degree ``n`` with no delay the series is exact
    (``c = den[::-1]/b0``).  ``c_1/c_0`` is the model's low-frequency phase delay [s].
    """
    if order < 0:
        raise ParameterError(f"series order must be non-negative; got {order}")
    n_terms = order + 1
    a = np.zeros(n_terms)  # ascending coefficients of e^{s tau} den(s)
    den_asc = den[::-1]
    exp_series = np.array([delay**i / math.factorial(i) for i in range(n_terms)])
    for i in range(min(n_terms, den_asc.size)):
        a[i:] += den_asc[i] * exp_series[: n_terms - i]
    b = np.zeros(n_terms)
    num_asc = num[::-1]
    b[: min(n_terms, num_asc.size)] = num_asc[:n_terms]
    # power-series division c = a / b (b[0] = G(0)*den(0) != 0 is checked by the caller)
    c = np.zeros(n_terms)
    for i in range(n_terms):
        c[i] = (a[i] - np.dot(b[1 : i + 1], c[i - 1 :: -1][:i])) / b[0]
    return c


def balanced_realization(
    num: FloatArray, den: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """A balanced continuous-time realisation ``(A, B, C, D)`` of ``num(s)/den(s)``.

    The controllable canonical form of an actuator model spans twenty orders of magnitude
    (``a1*beta0 = 2.1e13``), which ruins discrete Riccati solutions.  The realisation is first
    balanced by a diagonal similarity (LAPACK ``gebal`` through :func:`scipy.linalg.matrix_balance`)
    and then transformed so that the controllability and observability Gramians are equal and
    diagonal (square-root balancing, Laub et al. 1987): every state then carries comparable
    energy and the Riccati problems are well conditioned.
    """
    sys = control.ss(control.tf(num, den))
    a0, b0, c0, d0 = (np.asarray(m, dtype=float) for m in (sys.A, sys.B, sys.C, sys.D))
    ab, (scale, _) = sla.matrix_balance(a0, permute=False, separate=True)
    bb = b0 / scale[:, None]
    cb = c0 * scale[None, :]
    wc = sla.solve_continuous_lyapunov(ab, -bb @ bb.T)
    wo = sla.solve_continuous_lyapunov(ab.T, -cb.T @ cb)
    lc = sla.cholesky(0.5 * (wc + wc.T), lower=True)
    lo = sla.cholesky(0.5 * (wo + wo.T), lower=True)
    u, hsv, vt = np.linalg.svd(lo.T @ lc)
    t = lc @ vt.T / np.sqrt(hsv)[None, :]
    t_inv = (u / np.sqrt(hsv)[None, :]).T @ lo.T
    return t_inv @ ab @ t, t_inv @ bb, cb @ t, d0
