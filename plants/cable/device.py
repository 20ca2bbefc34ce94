"""The nominal interface device in the cable FE model (private; re-exported by plants.cable.model):
the assembled model with the device (:func:`fe_matrices`), the Newmark-AA condensation of the
series branch's flywheel DOF, and the mesh rule.

Condensation
------------
The series branch (S0 Eq.12) is a spring ``k_s`` [N/m] from the damper node ``j`` to a flywheel
``x`` of inertance ``m_s`` [kg] with a viscous ``c_s`` [N s/m] to ground.  Appended as one more DOF
it would border the tridiagonal system.  Its Newmark-AA row (no external force on the flywheel)::

    D x1 - k_s u_j1 = r_x,   D = k_s + 2 c_s/h + 4 m_s/h^2,
                             r_x = m_s (4/h^2 x + 4/h x' + x'') + c_s (2/h x + x')

gives ``x1 = (r_x + k_s u_j1)/D``; substituted into row ``j`` it adds the constant
``k_s (1 - k_s/D) = k_s b/(k_s + b)``, ``b = 2 c_s/h + 4 m_s/h^2``, to the effective matrix's
diagonal at ``j`` (factorised once; the second form avoids cancellation for stiff springs) and
``k_s r_x/D`` to the right-hand side at ``j`` each step.  After the tridiagonal solve,
``x1`` follows from ``u_j1`` and ``x1'``, ``x1''`` from the Newmark formulas.  The result is the
augmented system's Newmark step exactly (no approximation), at O(1) extra cost.

Mesh rule
---------
The damper node, of mass ``~ m h`` [kg], sits on the device spring (at high frequency the
flywheel stands still): its local frequency ``sqrt(k_s/(m h))`` must lie below the FE string's
cutoff ``2 c/h`` (lumped-mass lattice, ``c = sqrt(T/m)``), so that what the stepped correction
force excites there radiates into the string instead of ringing at the node.
``2 c/h > sqrt(k_s/(m h))`` is ``h < h_max = 4 T/k_s``.  For the seed cable (``T = 5e6`` N) and
the Type II stiffness at prototype scale (``k_s = 6.4e7`` N/m) ``h_max = 0.3125`` m, i.e.
``N >= 641`` elements on 200 m.  The rule is a criterion, not a spectral transition: a point
spring on a 1-D lattice always binds one mode above the band, decaying by ``r`` per element
with ``1/r - r = k_s h/T`` (lumped lattice), so ``h = h_max`` means ``r = sqrt(5) - 2 = 0.24``
and finer meshes spread it further (measured, seed values, average mass: the damper node holds
``phi_j^2 M_jj/phi^T M phi`` = 98 % of that mode at ``N = 300``, 87 % at 641, 74 % at 1000).
:class:`plants.cable.model.Cable` does not enforce the rule (convergence studies need coarse
meshes);
:func:`elements_for` gives the smallest mesh that meets it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from plants.cable.fe import (
    MAX_ELEMENTS,
    MassKind,
    Tridiagonal,
    assemble,
    check_mesh,
    mesh_nodes,
)
from plants.cable.properties import CableProperties, InterfaceDevice, RayleighDamping
from rths.core.errors import (
    ParameterError,
    check_finite,
    check_positive,
    check_positive_int,
)

__all__ = [
    "FEMatrices",
    "SeriesCondensation",
    "augmented_matrices",
    "elements_for",
    "fe_matrices",
    "max_element_size",
]


@dataclass(frozen=True, slots=True)
class SeriesCondensation:
    """Newmark-AA constants of a series branch for the step ``dt`` [s] (module docstring).

    Attributes
    ----------
    stiffness, inertance, damping
        ``k_s`` [N/m], ``m_s`` [kg], ``c_s`` [N s/m].
    dt
        Time step ``h`` [s].
    denominator
        ``D = k_s + 2 c_s/h + 4 m_s/h^2`` [N/m].
    diagonal
        ``k_s (1 - k_s/D)`` [N/m], added to the effective matrix at the damper node.
    """

    stiffness: float
    inertance: float
    damping: float
    dt: float
    denominator: float
    diagonal: float

    @classmethod
    def of(cls, device: InterfaceDevice, dt: float) -> SeriesCondensation:
        """The constants of ``device``'s series branch (which it must have) for step ``dt``."""
        if device.series_stiffness is None:
            raise ParameterError("the device has no series branch; got series_stiffness=None")
        k_s, m_s, c_s = device.series_stiffness, device.series_inertance, device.series_damping
        b = 2.0 * c_s / dt + 4.0 * m_s / dt**2
        return cls(k_s, m_s, c_s, dt, k_s + b, k_s * b / (k_s + b))

    def consistent_state(
        self,
        node_displacement: float,
        node_velocity: float,
        flywheel: tuple[float, float] | None = None,
    ) -> NDArray[np.float64]:
        """Flywheel ``(x, x', x'')`` consistent with its equation of motion (S0 Eq.12).

        ``flywheel = (x [m], x' [m/s])``; ``None`` means the spring unstretched and the flywheel
        moving with the node (``x = u_d``, ``x' = v_d``).  Without inertance ``x'`` follows from
        ``c_s x' = k_s (u_d - x)`` (the given one is ignored) and ``x''`` is set to 0.
        """
        if flywheel is None:
            x, xd = node_displacement, node_velocity
        else:
            try:
                x, xd = flywheel
            except (TypeError, ValueError):
                raise ParameterError(
                    f"flywheel must be (displacement, velocity); got {flywheel!r}"
                ) from None
            x = check_finite(x, "flywheel displacement")
            xd = check_finite(xd, "flywheel velocity")
        spring = self.stiffness * (node_displacement - x)
        if self.inertance == 0.0:
            return np.array([x, spring / self.damping, 0.0])
        return np.array([x, xd, (spring - self.damping * xd) / self.inertance])

    def flywheel_load(self, flywheel: NDArray[np.float64]) -> float:
        """``r_x`` [N]: the flywheel row's right-hand side from its state ``(x, x', x'')``."""
        h = self.dt
        x, xd, xdd = flywheel
        r = self.inertance * (4.0 / h**2 * x + 4.0 / h * xd + xdd)
        return float(r + self.damping * (2.0 / h * x + xd))

    def node_load(self, flywheel_load: float) -> float:
        """``k_s r_x/D`` [N]: what the condensed flywheel adds to the damper node's load."""
        return self.stiffness * flywheel_load / self.denominator

    def advance(
        self,
        flywheel: NDArray[np.float64],
        flywheel_load: float,
        node_displacement: float,
        out: NDArray[np.float64],
    ) -> NDArray[np.float64]:
        """The flywheel state ``(x, x', x'')`` at ``t_{k+1}`` into ``out`` (returned), from the
        state at ``t_k``, its ``r_x`` and the damper node's new displacement ``u_j1`` [m]."""
        h = self.dt
        x, xd, xdd = flywheel
        x1 = (flywheel_load + self.stiffness * node_displacement) / self.denominator
        out[0] = x1
        out[1] = 2.0 / h * (x1 - x) - xd
        out[2] = 4.0 / h**2 * (x1 - x) - 4.0 / h * xd - xdd
        return out


def augmented_matrices(
    stiffness: Tridiagonal,
    mass: Tridiagonal,
    damping: Tridiagonal,
    index: int,
    device: InterfaceDevice,
) -> tuple[sp.csc_matrix, sp.csc_matrix, sp.csc_matrix]:
    """Sparse ``(K, M, C)`` with the flywheel appended as the last DOF (shape ``(n+1, n+1)``).

    The spring adds ``k_s [[1, -1], [-1, 1]]`` on ``(index, n)``; ``m_s`` and ``c_s`` sit at
    ``(n, n)`` (S0 Eq.12 with the flywheel displacement ``x_i`` as DOF ``n``).

    Parameters
    ----------
    stiffness : Tridiagonal
        The cable's stiffness [N/m] over its ``n`` free nodes (with the device's grounded
        spring, if any, already in it).
    mass : Tridiagonal
        The cable's mass [kg] over the free nodes, with the device's rigid inertance in it.
    damping : Tridiagonal
        The cable's damping [N s/m] over the free nodes, with the device's rigid dashpot in it.
    index : int
        Index of the damper node among the free nodes.
    device : InterfaceDevice
        The device; it must have a series branch (``series_stiffness`` ``k_s`` [N/m],
        ``series_inertance`` ``m_s`` [kg], ``series_damping`` ``c_s`` [N s/m]).

    Raises
    ------
    ParameterError
        If ``device`` has no series branch.
    """
    if device.series_stiffness is None:
        raise ParameterError("the device has no series branch; got series_stiffness=None")
    n = stiffness.diag.size
    k_s = device.series_stiffness
    spring = sp.coo_matrix(
        ([k_s, -k_s, -k_s, k_s], ([index, index, n, n], [index, n, index, n])), shape=(n + 1, n + 1)
    )

    def bordered(matrix: Tridiagonal, corner: float) -> sp.csc_matrix:
        return sp.block_diag([matrix.to_sparse(), sp.csc_matrix([[corner]])], format="csc")

    k = (bordered(stiffness, 0.0) + spring).tocsc()
    return k, bordered(mass, device.series_inertance), bordered(damping, device.series_damping)


def max_element_size(series_stiffness: float, properties: CableProperties) -> float:
    """Largest element size ``h_max = 4 T/k_s`` [m] at which the damper node still radiates.

    Parameters
    ----------
    series_stiffness
        ``k_s`` [N/m] of the device's series branch.
    properties
        The cable (its tension ``T`` [N]).

    Notes
    -----
    The node's local frequency on the device spring, ``sqrt(k_s/(m h))``, must lie below the
    FE string's cutoff ``2 c/h`` (module docstring).  The bound is strict: use ``h < h_max``.
    """
    k_s = check_positive(series_stiffness, "series stiffness")
    return 4.0 * properties.tension / k_s


def elements_for(
    properties: CableProperties,
    damper_position: float,
    series_stiffness: float | None,
    minimum: int = 100,
) -> int:
    """The smallest number of elements ``N >= minimum`` whose mesh meets the rule ``h < h_max``.

    Parameters
    ----------
    properties
        The cable.
    damper_position
        Normalised damper position ``x_d`` in (0, 1); the mesh is that of
        :func:`plants.cable.fe.mesh_nodes` (uniform on each side of the damper node).
    series_stiffness
        ``k_s`` [N/m] of the device's series branch; ``None`` (no branch) imposes nothing.
    minimum
        Lower bound on ``N`` (>= 2), e.g. for the accuracy of the string modes.

    Returns
    -------
    int
        ``N`` such that every element is shorter than :func:`max_element_size`.
    """
    x_d, n = check_mesh(damper_position, check_positive_int(minimum, "minimum elements"))
    if series_stiffness is None:
        return n
    h_max = max_element_size(series_stiffness, properties)
    needed = properties.length / h_max
    if needed > MAX_ELEMENTS:
        raise ParameterError(
            f"the device's series stiffness {series_stiffness:.6g} N/m needs elements shorter than "
            f"4 T/k_s = {h_max:.3g} m: {needed:.3g} of them on {properties.length:g} m, more "
            f"than {MAX_ELEMENTS} (check the model's stiffness and the scaling)"
        )
    n = max(n, math.floor(needed))  # no element shorter than L/N fits below
    while True:
        nodes, _ = mesh_nodes(properties.length, x_d, n)
        if np.max(np.diff(nodes)) < h_max:
            return n
        n += 1


@dataclass(frozen=True, slots=True)
class FEMatrices:
    """FE model over the free nodes: ``positions`` [m] shape ``(N-1,)``, the damper node's index,
    stiffness [N/m], mass [kg] and damping [N s/m] as sparse square matrices.

    Without a series device branch they are ``(N-1, N-1)``; with one the flywheel is appended
    as DOF ``flywheel_index = N-1`` and they are ``(N, N)``.

    Attributes
    ----------
    positions : numpy.ndarray
        Coordinates [m] of the ``N - 1`` free nodes from the left support, shape ``(N-1,)``
        (the flywheel DOF has none).
    damper_index : int
        Index of the damper node (at ``x_d L``) among the free nodes.
    stiffness : scipy.sparse.csc_matrix
        Stiffness matrix ``K`` [N/m].
    mass : scipy.sparse.csc_matrix
        Mass matrix ``M`` [kg].
    damping : scipy.sparse.csc_matrix
        Damping matrix ``C`` [N s/m] (Rayleigh damping of the string plus the device's).
    flywheel_index : int or None, default None
        Index of the flywheel DOF (``x_i`` of S0 Eq.12) when the device has a series branch,
        else None.
    """

    positions: NDArray[np.float64]
    damper_index: int
    stiffness: sp.csc_matrix
    mass: sp.csc_matrix
    damping: sp.csc_matrix
    flywheel_index: int | None = None


def fe_matrices(
    properties: CableProperties,
    damper_position: float,
    elements: int,
    *,
    intrinsic_damping: RayleighDamping | None = None,
    damper: InterfaceDevice | None = None,
    mass_matrix: MassKind = "average",
) -> FEMatrices:
    """The cable's FE matrices (the ones :class:`plants.cable.model.Cable` integrates), e.g. for
    eigen-analysis.

    Parameters
    ----------
    properties
        The cable.
    damper_position
        Normalised damper location ``x_d`` in (0, 1); a node is placed exactly there.
    elements
        Number of linear elements ``N`` >= 2.
    intrinsic_damping
        Rayleigh damping of the cable, or ``None`` for none.
    damper
        The interface device at the damper node inside the model, or ``None``; a series branch
        appends the flywheel DOF (not condensed, see :class:`FEMatrices`).
    mass_matrix
        Element mass matrix; the default ``"average"`` is the recommended one
        (:mod:`plants.cable.model`),
        the others exist for convergence studies.
    """
    x_d, n = check_mesh(damper_position, elements)
    if mass_matrix not in ("consistent", "lumped", "average"):
        raise ParameterError(
            f"mass_matrix must be 'consistent', 'lumped' or 'average'; got {mass_matrix!r}"
        )
    nodes, index = mesh_nodes(properties.length, x_d, n)
    k, m, c = assemble(properties, nodes, index, intrinsic_damping, damper, mass_matrix)
    positions = nodes[1:-1].copy()
    if damper is not None and damper.has_series:
        k_aug, m_aug, c_aug = augmented_matrices(k, m, c, index, damper)
        return FEMatrices(positions, index, k_aug, m_aug, c_aug, flywheel_index=n - 1)
    return FEMatrices(positions, index, k.to_sparse(), m.to_sparse(), c.to_sparse())
