"""Interfaces shared by every plant: numerical substructures and specimens (the actuator's is
:mod:`plants.actuator.base`).

A plant is a fixed-step model of a physical thing.  It knows nothing of zenoh, MCAP, clocks or the
loop: the loop (``rths.runtime.loop``) holds plants through these three interfaces only, so a new
damper model or a new structure is one new module that subclasses one of them.

Time alignment used throughout (loop step ``k`` covers ``[t_k, t_k+1]``)::

    substructure.step(F_k)      -> target r_{k+1}   (kinematics of the interface at t_{k+1})
    compensator.step(r_{k+1}, y_k) -> command u_k   (held constant over [t_k, t_{k+1}])
    actuator.step(u_k)          -> y_{k+1}, F_{k+1} (specimen end and its force at t_{k+1})

Sign convention: the *restoring force* ``F`` of a device is the force that must be applied to its
driven end to impose the motion (``F = m_e * a`` for an ideal inerter); the structure it is attached
to receives ``-F``.  All quantities are SI: m, m/s, m/s^2, N, s.

The public ``step`` methods follow the template of ``scipy.integrate.OdeSolver``: the base class
counts steps, owns time, checks that inputs and results are finite and hands off to ``_step_impl``
that subclasses implement; ``reset`` is concrete and calls ``_reset_impl``.

Hot-path convention (the loop runs at up to 4096 Hz; every Python call per step counts): a plant
whose step is more than a few float operations runs it as **one compiled call per step** -- a
``numba.njit(cache=True)`` kernel in a private ``kernel.py`` beside the model (e.g.
:mod:`plants.cable.kernel`, :mod:`plants.actuator.kernel`, :mod:`plants.imd.kernels`,
:mod:`controllers.model_based._lqg_kernel`) working on flat float64 arrays the model owns
(constants, state,
outputs).  The kernel writes everything read per step -- the interface kinematics, forces and
the logged channels -- into an output array, so ``step``, ``device_force`` and
``write_channels`` only copy from it.  The readable NumPy/Python path stays as the reference
(``use_numba=False`` / ``use_jit=False``) and a test compares the two step for step: bit for bit
where the arithmetic is the same, else within a stated round-off tolerance.  The base classes
check finiteness once per step on the results (no tuples, no generators).  A plant may also
offer ``compiled_step()`` (:mod:`rths.core.compiled`): its kernel, constants and state arrays, so
that the ``fast`` clock runs whole blocks of loop steps in one fused kernel
(:mod:`rths.runtime.fastpath`); it is tested row by row against the Python path.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rths.core.channels import Channel
from rths.core.errors import (
    NumericalError,
    ParameterError,
    check_positive,
)
from rths.core.kinematics import Kinematics

__all__ = [
    "Kinematics",
    "Specimen",
    "Substructure",
    "check_finite_input",
    "check_finite_output",
    "drive",
]


def check_finite_input(value: float, what: str) -> float:
    """``value`` as a float, or :class:`ParameterError` naming ``what`` if it is not finite.

    Parameters
    ----------
    value
        An input of a step (a force [N] or a command [m]).
    what
        How the error names it.
    """
    x = float(value)
    if not math.isfinite(x):
        raise ParameterError(f"{what} must be finite; got {value!r}")
    return x


def check_finite_output(kinematics: Kinematics, force: float | None, who: object, t: float) -> None:
    """Raise :class:`NumericalError` naming the plant if a result is not finite (inline tests,
    no tuple or generator: this runs on every step).

    Parameters
    ----------
    kinematics
        The motion a step produced.
    force
        The force [N] it produced, or None.
    who
        The plant (named in the error).
    t
        Its time [s] (named in the error).
    """
    isfinite = math.isfinite
    if not (
        isfinite(kinematics.displacement)
        and isfinite(kinematics.velocity)
        and isfinite(kinematics.acceleration)
        and (force is None or isfinite(force))
    ):
        raise NumericalError(
            f"{type(who).__name__} produced a non-finite result at t = {t:.6g} s: "
            f"{kinematics!r}" + ("" if force is None else f", force {force!r}")
        )


class Substructure(ABC):
    """A numerical substructure advanced with a fixed step, coupled through one interface DOF.

    The substructure owns its external load (e.g. the distributed load on a cable, the base
    acceleration under a frame); the loop supplies only the restoring force of the device at the
    interface and reads back the interface kinematics (the RTHS *target*).

    The base class owns the shared work (the template of ``scipy.integrate.OdeSolver.step``):
    :meth:`step` checks the force, calls ``_step_impl``, checks the result is finite and counts
    the step; :attr:`steps` and :attr:`time` follow from that count; :meth:`reset` zeroes it and
    calls ``_reset_impl``.

    Parameters
    ----------
    dt : float
        Fixed integration time step [s], > 0 (the loop period at which :meth:`step` is called).

    Subclass contract
    -----------------
    * Call ``super().__init__(dt)``; ``dt`` [s] is fixed at construction.
    * ``_step_impl(F)`` advances from ``t_k = steps * dt`` to ``t_{k+1}`` with the device
      restoring force ``F`` [N] (prototype scale, finite) acting on the interface for that step
      (held over the step), and returns the interface kinematics at ``t_{k+1}``.  While it runs,
      :attr:`steps` is still ``k``.  When the substructure carries a nominal interface device
      (``device_force``), ``F`` is the *correction* on top of it.
    * ``predict(F)`` returns what ``step(F)`` would return without changing any state (for
      look-ahead compensators and checks; the runner also calls it once before the clock starts
      so that compiled kernels are built outside the timed loop).
    * ``_reset_impl()`` returns the model to its initial state (rest).
    * ``interface`` gives the interface kinematics now; ``outputs()`` named responses to log.
    """

    def __init__(self, dt: float) -> None:
        self.dt: float = check_positive(dt, "time step dt")
        self._steps = 0

    @property
    def steps(self) -> int:
        """Steps taken since construction or the last :meth:`reset`."""
        return self._steps

    @property
    def time(self) -> float:
        """Current simulated time [s] (``steps * dt``, exact: no accumulated rounding)."""
        return self._steps * self.dt

    def reset(self) -> None:
        """Return to rest at ``t = 0``."""
        self._steps = 0
        self._reset_impl()

    @abstractmethod
    def _reset_impl(self) -> None:
        """Return the model's state to rest (the step count is the base class's)."""

    @property
    @abstractmethod
    def interface(self) -> Kinematics:
        """Kinematics of the interface DOF at the current time."""

    def step(self, restoring_force: float) -> Kinematics:
        """Advance one step with the device restoring force [N]; return the new interface state.

        Raises
        ------
        ParameterError
            If the force is not finite.
        NumericalError
            If the model's result is not finite (the run diverged).
        """
        kinematics = self._step_impl(check_finite_input(restoring_force, "restoring force"))
        self._steps += 1
        check_finite_output(kinematics, None, self, self.time)
        return kinematics

    @abstractmethod
    def _step_impl(self, restoring_force: float) -> Kinematics:
        """Advance one step (see the class docstring)."""

    @abstractmethod
    def predict(self, restoring_force: float) -> Kinematics:
        """The interface state one step ahead with the given force, without committing it."""

    @property
    def device_force(self) -> float:
        """Restoring force [N] of the nominal interface device the substructure carries
        implicitly at the current time (0 when it carries none).

        The loop feeds back only the correction ``measured force - device_force``: the nominal
        device is integrated with the structure (unconditionally stable) and the physical
        specimen supplies its departure from it (see :mod:`rths.runtime.loop`).
        """
        return 0.0

    def outputs(self) -> dict[str, float]:
        """Named response quantities (SI) for logging, e.g. the displacement at a monitoring
        point; empty unless a substructure defines some."""
        return {}

    def channels(self) -> tuple[Channel, ...]:
        """The logged channels, in the order :meth:`write_channels` writes them.  Default: the
        keys of :meth:`outputs` (no unit declared); a substructure on the real-time path
        declares its own and overrides :meth:`write_channels`."""
        return tuple(Channel(name, "?", "substructure output") for name in self.outputs())

    def write_channels(self, out: NDArray[np.float64]) -> None:
        """Write this step's values of :meth:`channels` into ``out`` (a slice of the loop's
        preallocated row).  Default: from :meth:`outputs` (slow: a dict per step)."""
        out[:] = tuple(self.outputs().values())


class Specimen(ABC):
    """A physical device driven by the displacement of one end (the other end is fixed).

    The base class owns the shared work: :meth:`step` checks the drive state and the time step,
    calls ``_step_impl``, checks the force is finite and counts the step; :meth:`reset` zeroes
    the count and calls ``_reset_impl``.

    Subclass contract
    -----------------
    * Call ``super().__init__()``.
    * ``_step_impl(u, v, a, dt)`` advances the internal state from the previous drive state to the
      new one -- displacement ``u`` [m], velocity ``v`` [m/s], acceleration ``a`` [m/s^2] of the
      driven end at the end of an interval of ``dt`` [s] -- and returns the restoring force [N]
      at the end of the interval.  Between the two drive states a model may interpolate (cubic
      Hermite in ``u``, ``v``) to take internal sub-steps; it chooses how many from its own
      stiffness, so callers may use any ``dt``.
    * ``rigid_inertance`` [kg] and ``rigid_damping`` [N s/m] expose the part of the force that is
      exactly ``m_r * a + c_r * v`` at the driven end.  An actuator model integrates that part
      implicitly with its own moving mass (an inerter of 1.6 t behind a 29 kg piston cannot be
      coupled explicitly) and feeds back only the remainder ``F - m_r*a - c_r*v``.
    * ``state()`` returns named internal variables for logging (may be empty).
    * ``_reset_impl()`` returns to rest at ``u = v = a = 0``.

    A new damper model is one module: subclass this, give the constructor's parameters as a frozen
    options dataclass and register the class with ``@SPECIMENS.register("my_kind", MyOptions)``
    (:mod:`rths.core.registry`); scenario files then name it ``[specimen] kind = "my_kind"``.
    """

    #: Registry name used in scenario files, e.g. ``"imd"`` (set by the registry decorator).
    kind: ClassVar[str] = ""

    def __init__(self) -> None:
        self._steps = 0

    @property
    def steps(self) -> int:
        """Steps taken since construction or the last :meth:`reset`."""
        return self._steps

    @property
    def rigid_inertance(self) -> float:
        """Inertance [kg] acting directly (rigidly) at the driven end."""
        return 0.0

    @property
    def rigid_damping(self) -> float:
        """Viscous coefficient [N s/m] acting directly at the driven end."""
        return 0.0

    def reset(self) -> None:
        """Return to rest."""
        self._steps = 0
        self._reset_impl()

    @abstractmethod
    def _reset_impl(self) -> None:
        """Return the model's state to rest (the step count is the base class's)."""

    def step(self, u: float, v: float, a: float, dt: float) -> float:
        """Advance to the drive state ``(u, v, a)`` over ``dt`` [s]; return the force [N].

        Raises
        ------
        ParameterError
            If the drive state is not finite or ``dt`` is not positive.
        NumericalError
            If the model's force is not finite.
        """
        u, v, a, dt = float(u), float(v), float(a), float(dt)
        if not math.isfinite(u + v + a):
            raise ParameterError(
                f"{type(self).__name__} drive state must be finite; got u={u!r} m, v={v!r} m/s, "
                f"a={a!r} m/s^2"
            )
        if not (0.0 < dt < math.inf):
            raise ParameterError(f"time step dt must be positive; got {dt!r}")
        force = self._step_impl(u, v, a, dt)
        self._steps += 1
        if not math.isfinite(force):
            raise NumericalError(
                f"{type(self).__name__} produced a non-finite force {force!r} at step "
                f"{self._steps} (u={u!r} m, v={v!r} m/s)"
            )
        return force

    @abstractmethod
    def _step_impl(self, u: float, v: float, a: float, dt: float) -> float:
        """Advance one interval (see the class docstring)."""

    def state(self) -> dict[str, float]:
        """Named internal variables (SI) for logging; empty unless a model has some."""
        return {}

    def channels(self) -> tuple[Channel, ...]:
        """The logged channels (default: the keys of :meth:`state`, no unit declared)."""
        return tuple(Channel(name, "?", "specimen state") for name in self.state())

    def write_channels(self, out: NDArray[np.float64]) -> None:
        """Write the values of :meth:`channels` into ``out`` (default: from :meth:`state`)."""
        out[:] = tuple(self.state().values())


def drive(
    specimen: Specimen,
    displacement: ArrayLike,
    dt: float,
    velocity: ArrayLike | None = None,
    acceleration: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """Force history [N] of a specimen driven through a displacement history [m].

    Parameters
    ----------
    specimen : Specimen
        The device; it is reset first.
    displacement : array_like
        Samples of the drive displacement [m] at uniform spacing ``dt``, shape ``(n,)``.
    dt : float
        Sample spacing [s], > 0; also the ``dt`` of every :meth:`Specimen.step`.
    velocity, acceleration : array_like or None, default None
        Matching derivatives [m/s] and [m/s^2], shape ``(n,)``.  When omitted they are computed
        with second-order central differences (``numpy.gradient``), which is exact for
        quadratics and adequate for smooth, noise-free drives; filter noisy records before
        calling.

    Returns
    -------
    numpy.ndarray
        Restoring force at each sample, shape ``(n,)``; sample 0 is the force at rest state
        reached by stepping from zero to the first drive sample.
    """
    dt = check_positive(dt, "time step dt")
    u = np.asarray(displacement, dtype=float)
    if u.ndim != 1 or u.size == 0:
        raise ParameterError(f"displacement must be a non-empty 1-D array; got shape {u.shape}")
    v = np.gradient(u, dt) if velocity is None else np.asarray(velocity, dtype=float)
    a = np.gradient(v, dt) if acceleration is None else np.asarray(acceleration, dtype=float)
    if v.shape != u.shape or a.shape != u.shape:
        raise ParameterError(
            f"velocity/acceleration must have the displacement's shape {u.shape}; "
            f"got {v.shape} and {a.shape}"
        )
    specimen.reset()
    force = np.empty_like(u)
    for i in range(u.size):
        force[i] = specimen.step(u[i], v[i], a[i], dt)
    return force
