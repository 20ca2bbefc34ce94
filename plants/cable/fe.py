"""Linear finite elements of a taut string with a node at the damper (private to
plants.cable.model).

Everything here is a symmetric tridiagonal matrix over the free nodes (the two fixed ends are
removed), stored as its diagonal and first off-diagonal so that assembly, products and the
banded Cholesky factorisation stay O(N).  The rigid part of an interface device (a grounded
inertance and dashpot at the damper node) is a diagonal entry; its series branch lives in
:mod:`plants.cable.device`.  Units: positions [m], tension [N], mass per length [kg/m],
stiffness [N/m], mass [kg], damping [N s/m].
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from plants.cable.properties import CableProperties, InterfaceDevice, RayleighDamping
from rths.core.errors import ParameterError, check_finite, check_positive_int

__all__ = [
    "MassKind",
    "Tridiagonal",
    "assemble",
    "check_mesh",
    "mesh_nodes",
    "rayleigh_coefficients",
    "sine_load_shape",
    "string_mass",
    "string_modal_frequency",
    "string_stiffness",
]

#: Element mass matrix: consistent ``m h/6 [[2,1],[1,2]]``, lumped ``m h/2 I`` or their average
#: ``m h/12 [[5,1],[1,5]]`` (fourth-order accurate frequencies on a uniform mesh).
MassKind = Literal["consistent", "lumped", "average"]

_MASS_WEIGHTS: dict[str, tuple[float, float]] = {
    # (diagonal, off-diagonal) entries of the element mass matrix divided by m*h
    "consistent": (2.0 / 6.0, 1.0 / 6.0),
    "lumped": (0.5, 0.0),
    "average": (5.0 / 12.0, 1.0 / 12.0),
}


@dataclass(frozen=True, slots=True)
class Tridiagonal:
    """Symmetric tridiagonal matrix: ``diag`` shape ``(n,)``, ``off`` shape ``(n-1,)``.

    Attributes
    ----------
    diag : numpy.ndarray
        Main diagonal, shape ``(n,)``, in the matrix's unit (N/m, kg or N s/m).
    off : numpy.ndarray
        First off-diagonal (equal above and below), shape ``(n-1,)``, same unit.
    """

    diag: NDArray[np.float64]
    off: NDArray[np.float64]

    def __add__(self, other: Tridiagonal) -> Tridiagonal:
        return Tridiagonal(self.diag + other.diag, self.off + other.off)

    def scaled(self, factor: float) -> Tridiagonal:
        """``factor`` times this matrix."""
        return Tridiagonal(factor * self.diag, factor * self.off)

    def with_point(self, index: int, value: float) -> Tridiagonal:
        """This matrix plus ``value`` on diagonal entry ``index`` (a grounded point element)."""
        diag = self.diag.copy()
        diag[index] += value
        return Tridiagonal(diag, self.off.copy())

    def matvec(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """The product with a vector of shape ``(n,)``."""
        y = self.diag * x
        y[:-1] += self.off * x[1:]
        y[1:] += self.off * x[:-1]
        return y

    def quadratic(self, x: NDArray[np.float64]) -> float:
        """``x.T @ A @ x``."""
        return float(x @ self.matvec(x))

    def banded_lower(self) -> NDArray[np.float64]:
        """Lower banded storage for :func:`scipy.linalg.cholesky_banded` (``lower=True``)."""
        ab = np.zeros((2, self.diag.size))
        ab[0] = self.diag
        ab[1, :-1] = self.off
        return ab

    def to_sparse(self) -> sp.csc_matrix:
        """The matrix as a SciPy sparse CSC matrix."""
        return sp.diags([self.off, self.diag, self.off], [-1, 0, 1], format="csc")

    def to_dense(self) -> NDArray[np.float64]:
        """The matrix as a dense array of shape ``(n, n)``."""
        return np.diag(self.diag) + np.diag(self.off, 1) + np.diag(self.off, -1)


#: Most elements a cable mesh may have: far beyond what a string needs (the mesh rule of a stiff
#: device asks for hundreds), and already a second of wall time per simulated second.
MAX_ELEMENTS = 100_000


def check_mesh(damper_position: float, elements: int) -> tuple[float, int]:
    """Validated ``(x_d, N)``: damper position in (0, 1) and 2 to :data:`MAX_ELEMENTS` elements.

    Parameters
    ----------
    damper_position : float
        Normalised damper location ``x_d = xbar_d/L`` [-] (S0 Eq.23), in (0, 1).
    elements : int
        Number of linear elements ``N``, 2 to :data:`MAX_ELEMENTS`.

    Raises
    ------
    ParameterError
        If either is out of range.
    """
    x_d = check_finite(damper_position, "damper position x_d")
    if not 0.0 < x_d < 1.0:
        raise ParameterError(f"damper position x_d must lie in (0, 1); got {damper_position!r}")
    n = check_positive_int(elements, "number of elements")
    if not 2 <= n <= MAX_ELEMENTS:
        raise ParameterError(
            f"number of elements must lie in [2, {MAX_ELEMENTS}]; got {elements!r}"
        )
    return x_d, n


def mesh_nodes(
    length: float, damper_position: float, elements: int
) -> tuple[NDArray[np.float64], int]:
    """Node coordinates [m] with a node exactly at the damper, and that node's free-DOF index.

    The ``n_left = max(1, round(N x_d))`` elements left of the damper and the ``N - n_left``
    to its right are each uniform (capped so that both sides keep at least one element).

    Parameters
    ----------
    length : float
        Cable length ``L`` [m].
    damper_position : float
        Normalised damper location ``x_d`` [-] in (0, 1) (S0 Eq.23), already validated
        (:func:`check_mesh`).
    elements : int
        Number of linear elements ``N`` >= 2, already validated.

    Returns
    -------
    nodes
        All ``N + 1`` node coordinates including both fixed ends, shape ``(N + 1,)``.
    damper_index
        Index of the damper node among the ``N - 1`` free nodes.
    """
    n_left = min(max(1, round(elements * damper_position)), elements - 1)
    x_d = damper_position * length
    left = np.linspace(0.0, x_d, n_left + 1)
    right = np.linspace(x_d, length, elements - n_left + 1)
    return np.concatenate([left, right[1:]]), n_left - 1


def string_stiffness(nodes: NDArray[np.float64], tension: float) -> Tridiagonal:
    """Stiffness [N/m] of the free nodes: element ``T/h [[1,-1],[-1,1]]`` assembled.

    Parameters
    ----------
    nodes : numpy.ndarray
        All node coordinates [m] including both fixed ends, shape ``(N + 1,)``, increasing.
    tension : float
        Cable tension ``T`` [N].

    Returns
    -------
    Tridiagonal
        The ``(N - 1) x (N - 1)`` stiffness over the free nodes [N/m].
    """
    k = tension / np.diff(nodes)
    return Tridiagonal(k[:-1] + k[1:], -k[1:-1])


def string_mass(
    nodes: NDArray[np.float64], mass_per_length: float, kind: MassKind = "average"
) -> Tridiagonal:
    """Mass matrix [kg] of the free nodes for the element mass ``kind`` (see :data:`MassKind`).

    Parameters
    ----------
    nodes : numpy.ndarray
        All node coordinates [m] including both fixed ends, shape ``(N + 1,)``, increasing.
    mass_per_length : float
        Cable mass per unit length ``m`` [kg/m].
    kind : {"average", "consistent", "lumped"}, default "average"
        Element mass matrix (:data:`MassKind`).

    Returns
    -------
    Tridiagonal
        The ``(N - 1) x (N - 1)`` mass over the free nodes [kg].
    """
    d, o = _MASS_WEIGHTS[kind]
    mh = mass_per_length * np.diff(nodes)
    return Tridiagonal(d * (mh[:-1] + mh[1:]), o * mh[1:-1])


def sine_load_shape(nodes: NDArray[np.float64], wavenumber: float) -> NDArray[np.float64]:
    """Consistent nodal loads [m] of the unit distributed load ``sin(k x)`` (S0 Eq.22 shape).

    Entry ``j`` is the exact integral of the hat function of free node ``j`` times ``sin(k x)``,
    so a load ``p0 sin(k x)`` [N/m] has nodal forces ``p0 * shape`` [N].  On an element
    ``[a, b]`` of length ``h``

    .. math::

        \\int_a^b \\frac{x-a}{h}\\sin kx\\,dx
            = -\\frac{\\cos kb}{k} + \\frac{\\sin kb - \\sin ka}{k^2 h},
        \\qquad
        \\int_a^b \\frac{b-x}{h}\\sin kx\\,dx
            = \\frac{\\cos ka}{k} - \\frac{\\sin kb - \\sin ka}{k^2 h}.

    Parameters
    ----------
    nodes : numpy.ndarray
        All node coordinates [m] including both fixed ends, shape ``(N + 1,)``, increasing.
    wavenumber : float
        ``k`` [rad/m]; S0 Eq.22's ``sin(n pi x)`` in normalised ``x`` is ``k = n pi/L``.
        0 gives zero loads.

    Returns
    -------
    numpy.ndarray
        Nodal load per unit load amplitude [m] at the ``N - 1`` free nodes, shape ``(N - 1,)``.
    """
    a, b = nodes[:-1], nodes[1:]
    h = b - a
    k = wavenumber
    if k == 0.0:
        return np.zeros(nodes.size - 2)
    chord = (np.sin(k * b) - np.sin(k * a)) / (k * k * h)
    rising = -np.cos(k * b) / k + chord  # hat function rising over the element (its right node)
    falling = np.cos(k * a) / k - chord  # hat function falling over the element (its left node)
    return rising[:-1] + falling[1:]


def rayleigh_coefficients(ratio: float, omega_i: float, omega_j: float) -> tuple[float, float]:
    """Rayleigh ``(a0 [1/s], a1 [s])`` giving damping ``ratio`` at ``omega_i`` and ``omega_j``.

    ``zeta(w) = a0/(2 w) + a1 w/2``; with equal ratios at both anchors
    ``a0 = 2 zeta wi wj/(wi + wj)`` and ``a1 = 2 zeta/(wi + wj)`` (Chopra, Dynamics of
    Structures, Eq. 11.4.9).

    Parameters
    ----------
    ratio : float
        Damping ratio ``zeta`` [-] wanted at both anchors.
    omega_i, omega_j : float
        Anchor circular frequencies ``wi``, ``wj`` [rad/s], > 0 (e.g. ``n omega0`` of two
        string modes).
    """
    total = omega_i + omega_j
    return 2.0 * ratio * omega_i * omega_j / total, 2.0 * ratio / total


def string_modal_frequency(mode: int, wave_speed: float, length: float) -> float:
    """Natural circular frequency ``n pi c / L`` [rad/s] of mode ``n`` of the continuous string.

    Parameters
    ----------
    mode : int
        Mode number ``n`` >= 1.
    wave_speed : float
        Transverse wave speed ``c = sqrt(T/m)`` [m/s].
    length : float
        Cable length ``L`` [m].
    """
    return mode * math.pi * wave_speed / length


def assemble(
    properties: CableProperties,
    nodes: NDArray[np.float64],
    damper_index: int,
    intrinsic: RayleighDamping | None,
    device: InterfaceDevice | None,
    mass_kind: MassKind,
) -> tuple[Tridiagonal, Tridiagonal, Tridiagonal]:
    """``(K, M, C)`` over the free nodes: string stiffness plus the device's grounded spring;
    string mass plus its rigid inertance; Rayleigh damping (of the string alone) plus its rigid
    dashpot.  The series branch is not included.

    Parameters
    ----------
    properties : CableProperties
        The cable (``T`` [N], ``m`` [kg/m], ``omega0`` [rad/s] for the Rayleigh anchors).
    nodes : numpy.ndarray
        All node coordinates [m] including both fixed ends, shape ``(N + 1,)``
        (:func:`mesh_nodes`).
    damper_index : int
        Index of the damper node among the ``N - 1`` free nodes.
    intrinsic : RayleighDamping or None
        The cable's intrinsic damping; None (or a zero ratio) for none.
    device : InterfaceDevice or None
        Nominal interface device whose rigid part (``stiffness`` [N/m], ``inertance`` [kg],
        ``damping`` [N s/m]) is added at the damper node; None for none.
    mass_kind : {"average", "consistent", "lumped"}
        Element mass matrix (:data:`MassKind`).

    Returns
    -------
    tuple of Tridiagonal
        ``(K [N/m], M [kg], C [N s/m])``, each ``(N - 1) x (N - 1)``.
    """
    p = properties
    stiffness = string_stiffness(nodes, p.tension)
    string_m = string_mass(nodes, p.mass_per_length, mass_kind)
    zero = np.zeros(nodes.size - 2)
    damping = Tridiagonal(zero, zero[:-1].copy())
    if intrinsic is not None and intrinsic.ratio > 0.0:
        w_i, w_j = (n * p.omega0 for n in intrinsic.modes)
        a0, a1 = rayleigh_coefficients(intrinsic.ratio, w_i, w_j)
        damping = string_m.scaled(a0) + stiffness.scaled(a1)
    mass = string_m
    if device is not None:
        stiffness = stiffness.with_point(damper_index, device.stiffness)
        mass = mass.with_point(damper_index, device.inertance)
        damping = damping.with_point(damper_index, device.damping)
    return stiffness, mass, damping
