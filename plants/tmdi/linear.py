"""Closed-form results for the linear TMDI system of S1 Fig.1a (private; re-exported by
:mod:`plants.tmdi.structure`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from rths.core.errors import ParameterError, check_nonnegative

if TYPE_CHECKING:
    from plants.tmdi.parameters import TMDIParameters

__all__ = ["linear_frf", "linearised_frequencies"]

#: Names of the S1 Eq.7 response quantities, in the paper's order.
EQ7_QUANTITIES: tuple[str, ...] = (
    "u_I",
    "a_I_tot",
    "F_I",
    "u_TI",
    "a_T_tot",
    "F_T",
    "u_T",
    "a_T",
    "F_B",
)


def linear_frf(
    parameters: TMDIParameters, inertance: float, frequency: ArrayLike
) -> dict[str, NDArray[np.complex128]]:
    """Complex FRFs of the linear 2-DOF TMDI (S1 Fig.1a) per unit ground acceleration.

    The linear system uses the ``k1`` and ``c`` of each isolator (``k2 = k3 = 0``) and an ideal
    grounded inerter of inertance ``b``; with harmonic ``ü_G = e^{iωt}`` S1 Eq.12 becomes

    .. math::

        \\begin{bmatrix} -ω^2 m_I + z_I + z_T & -z_T \\\\ -z_T & -ω^2 (m_T + b) + z_T
        \\end{bmatrix} \\begin{bmatrix} U_I \\\\ U_T \\end{bmatrix}
        = -\\begin{bmatrix} m_I \\\\ m_T \\end{bmatrix}, \\qquad z = k_1 + iωc,

    and the S1 Eq.7 quantities follow (e.g. ``a_I_tot = 1 - ω² U_I``, ``F_B = -b ω² U_T``).

    Parameters
    ----------
    parameters
        The structure; for the uncontrolled PS only the primary quantities are returned.
    inertance
        ``b`` [kg] (0 for a plain TMD).
    frequency
        Frequencies [Hz], any shape.

    Returns
    -------
    dict
        Complex arrays of the shape of ``frequency`` keyed by the S1 Eq.7 names
        (``"u_I"`` [m/(m/s²)], ``"a_I_tot"`` [-], ``"F_I"`` [N/(m/s²)], ...).
    """
    b = check_nonnegative(inertance, "inertance b")
    f = np.asarray(frequency, dtype=float)
    if not np.all(np.isfinite(f)):
        raise ParameterError(f"frequency must be finite; got {frequency!r}")
    w = 2.0 * np.pi * f
    m_i = parameters.primary_mass
    z_i = parameters.primary_isolator.k1 + 1j * w * parameters.primary_isolator.c
    if not parameters.has_tmd:
        u_i = -m_i / (-(w**2) * m_i + z_i)
        return {
            "u_I": u_i.astype(np.complex128),
            "a_I_tot": (1.0 - w**2 * u_i).astype(np.complex128),
            "F_I": (z_i * u_i).astype(np.complex128),
        }
    iso = parameters.secondary_isolator
    assert iso is not None  # has_tmd
    m_t = parameters.secondary_mass
    z_t = iso.k1 + 1j * w * iso.c
    a11 = -(w**2) * m_i + z_i + z_t
    a22 = -(w**2) * (m_t + b) + z_t
    det = a11 * a22 - z_t * z_t
    u_i = (-m_i * a22 - z_t * m_t) / det
    u_t = (-m_t * a11 - z_t * m_i) / det
    a_t = -(w**2) * u_t
    return {
        "u_I": u_i,
        "a_I_tot": 1.0 - w**2 * u_i,
        "F_I": z_i * u_i,
        "u_TI": u_t - u_i,
        "a_T_tot": 1.0 + a_t,
        "F_T": z_t * (u_t - u_i),
        "u_T": u_t,
        "a_T": a_t,
        "F_B": b * a_t,
    }


def linearised_frequencies(parameters: TMDIParameters, inertance: float) -> tuple[float, ...]:
    """Undamped natural frequencies [Hz] of the small-amplitude (``k1``) linearisation.

    Returns ``(f0,)`` for the uncontrolled PS and ``(f1, f2)`` (ascending) with the TMDI,
    from the generalised eigenproblem ``K φ = ω² M φ`` with ``M = diag(m_I, m_T + b)``
    (``scipy.linalg.eigh``).  S1 §3.1 observes ``f1 < f0 < f2``.

    Parameters
    ----------
    parameters : TMDIParameters
        The structure; only ``m_I``, ``m_T`` [kg] and each isolator's ``k1`` [N/m] (S1 Eq.8)
        are used.
    inertance : float
        Inertance ``b`` [kg] of the ideal grounded inerter, >= 0 (0 for a plain TMD; ignored
        for the uncontrolled PS).
    """
    b = check_nonnegative(inertance, "inertance b")
    k_i = parameters.primary_isolator.k1
    if not parameters.has_tmd:
        return (float(np.sqrt(k_i / parameters.primary_mass) / (2.0 * np.pi)),)
    assert parameters.secondary_isolator is not None
    k_t = parameters.secondary_isolator.k1
    stiffness = np.array([[k_i + k_t, -k_t], [-k_t, k_t]])
    mass = np.diag([parameters.primary_mass, parameters.secondary_mass + b])
    w2 = scipy.linalg.eigh(stiffness, mass, eigvals_only=True)
    return tuple(float(x) for x in np.sqrt(w2) / (2.0 * np.pi))
