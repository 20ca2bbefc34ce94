"""Inertial mass damper (IMD) specimen models (seed S0: Lu et al., cable + IMD, RTHS).

Two models share one parameter set, :class:`IMDParameters`, in which every effect is switched on
or off (see its table); any combination works at once, so the emulated lab can carry effects the
numerical model does not know about.

* :class:`SimplifiedIMD` (``kind = "imd_simplified"``) -- S0 Eq.1, the rigid device
  ``F = m_e u'' + c_d u' + F_r sign(u')``.  Its inertance and damping are exposed as
  ``rigid_inertance`` / ``rigid_damping`` so an actuator can integrate them implicitly.
* :class:`InternalStiffnessIMD` (``kind = "imd_internal"``) -- S0 Eq.12 as intended,
  ``F = k_e (u_d - x_i)``, ``m_e x_i'' + c_d x_i' + k_e (x_i - u_d) = 0``, with the variant
  stiffness of Eq.4, a backlash dead zone of total clearance ``h_d`` in series with the spring
  (the force path is open and the flywheel coasts while the gap is crossed, cf. S1 Eq.11) and
  Coulomb friction at the driven end.  Nothing is rigid: ``rigid_inertance = rigid_damping = 0``.

Both take ``c_d`` either fixed or from the amplitude law ``xi_e(A)`` of S0 Eq.18 with an online
amplitude estimate (:mod:`plants.imd.amplitude`: half the peak-to-peak drive between its last
two reversals; 0 -- hence ``xi_e = 0.3`` -- until two reversals have been seen).  Friction is
regularised as ``F_r tanh(u'/v_eps)`` (``IMDParameters.friction_velocity``, default 1 mm/s).

Sub-steps (series model): ``n_sub = ceil(dt * max(sqrt(k_max/m_e), c_d/m_e) / theta)`` with
``theta = 0.2`` rad, i.e. the fastest internal eigenvalue times the sub-step stays <= 0.2, where
RK4 loses < 1e-6 of the oscillator energy per sub-step and the phase error is < 3e-6 rad.
Type II at 1-8 kHz needs one sub-step; the default 100 Hz backlash contact needs 1-4.

Use::

    p = IMDParameters.preset("type_ii", friction=40.0)     # Table 4 + friction
    lab = imd_from_parameters(p)                            # every switched-on effect
    sim = SimplifiedIMD(p)                                  # what the numerical model knows
    F = lab.step(u, v, a, dt)

Adding a damper model (an afternoon): one new module in ``plants/`` with a
:class:`plants.base.Specimen` subclass -- ``_step_impl(u, v, a, dt)`` returning the restoring
force [N], ``_reset_impl``, ``state()``, a ``from_options`` classmethod -- registered with
``@SPECIMENS.register("<kind>", <frozen options dataclass>)`` (:mod:`rths.core.registry`); plus
oracle tests.  Reuse the shared pieces where they fit: the amplitude tracker,
:func:`plants.imd.kernels.regularised_sign`, the Hermite drive and RK4 loop of
:func:`plants.imd.kernels.advance_flywheel`.  The README shows a complete toy example.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from plants.base import Specimen
from plants.imd import step_kernel
from plants.imd.amplitude import AmplitudeTracker
from plants.imd.kernels import advance_flywheel, advance_flywheel_jit, regularised_sign
from plants.imd.parameters import (
    CONTACT_FREQUENCY_HZ,
    AmplitudeDamping,
    IMDParameters,
    ball_screw_stiffness,
    damping_from_ratio,
    screw_series_stiffness,
)
from rths.core.channels import Channel
from rths.core.compiled import CompiledStep
from rths.core.errors import ParameterError, check_positive, format_choices
from rths.core.registry import SPECIMENS

__all__ = [
    "CONTACT_FREQUENCY_HZ",
    "imd",
    "MAX_STEP_PHASE",
    "AmplitudeDamping",
    "IMDParameters",
    "InternalStiffnessIMD",
    "SimplifiedIMD",
    "ball_screw_stiffness",
    "damping_from_ratio",
    "imd_from_parameters",
    "screw_series_stiffness",
]

_DAMPING_CHANNELS = (
    Channel("damping", "N s/m", "equivalent damping coefficient c_d"),
    Channel("amplitude", "m", "drive amplitude estimate behind S0 Eq.18"),
)
_SERIES_CHANNELS = (
    Channel("flywheel_displacement", "m", "flywheel displacement x_i"),
    Channel("flywheel_velocity", "m/s", "flywheel velocity"),
    Channel("spring_force", "N", "force through the series spring"),
    Channel("friction_force", "N", "Coulomb friction force at the driven end"),
    Channel("force_fluctuation", "N", "S0 Eq.15: F - m_e u'' - c_d u' without friction"),
    Channel("gap_open", "1", "1 while the backlash gap is crossed, else 0"),
    Channel("stiffness", "N/m", "series stiffness k_e (S0 Eq.4)"),
    _DAMPING_CHANNELS[0],
    _DAMPING_CHANNELS[1],
)

#: Largest ``|lambda| * dt_sub`` [rad] the series model allows per RK4 sub-step.
MAX_STEP_PHASE: float = 0.2


def _check_dt(dt: float) -> float:
    if not dt > 0.0:  # also rejects NaN
        raise ParameterError(f"time step dt must be positive; got {dt!r}")
    return dt


class _DampingMixin:
    """Fixed ``c_d`` or ``c_d(A)`` from S0 Eq.18 with the online amplitude estimate."""

    parameters: IMDParameters
    _tracker: AmplitudeTracker | None
    _damping: float

    def _init_damping(self) -> None:
        law = self.parameters.damping_law
        self._tracker = (
            None if law is None else AmplitudeTracker(law.reversal_tolerance, law.reversal_fraction)
        )
        self._damping = self.parameters.damping_coefficient(0.0)

    def _reset_damping(self) -> None:
        if self._tracker is not None:
            self._tracker.reset()
        self._damping = self.parameters.damping_coefficient(0.0)

    def _observe_drive(self, u: float) -> None:
        """Feed the drive displacement [m]; ``c_d`` changes only at reversals."""
        if self._tracker is not None and self._tracker.update(u):
            self._damping = self.parameters.damping_coefficient(self._tracker.amplitude)

    @property
    def amplitude(self) -> float:
        """Current load-amplitude estimate [m] (0 without a damping law)."""
        return 0.0 if self._tracker is None else self._tracker.amplitude

    @property
    def damping(self) -> float:
        """Current equivalent damping coefficient ``c_d`` [N s/m]."""
        return self._damping


@SPECIMENS.register("imd_simplified", IMDParameters)
class SimplifiedIMD(_DampingMixin, Specimen):
    """The simplified IMD, S0 Eq.1: ``F = m_e u'' + c_d u' + F_r tanh(u'/v_eps)``.

    Uses ``inertance``, ``damping``/``damping_law`` and ``friction`` of the parameter set and
    ignores the series effects (internal stiffness, backlash): it is their rigid limit.

    Parameters
    ----------
    parameters
        The damper; ``stiffness`` is used only to turn a damping law into ``c_d``.

    Notes
    -----
    With a damping law ``rigid_damping`` changes at drive reversals; read it every step (or
    keep the value read once -- the difference is then part of the remainder force, which is
    still correct, only explicit).
    """

    def __init__(self, parameters: IMDParameters) -> None:
        super().__init__()
        self.parameters: IMDParameters = parameters
        self._init_damping()
        self._friction = parameters.friction
        self._v_eps = parameters.friction_velocity

    @classmethod
    def from_options(cls, options: IMDParameters, **_: object) -> SimplifiedIMD:
        """The registered kind: the model of ``options``."""
        return cls.from_parameters(options)

    @classmethod
    def from_parameters(cls, parameters: IMDParameters) -> SimplifiedIMD:
        """The model for a parameter set (the registry's uniform constructor)."""
        return cls(parameters)

    @property
    def rigid_inertance(self) -> float:
        """``m_e`` [kg]: the whole inertance acts rigidly at the driven end."""
        return self.parameters.inertance

    @property
    def rigid_damping(self) -> float:
        """Current ``c_d`` [N s/m]: the whole damping acts rigidly at the driven end."""
        return self._damping

    def _reset_impl(self) -> None:
        """Return to rest and forget the amplitude estimate."""
        self._reset_damping()

    def _step_impl(self, u: float, v: float, a: float, dt: float) -> float:
        _check_dt(dt)
        force = self.parameters.inertance * a + self._damping * v
        if self._friction > 0.0:
            force += self._friction * regularised_sign(v, self._v_eps)
        self._observe_drive(u)
        return force

    def compiled_step(self) -> CompiledStep:
        """This model for the loop's fused kernel (:mod:`plants.imd.step_kernel`)."""
        return step_kernel.pack(self, series=False)

    def state(self) -> dict[str, float]:
        """``damping`` [N s/m] and ``amplitude`` [m] (the estimate behind S0 Eq.18)."""
        return {"damping": self._damping, "amplitude": self.amplitude}

    def channels(self) -> tuple[Channel, ...]:
        """The keys of :meth:`state`, with units."""
        return _DAMPING_CHANNELS

    def write_channels(self, out: NDArray[np.float64]) -> None:
        """:meth:`state`'s values, no dict."""
        out[0] = self._damping
        out[1] = self.amplitude


@SPECIMENS.register("imd_internal", IMDParameters)
class InternalStiffnessIMD(_DampingMixin, Specimen):
    """IMD with internal stiffness, S0 Eq.12 (+ Eq.4, Eq.18, backlash and friction).

    .. math::

        F = k_e(u_d)\\,\\mathrm{dz}(u_d - x_i, h_d/2) + F_r \\tanh(\\dot u_d/v_\\epsilon), \\qquad
        m_e \\ddot x_i + c_d \\dot x_i = k_e(u_d)\\,\\mathrm{dz}(u_d - x_i, h_d/2)

    with ``k_e = k0 l_f/(l_f + u_d)`` (S0 Eq.4; ``k0`` when ``l_f`` is None) and the dead zone
    ``dz(d, g) = d - g sign(d)`` for ``|d| > g``, else 0.  The series spring is ``k0`` when the
    internal stiffness is on, otherwise the contact stiffness of the backlash.  The force
    fluctuation of S0 Eq.15, ``F - (m_e u_d'' + c_d u_d')``, is logged in :meth:`state`.
    At rest the flywheel sits centred in its gap, so a backlash model starts with the force path
    open.

    Parameters
    ----------
    parameters
        The damper; needs a series element (internal stiffness or ``clearance > 0``).
    max_step_phase
        Largest ``|lambda| dt_sub`` [rad] per RK4 sub-step (see the module docstring).
    use_jit
        Run the numba-compiled kernel (compiled once, cached on disk); False runs the same
        source as plain Python (the reference path).
    """

    def __init__(
        self,
        parameters: IMDParameters,
        *,
        max_step_phase: float = MAX_STEP_PHASE,
        use_jit: bool = True,
    ) -> None:
        super().__init__()
        if not parameters.has_series_element:
            raise ParameterError(
                "InternalStiffnessIMD needs internal stiffness or a backlash clearance; got "
                f"stiffness={parameters.stiffness!r}, internal_stiffness="
                f"{parameters.internal_stiffness!r}, clearance={parameters.clearance!r} "
                "(use SimplifiedIMD for the rigid device)"
            )
        self.parameters: IMDParameters = parameters
        self.max_step_phase: float = check_positive(max_step_phase, "max_step_phase")
        self._advance = advance_flywheel_jit if use_jit else advance_flywheel
        self._k0 = parameters.series_stiffness
        self._lf = 0.0 if parameters.free_length is None else parameters.free_length
        self._half_gap = 0.5 * parameters.clearance
        self._m = parameters.inertance
        self._friction = parameters.friction
        self._v_eps = parameters.friction_velocity
        self._init_damping()
        self.reset()

    @classmethod
    def from_options(cls, options: IMDParameters, **_: object) -> InternalStiffnessIMD:
        """The registered kind: the model of ``options``."""
        return cls.from_parameters(options)

    @classmethod
    def from_parameters(cls, parameters: IMDParameters) -> InternalStiffnessIMD:
        """The model for a parameter set (the registry's uniform constructor)."""
        return cls(parameters)

    def _reset_impl(self) -> None:
        """Return to rest: drive and flywheel at 0, amplitude estimate forgotten."""
        self._reset_damping()
        self._x = 0.0  # flywheel displacement x_i [m]
        self._w = 0.0  # flywheel velocity [m/s]
        self._u = 0.0  # last drive state
        self._v = 0.0
        self._a = 0.0
        self._spring = 0.0
        self._force = 0.0
        self._substep_key = (0.0, 0.0)  # (dt, c_d) the cached sub-step count is for
        self._substep_count = 1

    def stiffness_at(self, u: float) -> float:
        """Series stiffness ``k_e`` [N/m] at drive displacement ``u`` [m] (S0 Eq.4)."""
        if self._lf <= 0.0:
            return self._k0
        if u <= -self._lf:
            raise ParameterError(
                f"drive displacement u must exceed -l_f = {-self._lf!r} m for the variant "
                f"stiffness (S0 Eq.4); got {u!r}"
            )
        return self._k0 * self._lf / (self._lf + u)

    def substeps(self, dt: float, u0: float = 0.0, u1: float = 0.0) -> int:
        """RK4 sub-steps for an interval ``dt`` [s] between drive displacements ``u0``, ``u1``."""
        k = self.stiffness_at(min(u0, u1))
        rate = max(math.sqrt(k / self._m), self._damping / self._m)
        return max(1, math.ceil(rate * dt / self.max_step_phase))

    def _step_impl(self, u: float, v: float, a: float, dt: float) -> float:
        if self._lf > 0.0:  # k_e depends on the drive (S0 Eq.4)
            n_sub = self.substeps(_check_dt(dt), self._u, u)
        else:  # constant k0: the count changes only with dt or c_d (at reversals)
            if (dt, self._damping) != self._substep_key:
                self._substep_key = (dt, self._damping)
                self._substep_count = self.substeps(_check_dt(dt))
            n_sub = self._substep_count
        self._x, self._w, self._spring = self._advance(
            self._x,
            self._w,
            self._u,
            self._v,
            u,
            v,
            dt,
            n_sub,
            self._m,
            self._damping,
            self._k0,
            self._lf,
            self._half_gap,
        )
        force = self._spring
        if self._friction > 0.0:
            force += self._friction * regularised_sign(v, self._v_eps)
        self._u, self._v, self._a = u, v, a
        self._observe_drive(u)
        self._force = force
        return force

    def compiled_step(self) -> CompiledStep | None:
        """This model for the loop's fused kernel (:mod:`plants.imd.step_kernel`); None on the
        reference path."""
        return (
            step_kernel.pack(self, series=True) if self._advance is advance_flywheel_jit else None
        )

    @property
    def gap_open(self) -> bool:
        """True while the backlash gap is being crossed (no force through the spring)."""
        return self._half_gap > 0.0 and abs(self._u - self._x) <= self._half_gap

    def channels(self) -> tuple[Channel, ...]:
        """The keys of :meth:`state`, with units."""
        return _SERIES_CHANNELS

    def write_channels(self, out: NDArray[np.float64]) -> None:
        """:meth:`state`'s values, no dict."""
        out[0] = self._x
        out[1] = self._w
        out[2] = self._spring
        out[3] = self._force - self._spring
        out[4] = self._spring - self._m * self._a - self._damping * self._v
        out[5] = 1.0 if self.gap_open else 0.0
        out[6] = self._k0 if self._lf <= 0.0 else self.stiffness_at(self._u)
        out[7] = self._damping
        out[8] = self.amplitude

    def state(self) -> dict[str, float]:
        """Internal variables (SI) at the last step.

        ``flywheel_displacement`` x_i [m], ``flywheel_velocity`` [m/s], ``spring_force`` [N],
        ``friction_force`` [N], ``force_fluctuation`` [N] (S0 Eq.15: ``F - m_e u'' - c_d u'``
        without friction), ``gap_open`` (1.0/0.0), ``stiffness`` k_e [N/m], ``damping``
        c_d [N s/m], ``amplitude`` [m].
        """
        return {
            "flywheel_displacement": self._x,
            "flywheel_velocity": self._w,
            "spring_force": self._spring,
            "friction_force": self._force - self._spring,
            "force_fluctuation": self._spring - self._m * self._a - self._damping * self._v,
            "gap_open": float(self.gap_open),
            "stiffness": self.stiffness_at(self._u),
            "damping": self._damping,
            "amplitude": self.amplitude,
        }


@SPECIMENS.register("imd", IMDParameters)
def imd(options: IMDParameters, **_: object) -> Specimen:
    """An inertial mass damper carrying every effect its parameters switch on (S0 Eq.1 or Eq.12).

    :class:`InternalStiffnessIMD` when there is a series element (internal stiffness, backlash),
    else :class:`SimplifiedIMD`.

    Parameters
    ----------
    options : IMDParameters
        The damper (``[specimen]`` table of a ``kind = "imd"`` scenario, SI units) with its
        switched-on effects.  Registry context (``rng``) is accepted and ignored.
    """
    cls = InternalStiffnessIMD if options.has_series_element else SimplifiedIMD
    return cls.from_parameters(options)


def imd_from_parameters(parameters: IMDParameters, kind: str = "imd") -> Specimen:
    """Build an IMD model from a parameter set.

    Parameters
    ----------
    parameters
        The damper with its switched-on effects.
    kind
        ``"imd"`` (default): the model that carries every switched-on effect --
        :class:`InternalStiffnessIMD` when there is a series element, else
        :class:`SimplifiedIMD`.  Or ``"imd_simplified"`` / ``"imd_internal"`` to force a model.
    """
    if kind not in _IMD_KINDS:
        raise ParameterError(
            f"unknown IMD kind {kind!r}; choose one of {format_choices(_IMD_KINDS)}"
        )
    model: Specimen = SPECIMENS.get(kind).build(parameters)
    return model


_IMD_KINDS = ("imd", "imd_internal", "imd_simplified")
