"""Taut stay cable: the numerical substructure of the seed RTHS (S0 §5.1, design.md §5).

The cable is a taut string of length ``L`` [m], tension ``T`` [N] and mass per length ``m``
[kg/m], fixed at both ends, with a transverse damper at ``x_d = xbar_d/L`` (S0 Eq.23).  It is
discretised with linear two-node elements that put a node exactly at the damper and are uniform
on each side of it, and integrated with Newmark's average-acceleration rule.

Modelling choices (with the evidence)
-------------------------------------
* **Mass matrix: the average of the consistent and lumped matrices**, element
  ``m h/12 [[5,1],[1,5]]``.  On a uniform mesh its frequencies are fourth-order accurate (the
  consistent matrix overestimates by ``(kh)^2/24``, the lumped one underestimates by the same).
  Measured against the exact frequency equation (:mod:`plants.cable_damper`), viscous damper at
  ``x_d = 0.02``, ``kappa = 1``, mode 1, relative error of the damping ratio for N = 50/100/200/400
  elements: consistent 3.4e-4/8.5e-5/2.1e-5/5.3e-6, lumped -3.3e-4/-8.1e-5/-2.0e-5/-5.1e-6,
  average 7.0e-6/1.8e-6/4.5e-7/1.1e-7.  For the IMD optimum of mode 3 the error is dominated by
  the sensitivity of the two nearly coalescent roots and all three converge as 1/N^2 with the
  same constant (consistent 7.6e-4, lumped 8.8e-4, average 8.1e-4 at N = 400, worst root), so
  the average matrix costs nothing there and gains 50x elsewhere; it stays tridiagonal.
  Reproduce with ``python tools/bench_cable.py --mass-study``.
* **Intrinsic damping: Rayleigh** ``C = a0 M + a1 K`` anchored at two string modes (default
  modes 1 and 3, 0.1 %, S0 §1).  It keeps ``C`` tridiagonal and the damping classical, unlike
  dense modal damping; pure stiffness-proportional damping would triple the ratio of mode 3 (the
  seed test's mode) when mode 1 has 0.1 %.  Above the upper anchor the ratio grows like
  ``a1 omega/2``, which quietly damps the spurious high FE modes a stepped device force excites.
* **Coupling and time alignment**: ``step(F_k)`` advances from ``t_k`` to ``t_{k+1}``; the device
  restoring force ``F_k`` measured at ``t_k`` is applied as the interface force *at* ``t_{k+1}``
  (the standard one-step lag of RTHS), and the cable receives ``-F_k`` (sign convention of
  :mod:`plants.base`).  The distributed load (S0 Eq.22) is evaluated exactly at ``t_{k+1}``.
* An optional grounded **point damper inside the model** (inertance ``mbar_e`` [kg], viscous
  ``cbar_d`` [N s/m], simplified S0 Eq.1) is added to ``M`` and ``C`` and so integrated
  implicitly; it serves the fully numerical "mock" RTHS and the eigen-analysis.

The effective matrix ``K + 2/h C + 4/h^2 M`` is factorised once (banded Cholesky) and each step
is one fused O(N) pass compiled with numba (``use_numba=False`` selects the NumPy/SciPy
reference path, which gives the same numbers).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from plants._cable_fe import (
    MassKind,
    Tridiagonal,
    mesh_nodes,
    rayleigh_coefficients,
    sine_load_shape,
    string_mass,
    string_stiffness,
)
from plants._cable_newmark import newmark_operator, step_kernel, step_reference
from plants._cable_params import (
    CableProperties,
    DistributedLoad,
    PointDamper,
    RayleighDamping,
    normalised_damper,
    physical_damper,
)
from plants.base import Kinematics, Substructure
from rths.errors import ParameterError, check_finite, check_in_range, check_positive_int

_State = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]

__all__ = [
    "Cable",
    "CableProperties",
    "DistributedLoad",
    "FEMatrices",
    "PointDamper",
    "RayleighDamping",
    "fe_matrices",
    "normalised_damper",
    "physical_damper",
]


@dataclass(frozen=True, slots=True)
class FEMatrices:
    """FE model over the free nodes: ``positions`` [m] shape ``(N-1,)``, the damper node's index,
    stiffness [N/m], mass [kg] and damping [N s/m] as sparse ``(N-1, N-1)`` matrices."""

    positions: NDArray[np.float64]
    damper_index: int
    stiffness: sp.csc_matrix
    mass: sp.csc_matrix
    damping: sp.csc_matrix


def _check_mesh(damper_position: float, elements: int) -> tuple[float, int]:
    x_d = check_finite(damper_position, "damper position x_d")
    if not 0.0 < x_d < 1.0:
        raise ParameterError(f"damper position x_d must lie in (0, 1); got {damper_position!r}")
    n = check_positive_int(elements, "number of elements")
    if n < 2:
        raise ParameterError(f"number of elements must be at least 2; got {elements!r}")
    return x_d, n


def _assemble(
    properties: CableProperties,
    nodes: NDArray[np.float64],
    damper_index: int,
    intrinsic: RayleighDamping | None,
    damper: PointDamper | None,
    mass_kind: MassKind,
) -> tuple[Tridiagonal, Tridiagonal, Tridiagonal]:
    """``(K, M, C)``: string stiffness, string mass plus damper inertance, Rayleigh plus damper."""
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
    if damper is not None:
        mass = mass.with_point(damper_index, damper.inertance)
        damping = damping.with_point(damper_index, damper.damping)
    return stiffness, mass, damping


def fe_matrices(
    properties: CableProperties,
    damper_position: float,
    elements: int,
    *,
    intrinsic_damping: RayleighDamping | None = None,
    damper: PointDamper | None = None,
    mass_matrix: MassKind = "average",
) -> FEMatrices:
    """The cable's FE matrices (the ones :class:`Cable` integrates), e.g. for eigen-analysis.

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
        A grounded point damper at the damper node inside the model, or ``None``.
    mass_matrix
        Element mass matrix; the default ``"average"`` is the recommended one (module docstring),
        the others exist for convergence studies.
    """
    x_d, n = _check_mesh(damper_position, elements)
    if mass_matrix not in ("consistent", "lumped", "average"):
        raise ParameterError(
            f"mass_matrix must be 'consistent', 'lumped' or 'average'; got {mass_matrix!r}"
        )
    nodes, index = mesh_nodes(properties.length, x_d, n)
    k, m, c = _assemble(properties, nodes, index, intrinsic_damping, damper, mass_matrix)
    return FEMatrices(nodes[1:-1].copy(), index, k.to_sparse(), m.to_sparse(), c.to_sparse())


class Cable(Substructure):
    """Taut cable FE model integrated with Newmark average acceleration (see module docstring).

    Parameters
    ----------
    properties
        Length, tension and mass per length.
    damper_position
        Normalised damper (interface) location ``x_d`` in (0, 1), e.g. 0.02 in S0.
    dt
        Fixed time step [s].
    elements
        Number of linear elements ``N`` >= 2 (``N - 1`` free nodes).
    load
        Distributed load (S0 Eq.22); ``None`` for none.
    intrinsic_damping
        Rayleigh damping of the cable (default 0.1 % at modes 1 and 3); ``None`` for none.
    damper
        Point damper inside the model at the damper node (mock RTHS); ``None`` for none.
    use_numba
        Step with the compiled kernel (default) or the NumPy/SciPy reference path.

    Notes
    -----
    ``step(F_k)`` applies the device restoring force ``F_k`` [N] measured at ``t_k`` as the force
    at ``t_{k+1}`` (one-step lag) with the cable receiving ``-F_k``, and returns the damper node's
    kinematics at ``t_{k+1}``.
    """

    def __init__(
        self,
        properties: CableProperties,
        damper_position: float,
        dt: float,
        *,
        elements: int = 100,
        load: DistributedLoad | None = None,
        intrinsic_damping: RayleighDamping | None = RayleighDamping(),
        damper: PointDamper | None = None,
        use_numba: bool = True,
    ) -> None:
        super().__init__(dt)
        x_d, n = _check_mesh(damper_position, elements)
        self.properties = properties
        self.damper_position = x_d
        self.load = load if load is not None else DistributedLoad()
        self.use_numba = bool(use_numba)
        self._nodes, self._index = mesh_nodes(properties.length, x_d, n)
        self._stiffness, self._mass, self._damping = _assemble(
            properties, self._nodes, self._index, intrinsic_damping, damper, "average"
        )
        self._op = newmark_operator(self._stiffness, self._mass, self._damping, self.dt)
        self._l_diag = self._op.factor[0].copy()
        self._l_sub = self._op.factor[1, :-1].copy()
        wavenumber = self.load.mode * math.pi / properties.length
        self._load_shape = self.load.amplitude * sine_load_shape(self._nodes, wavenumber)
        resonance = self.load.mode * properties.omega0
        frequency = self.load.frequency
        self._load_frequency = resonance if frequency is None else frequency
        size = n - 1
        self._u, self._v, self._a = np.zeros(size), np.zeros(size), np.zeros(size)
        self._next = (np.zeros(size), np.zeros(size), np.zeros(size))
        self._k = 0

    # ------------------------------------------------------------------ Substructure contract
    def reset(self) -> None:
        """Return to rest at ``t = 0``."""
        for x in (self._u, self._v, self._a):
            x[:] = 0.0
        self._k = 0

    @property
    def time(self) -> float:
        """Current simulated time [s]."""
        return self._k * self.dt

    @property
    def interface(self) -> Kinematics:
        """Kinematics of the damper node at the current time."""
        i = self._index
        return Kinematics(float(self._u[i]), float(self._v[i]), float(self._a[i]))

    def _step_impl(self, restoring_force: float) -> Kinematics:
        u1, v1, a1 = self._advance(restoring_force, self._next)
        self._next = (self._u, self._v, self._a)
        self._u, self._v, self._a = u1, v1, a1
        self._k += 1
        return self.interface

    def predict(self, restoring_force: float) -> Kinematics:
        """The damper node's kinematics at ``t_{k+1}`` for force ``F`` [N], state unchanged."""
        force = check_finite(restoring_force, "restoring force")
        scratch = (np.empty_like(self._u), np.empty_like(self._u), np.empty_like(self._u))
        u1, v1, a1 = self._advance(force, scratch)
        i = self._index
        return Kinematics(float(u1[i]), float(v1[i]), float(a1[i]))

    def outputs(self) -> dict[str, float]:
        """Midspan displacement [m] and the kinetic and strain energies [J] for logging."""
        return {
            "midspan_displacement": self.displacement_at(0.5),
            "kinetic_energy": self.kinetic_energy,
            "strain_energy": self.strain_energy,
        }

    def _advance(self, force: float, out: _State) -> _State:
        """The state at ``t_{k+1}`` for device force ``force`` [N], written into ``out``."""
        load_scale = math.sin(self._load_frequency * (self._k + 1) * self.dt)
        if not self.use_numba:
            f = load_scale * self._load_shape
            f[self._index] -= force
            return step_reference(self._op, self._u, self._v, self._a, f)
        u1, v1, a1 = out
        m, c = self._mass, self._damping
        step_kernel(
            m.diag, m.off, c.diag, c.off, self._l_diag, self._l_sub, self.dt,
            self._u, self._v, self._a, self._load_shape, load_scale, self._index, -force,
            u1, v1, a1,
        )  # fmt: skip
        return out

    # ------------------------------------------------------------------ state and views
    def nodal_load(self, t: float) -> NDArray[np.float64]:
        """Consistent nodal forces [N] of the distributed load (S0 Eq.22) at time ``t`` [s]."""
        return math.sin(self._load_frequency * check_finite(t, "time t")) * self._load_shape

    def set_state(self, displacement: ArrayLike, velocity: ArrayLike) -> None:
        """Impose nodal displacement [m] and velocity [m/s], shape ``(N-1,)``, at the current time.

        The acceleration is set from equilibrium with the distributed load at the current time
        and no device force, ``M a = f - C v - K u``, so the next step starts consistently.
        """
        u = np.asarray(displacement, dtype=float)
        v = np.asarray(velocity, dtype=float)
        for name, x in (("displacement", u), ("velocity", v)):
            if x.shape != self._u.shape:
                raise ParameterError(
                    f"nodal {name} must have shape {self._u.shape}; got shape {x.shape}"
                )
            if not np.all(np.isfinite(x)):
                raise ParameterError(f"nodal {name} must be finite; got {x[~np.isfinite(x)][0]}")
        rhs = self.nodal_load(self.time) - self._damping.matvec(v) - self._stiffness.matvec(u)
        self._u[:], self._v[:] = u, v
        self._a[:] = sla.solveh_banded(self._mass.banded_lower(), rhs, lower=True)

    @property
    def positions(self) -> NDArray[np.float64]:
        """Coordinates of the free nodes [m], shape ``(N-1,)``."""
        return self._nodes[1:-1].copy()

    @property
    def damper_index(self) -> int:
        """Index of the damper node among the free nodes."""
        return self._index

    @property
    def displacement(self) -> NDArray[np.float64]:
        """Nodal displacements [m], shape ``(N-1,)`` (a copy)."""
        return self._u.copy()

    @property
    def velocity(self) -> NDArray[np.float64]:
        """Nodal velocities [m/s], shape ``(N-1,)`` (a copy)."""
        return self._v.copy()

    @property
    def acceleration(self) -> NDArray[np.float64]:
        """Nodal accelerations [m/s^2], shape ``(N-1,)`` (a copy)."""
        return self._a.copy()

    def displacement_at(self, x: float) -> float:
        """Displacement [m] at the normalised position ``x`` in [0, 1] (linear interpolation)."""
        xi = check_in_range(x, "position x", 0.0, 1.0) * self.properties.length
        return float(np.interp(xi, self._nodes, np.concatenate([[0.0], self._u, [0.0]])))

    @property
    def kinetic_energy(self) -> float:
        """``v^T M v / 2`` [J], including the kinetic energy of an internal inertance."""
        return 0.5 * self._mass.quadratic(self._v)

    @property
    def strain_energy(self) -> float:
        """``u^T K u / 2`` [J], the work done stretching the string."""
        return 0.5 * self._stiffness.quadratic(self._u)

    def modal_frequencies(self, count: int | None = None) -> NDArray[np.float64]:
        """Undamped natural frequencies [rad/s] of the FE model (with internal inertance).

        Parameters
        ----------
        count
            How many of the lowest to return (ascending); all ``N - 1`` when ``None``.
        """
        size = self._u.size
        n = size if count is None else check_positive_int(count, "count")
        if n > size:
            raise ParameterError(f"count must not exceed the {size} free nodes; got {count!r}")
        lam = sla.eigh(
            self._stiffness.to_dense(), self._mass.to_dense(),
            eigvals_only=True, subset_by_index=(0, n - 1),
        )  # fmt: skip
        return np.sqrt(lam)
