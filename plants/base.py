"""Interfaces shared by every plant: numerical substructures, specimens and actuators.

A plant is a fixed-step model of a physical thing.  It knows nothing of zenoh, MCAP, clocks or the
loop: the loop (``rths.runtime.loop``) holds plants through these three interfaces only, so a new damper
model or a new structure is one new module that subclasses one of them.

Time alignment used throughout (loop step ``k`` covers ``[t_k, t_k+1]``)::

    substructure.step(F_k)      -> target r_{k+1}   (kinematics of the interface at t_{k+1})
    compensator.step(r_{k+1}, y_k) -> command u_k   (held constant over [t_k, t_{k+1}])
    actuator.step(u_k)          -> y_{k+1}, F_{k+1} (specimen end and its force at t_{k+1})

Sign convention: the *restoring force* ``F`` of a device is the force that must be applied to its
driven end to impose the motion (``F = m_e * a`` for an ideal inerter); the structure it is attached
to receives ``-F``.  All quantities are SI: m, m/s, m/s^2, N, s.

The public ``step`` methods follow the template of ``scipy.integrate.OdeSolver``: they check the
input and hand off to ``_step_impl`` that subclasses implement.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rths.core.errors import ParameterError, check_positive
from rths.core.kinematics import Kinematics

__all__ = ["Actuator", "Kinematics", "Specimen", "Substructure", "drive"]


def _check_force(value: float, what: str) -> float:
    x = float(value)
    if not math.isfinite(x):
        raise ParameterError(f"{what} must be finite; got {value!r}")
    return x


class Substructure(ABC):
    """A numerical substructure advanced with a fixed step, coupled through one interface DOF.

    The substructure owns its external load (e.g. the distributed load on a cable, the base
    acceleration under a frame); the loop supplies only the restoring force of the device at the
    interface and reads back the interface kinematics (the RTHS *target*).

    Subclass contract
    -----------------
    * ``dt`` [s] is fixed at construction.
    * ``_step_impl(F)`` advances from ``t_k`` to ``t_{k+1} = t_k + dt`` with the device restoring
      force ``F`` [N] (prototype scale) acting on the interface for that step (held over the
      step), and returns the interface kinematics at ``t_{k+1}``.  When the substructure carries a
      nominal interface device (``device_force``), ``F`` is the *correction* on top of it.
    * ``predict(F)`` returns what ``step(F)`` would return without changing any state (for
      look-ahead compensators and checks; the runner also calls it once before the clock starts
      so that compiled kernels are built outside the timed loop).
    * ``reset()`` returns to the initial state (rest, ``t = 0``).
    """

    def __init__(self, dt: float) -> None:
        self.dt: float = check_positive(dt, "time step dt")

    @abstractmethod
    def reset(self) -> None:
        """Return to rest at ``t = 0``."""

    @property
    @abstractmethod
    def time(self) -> float:
        """Current simulated time [s]."""

    @property
    @abstractmethod
    def interface(self) -> Kinematics:
        """Kinematics of the interface DOF at the current time."""

    def step(self, restoring_force: float) -> Kinematics:
        """Advance one step with the device restoring force [N]; return the new interface state."""
        return self._step_impl(_check_force(restoring_force, "restoring force"))

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


class Specimen(ABC):
    """A physical device driven by the displacement of one end (the other end is fixed).

    Subclass contract
    -----------------
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
    * ``reset()`` returns to rest at ``u = v = a = 0``.
    """

    #: Short registry name used in scenario files, e.g. ``"imd"``.
    kind: ClassVar[str] = ""

    @property
    def rigid_inertance(self) -> float:
        """Inertance [kg] acting directly (rigidly) at the driven end."""
        return 0.0

    @property
    def rigid_damping(self) -> float:
        """Viscous coefficient [N s/m] acting directly at the driven end."""
        return 0.0

    @abstractmethod
    def reset(self) -> None:
        """Return to rest."""

    def step(self, u: float, v: float, a: float, dt: float) -> float:
        """Advance to the drive state ``(u, v, a)`` over ``dt`` [s]; return the force [N]."""
        return self._step_impl(float(u), float(v), float(a), float(dt))

    @abstractmethod
    def _step_impl(self, u: float, v: float, a: float, dt: float) -> float:
        """Advance one interval (see the class docstring)."""

    def state(self) -> dict[str, float]:
        """Named internal variables (SI) for logging; empty unless a model has some."""
        return {}


class Actuator(ABC):
    """A servo-hydraulic transfer system: command [m] in, motion of the specimen end out.

    The actuator owns the coupling to its specimen (control-structure interaction, CSI): the
    specimen's force acts back on the actuator's moving mass and hydraulics.

    Subclass contract
    -----------------
    * ``dt`` [s] is fixed at construction; internal sub-steps are the subclass's business.
    * ``_step_impl(u)`` holds the command ``u`` [m] over one step and returns the kinematics of
      the specimen end and the specimen restoring force [N] at the end of the step.  These are
      the *true* values; converters, quantisation and noise live in the lab (``plants.lab``).
    * ``transfer_function()`` returns the linear command→displacement model (python-control
      ``TransferFunction``, continuous time) including the specimen's rigid part, for compensator
      design and for the diagnosis's nominal model.
    * ``reset()`` returns to rest.
    """

    def __init__(self, dt: float) -> None:
        self.dt: float = check_positive(dt, "time step dt")

    @abstractmethod
    def reset(self) -> None:
        """Return to rest."""

    def step(self, command: float) -> tuple[Kinematics, float]:
        """Hold ``command`` [m] for one step; return (specimen-end kinematics, force [N])."""
        return self._step_impl(_check_force(command, "actuator command"))

    @abstractmethod
    def _step_impl(self, command: float) -> tuple[Kinematics, float]:
        """Advance one step (see the class docstring)."""

    @abstractmethod
    def transfer_function(self):  # -> control.TransferFunction (import kept out of hot modules)
        """Linear continuous-time command→displacement model (python-control)."""

    def state(self) -> dict[str, float]:
        """Named internal variables (SI) for logging; empty unless a model has some."""
        return {}


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
    specimen
        The device; it is reset first.
    displacement
        Samples of the drive displacement at uniform spacing ``dt`` [s], shape ``(n,)``.
    velocity, acceleration
        Matching derivatives, shape ``(n,)``.  When omitted they are computed with second-order
        central differences (``numpy.gradient``), which is exact for quadratics and adequate for
        smooth, noise-free drives; filter noisy records before calling.

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
