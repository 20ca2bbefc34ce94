"""Taut stay cable: the numerical substructure of the seed RTHS (S0 §5.1, design.md §5).

The cable is a taut string of length ``L`` [m], tension ``T`` [N] and mass per length ``m``
[kg/m], fixed at both ends, with a transverse damper at ``x_d = xbar_d/L`` (S0 Eq.23).  It is
discretised with linear two-node elements that put a node exactly at the damper and are uniform
on each side of it, and integrated with Newmark's average-acceleration rule.

The modelling choices, with the evidence, are in the package docstring (:mod:`plants.cable`).

The effective matrix ``K + 2/h C + 4/h^2 M`` is factorised once (banded Cholesky) and each step
is one fused O(N) pass compiled with numba (``use_numba=False`` selects the NumPy/SciPy
reference path, which gives the same numbers).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg as sla
from numpy.typing import ArrayLike, NDArray

from plants.base import Kinematics, Substructure
from plants.cable.device import (
    FEMatrices,
    SeriesCondensation,
    augmented_matrices,
    elements_for,
    fe_matrices,
    max_element_size,
)
from plants.cable.fe import assemble, check_mesh, mesh_nodes, sine_load_shape
from plants.cable.kernel import cable_step, outputs_reference
from plants.cable.newmark import newmark_operator, step_reference
from plants.cable.options import CableOptions
from plants.cable.properties import (
    CableProperties,
    DistributedLoad,
    InterfaceDevice,
    PointDamper,
    RayleighDamping,
    normalised_damper,
    normalised_stiffness,
    physical_damper,
    physical_stiffness,
)
from plants.device_model import DeviceModel
from rths.core.channels import Channel
from rths.core.compiled import CompiledStep
from rths.core.errors import (
    ParameterError,
    check_finite,
    check_in_range,
    check_positive_int,
)
from rths.core.registry import SUBSTRUCTURES

__all__ = [
    "CABLE_CHANNELS",
    "Cable",
    "CableProperties",
    "DistributedLoad",
    "FEMatrices",
    "InterfaceDevice",
    "PointDamper",
    "RayleighDamping",
    "elements_for",
    "fe_matrices",
    "max_element_size",
    "normalised_damper",
    "normalised_stiffness",
    "physical_damper",
    "physical_stiffness",
]


#: The cable's logged channels (:meth:`Cable.channels` takes the first 1, 2 or 4).
CABLE_CHANNELS: tuple[Channel, ...] = (
    Channel("midspan_displacement", "m", "cable displacement at midspan"),
    Channel("device_force", "N", "restoring force of the nominal device"),
    Channel("flywheel_displacement", "m", "nominal device's flywheel"),
    Channel("flywheel_velocity", "m/s", "nominal device's flywheel"),
)


@SUBSTRUCTURES.register("cable", CableOptions)
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
        Number of linear elements ``N`` >= 2 (``N - 1`` free nodes).  With a series device
        branch, see :func:`elements_for` for the mesh rule.
    load
        Distributed load (S0 Eq.22); ``None`` for none.
    intrinsic_damping
        Rayleigh damping of the cable (default 0.1 % at modes 1 and 3); ``None`` for none.
    damper
        Nominal interface device inside the model (:class:`InterfaceDevice`; the old
        :data:`PointDamper` is the same class); ``None`` for none.
    use_numba
        Step with the compiled kernel (default) or the NumPy/SciPy reference path.

    Attributes
    ----------
    device
        The nominal interface device (``damper``), or ``None``.

    Notes
    -----
    ``step(F_k)`` applies the force ``F_k`` [N] measured at ``t_k`` as the force at ``t_{k+1}``
    (one-step lag) with the cable receiving ``-F_k``, and returns the damper node's kinematics
    at ``t_{k+1}``.  With a device, ``F_k`` is the correction on top of :attr:`device_force`.
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
        damper: InterfaceDevice | None = None,
        use_numba: bool = True,
    ) -> None:
        super().__init__(dt)
        x_d, n = check_mesh(damper_position, elements)
        load = load if load is not None else DistributedLoad()
        omega = load.mode * properties.omega0 if load.frequency is None else load.frequency
        if load.amplitude and omega * self.dt >= math.pi:
            raise ParameterError(
                f"load frequency {omega / (2 * math.pi):.6g} Hz (mode {load.mode}) must lie below "
                f"the Nyquist frequency {0.5 / self.dt:g} Hz of the loop rate"
            )
        self.properties = properties
        self.damper_position = x_d
        self.device = damper
        self.load = load
        self.use_numba = bool(use_numba)
        self._nodes, self._index = mesh_nodes(properties.length, x_d, n)
        self._stiffness, self._mass, self._damping = assemble(
            properties, self._nodes, self._index, intrinsic_damping, damper, "average"
        )
        self._series: SeriesCondensation | None = None
        # the kernel's constants (plants.cable.kernel.PARAMS); k_s = 0: no series branch
        self._params = np.zeros(11)
        self._params[0] = self.dt
        if damper is not None:
            self._params[5:9] = (damper.inertance, damper.damping, damper.stiffness, 1.0)
        effective_stiffness = self._stiffness
        if damper is not None and damper.has_series:
            self._series = cs = SeriesCondensation.of(damper, self.dt)
            self._params[1:5] = (cs.stiffness, cs.inertance, cs.damping, cs.denominator)
            # the condensed flywheel's constant k_s (1 - k_s/D) enters the effective matrix only
            effective_stiffness = self._stiffness.with_point(self._index, cs.diagonal)
        self._op = newmark_operator(effective_stiffness, self._mass, self._damping, self.dt)
        wavenumber = self.load.mode * math.pi / properties.length
        self._load_shape = self.load.amplitude * sine_load_shape(self._nodes, wavenumber)
        mid = int(np.searchsorted(self._nodes, 0.5 * properties.length, side="right")) - 1
        mid = min(mid, len(self._nodes) - 2)
        span = self._nodes[mid + 1] - self._nodes[mid]
        self._midspan = (mid, (0.5 * properties.length - self._nodes[mid]) / span)
        self._params[9:11] = self._midspan
        # the compiled step's operator (plants.cable.kernel): one array, one dispatch
        size = n - 1
        self._ops = np.zeros((7, size))
        for row, values in enumerate(
            (
                self._mass.diag,
                self._mass.off,
                self._damping.diag,
                self._damping.off,
                self._op.factor[0],
                self._op.factor[1, :-1],
                self._load_shape,
            )
        ):
            self._ops[row, : values.size] = values
        resonance = self.load.mode * properties.omega0
        frequency = self.load.frequency
        self._load_frequency = resonance if frequency is None else frequency
        self._load_end = math.inf if self.load.duration is None else self.load.duration
        # two state buffers (u, v, a, flywheel (x [m], x' [m/s], x'' [m/s^2]) in row 3), the
        # current one by parity; the flywheel is zero without a series branch
        self._state = np.zeros((2, 4, size))
        self._views = tuple(
            (buf[0], buf[1], buf[2], buf[3, :3]) for buf in (self._state[0], self._state[1])
        )
        self._parity = 0
        self._u, self._v, self._a, self._fly = self._views[0]
        self._out = np.zeros(7)  # plants.cable.kernel.OUTPUTS of the current state

    @classmethod
    def from_options(
        cls, options: CableOptions, *, dt: float, device: InterfaceDevice | None = None, **_: object
    ) -> Cable:
        """The ``cable`` kind: the cable of ``options`` carrying the nominal ``device``.

        With ``elements = "auto"`` the mesh is the finest of 100 elements and what the device's
        series stiffness needs for the damper node to radiate (:func:`elements_for`).
        """
        props = CableProperties(options.length, options.tension, options.mass_per_length)
        n = options.elements
        if n == "auto":
            stiff = device.series_stiffness if device is not None and device.has_series else None
            n = elements_for(props, options.damper_position, stiff, minimum=100)
        load = options.load
        omega = None if load.frequency is None else 2.0 * math.pi * load.frequency
        damping = options.intrinsic_damping
        return cls(
            props,
            options.damper_position,
            dt,
            elements=n,
            load=DistributedLoad(load.amplitude, load.mode, omega, load.duration),
            intrinsic_damping=RayleighDamping(damping) if damping else None,
            damper=device,
        )

    @staticmethod
    def nominal_device(model: DeviceModel | None) -> InterfaceDevice | None:
        """The interface device (prototype scale) for a ``[model]`` of kind ``imd`` or
        ``linear`` (S0 Eq.1, or Eq.12 with a series stiffness); None for none.

        Raises
        ------
        ParameterError
            For a model kind a cable cannot carry (``inerter``).
        """
        if model is None:
            return None
        if model.kind not in ("imd", "linear"):
            raise ParameterError(
                f"a cable substructure takes a model of kind 'imd' or 'linear' (or 'none'); "
                f"got {model.kind!r}"
            )
        if model.series_stiffness is None:
            return InterfaceDevice(
                inertance=model.inertance, damping=model.damping, stiffness=model.stiffness
            )
        return InterfaceDevice(
            series_stiffness=model.series_stiffness,
            series_inertance=model.inertance,
            series_damping=model.damping,
        )

    # ------------------------------------------------------------------ Substructure contract
    def _reset_impl(self) -> None:
        """Return to rest at ``t = 0``."""
        self._state[:] = 0.0
        self._out[:] = 0.0
        self._parity = 0
        self._u, self._v, self._a, self._fly = self._views[0]

    @property
    def interface(self) -> Kinematics:
        """Kinematics of the damper node at the current time."""
        i = self._index
        return Kinematics(float(self._u[i]), float(self._v[i]), float(self._a[i]))

    @property
    def device_force(self) -> float:
        """Restoring force [N] of the nominal device at the current time (0 without one):
        ``m_r a_d + c_r v_d + k_r u_d + k_s (u_d - x)`` (S0 Eq.1 and Eq.12); the cable receives
        minus it."""
        return float(self._out[4])

    def _step_impl(self, restoring_force: float) -> Kinematics:
        self._advance(restoring_force, self._state, self._parity, self._out)
        self._parity ^= 1
        self._u, self._v, self._a, self._fly = self._views[self._parity]
        return Kinematics(*self._out[:3].tolist())

    def predict(self, restoring_force: float) -> Kinematics:
        """The damper node's kinematics at ``t_{k+1}`` for force ``F`` [N], state unchanged."""
        force = check_finite(restoring_force, "restoring force")
        scratch, out = self._state.copy(), np.zeros(7)
        self._advance(force, scratch, self._parity, out)
        return Kinematics(*out[:3].tolist())

    def outputs(self) -> dict[str, float]:
        """Midspan displacement [m] and, with a device, its restoring force [N] and the flywheel
        displacement [m] and velocity [m/s], for logging every step (cheap: O(1))."""
        values = self._out[3:].tolist()  # O(1) per step: energies are computed on demand
        return dict(zip((c.name for c in self.channels()), values))

    def channels(self) -> tuple[Channel, ...]:
        """The keys of :meth:`outputs`, with units (:data:`CABLE_CHANNELS`: the device's only
        with a device, the flywheel's only with a series branch)."""
        n = 1 + (self.device is not None) + 2 * (self._series is not None)
        return CABLE_CHANNELS[:n]

    def write_channels(self, out: NDArray[np.float64]) -> None:
        """Write :meth:`outputs`' values into ``out`` (no dict)."""
        out[:] = self._out[3 : 3 + out.size]

    def compiled_step(self) -> CompiledStep | None:
        """This cable for the loop's fused kernel (family ``"cable"``: constants ``ops, params,
        cfg``, state ``state, out, counters`` of :func:`plants.cable.kernel.cable_loop_step`);
        None on the reference path."""
        if not self.use_numba:
            return None
        cfg = np.array([self._index, self._load_frequency, self._load_end, self.dt])
        counters = np.array([float(self._steps), float(self._parity)])

        def commit() -> None:
            self._steps, self._parity = int(counters[0]), int(counters[1])
            self._u, self._v, self._a, self._fly = self._views[self._parity]

        state = (self._state, self._out, counters)
        return CompiledStep("cable", (self._ops, self._params, cfg), state, commit)

    def _advance(
        self, force: float, state: NDArray[np.float64], parity: int, out: NDArray[np.float64]
    ) -> None:
        """Advance ``state[parity]`` to ``state[1 - parity]`` for the device force ``force``
        [N] and write the outputs (:data:`plants.cable.kernel.OUTPUTS`) into ``out``."""
        load_scale = math.sin(self._load_frequency * (self.steps + 1) * self.dt)
        if (self.steps + 1) * self.dt > self._load_end:  # the load has stopped
            load_scale = 0.0
        j, series = self._index, self._series
        if self.use_numba:
            cable_step(self._ops, state, parity, self._params, j, load_scale, -force, out)
            return
        u, v, a, fly = (state[parity, r] for r in range(4))
        nxt = state[1 - parity]
        f = load_scale * self._load_shape
        f[j] -= force
        if series is not None:
            r_x = series.flywheel_load(fly[:3])
            f[j] += series.node_load(r_x)
        nxt[0], nxt[1], nxt[2] = step_reference(self._op, u, v, a, f)
        if series is not None:
            series.advance(fly[:3], r_x, float(nxt[0, j]), nxt[3, :3])
        outputs_reference(nxt[0], nxt[1], nxt[2], nxt[3, :3], self._params, j, out)

    # ------------------------------------------------------------------ state and views
    def nodal_load(self, t: float) -> NDArray[np.float64]:
        """Consistent nodal forces [N] of the distributed load (S0 Eq.22) at time ``t`` [s]."""
        t = check_finite(t, "time t")
        scale = math.sin(self._load_frequency * t) if t <= self._load_end else 0.0
        return scale * self._load_shape

    def set_state(
        self,
        displacement: ArrayLike,
        velocity: ArrayLike,
        *,
        flywheel: tuple[float, float] | None = None,
    ) -> None:
        """Impose nodal displacement [m] and velocity [m/s], shape ``(N-1,)``, at the current time.

        ``flywheel = (x [m], x' [m/s])`` sets a series branch's flywheel; by default its spring is
        unstretched and it moves with the damper node (``x = u_d``, ``x' = v_d``).  Without
        flywheel inertance its velocity follows from ``c_s x' = k_s (u_d - x)`` and the given
        one is ignored.  Accelerations are set from equilibrium with the distributed load at the
        current time and no correction force, ``M a = f - C v - K u`` (with the spring's force
        on the node), so the next step starts consistently.
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
        series, j = self._series, self._index
        if series is None and flywheel is not None:
            raise ParameterError(
                f"a flywheel state needs a device with a series branch; got flywheel={flywheel!r}"
            )
        if series is not None:
            self._fly[:] = series.consistent_state(float(u[j]), float(v[j]), flywheel)
            rhs[j] -= series.stiffness * (u[j] - self._fly[0])
        self._u[:], self._v[:] = u, v
        self._a[:] = sla.solveh_banded(self._mass.banded_lower(), rhs, lower=True)
        outputs_reference(self._u, self._v, self._a, self._fly, self._params, j, self._out)

    @property
    def flywheel(self) -> Kinematics | None:
        """Displacement [m], velocity [m/s], acceleration [m/s^2] of the series branch's flywheel
        at the current time; ``None`` without a series branch."""
        if self._series is None:
            return None
        return Kinematics(*(float(x) for x in self._fly))

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
        """``v^T M v / 2`` [J], including the device's rigid inertance, plus the flywheel's
        ``m_s x'^2/2``."""
        energy = 0.5 * self._mass.quadratic(self._v)
        if self._series is not None:
            energy += 0.5 * self._series.inertance * self._fly[1] ** 2
        return float(energy)

    @property
    def strain_energy(self) -> float:
        """``u^T K u / 2`` [J], the work done stretching the string (and a grounded device
        spring ``k_r u_d^2/2``), plus the series spring's ``k_s (u_d - x)^2/2``."""
        energy = 0.5 * self._stiffness.quadratic(self._u)
        if self._series is not None:
            energy += 0.5 * self._series.stiffness * (self._u[self._index] - self._fly[0]) ** 2
        return float(energy)

    def modal_frequencies(self, count: int | None = None) -> NDArray[np.float64]:
        """Undamped natural frequencies [rad/s] of the FE model with the device's inertances.

        A series branch with flywheel inertance adds its DOF (one more frequency, near the
        branch's own ``sqrt(k_s/m_s)`` for a stiff cable); without inertance the undamped branch
        carries no force and adds nothing.

        Parameters
        ----------
        count
            How many of the lowest to return (ascending); all of them when ``None``.
        """
        k, m = self._stiffness.to_dense(), self._mass.to_dense()
        what = "free nodes"
        if self._series is not None and self._series.inertance > 0.0:
            device: InterfaceDevice = self.device  # type: ignore[assignment]
            fe_k, fe_m, _ = augmented_matrices(
                self._stiffness, self._mass, self._damping, self._index, device
            )
            k, m, what = fe_k.toarray(), fe_m.toarray(), "DOFs (free nodes and the flywheel)"
        size = k.shape[0]
        n = size if count is None else check_positive_int(count, "count")
        if n > size:
            raise ParameterError(f"count must not exceed the {size} {what}; got {count!r}")
        lam = sla.eigh(k, m, eigvals_only=True, subset_by_index=(0, n - 1))
        return np.sqrt(lam)
