"""The vRTHS benchmark servo-hydraulic actuator built around the specimen it drives
(control-structure interaction), with an optional differential-pressure (Delta-P) loop for heavy
inertial specimens
(Silva et al. 2020; design.md section 5)::

    servo-valve   q   = a1b0/(s^2 + b1 s + b2) e,    e = gain*command - x - K_dp*F_a
    hydraulics    (s + a3) F_a = q - a2 xdot
    mechanics     (m_p + m_r) xddot + (c_p + c_r) xdot = F_a - F_rest

``m_r``, ``c_r`` are the specimen's rigid part (integrated implicitly with the piston);
``F_rest = F - m_r a - c_r v`` is the specimen's remaining force (stiffness, internal dynamics,
friction ...), fed back one *sub-step* late.  With ``LinearSpecimen(29.13, c, 1.19e6)`` this
reproduces the benchmark ``G_plant = gain*feedback(Gs*G0, 1)``, ``G0 = feedback(Ga*Gest, a2*s)``:
DC gain 0.982 (x1.0261 = 1.0075), phase delay 25.0 ms at 1 Hz and 19.0 ms at 10 Hz.

The pure delay on the command path and the velocity (flow) limit are the base class's
(:class:`plants.actuator.base.Actuator`); the limit is applied to the displacement after the linear
dynamics, per sub-step (Simulink Rate Limiter semantics, :class:`plants.lines.RateLimiter`); the
linear dynamics (including the CSI loop) run on unaware of it: exactly the model the diagnosis fits
as ``rate_limit``.

References
----------
.. [1] Silva, C. E., Gomez, D., Maghareh, A., Dyke, S. J., Spencer, B. F. Jr. (2020).
   Benchmark control problem for real-time hybrid simulation. Mech. Syst. Signal Process. 135.
"""

from __future__ import annotations

import math
from typing import Any

import control
import numpy as np

from plants.actuator.base import Actuator
from plants.actuator.kernel import SERVO_OUTPUTS, SERVO_PARAMS, servo_hydraulic_step
from plants.actuator.linear import (
    check_stable,
    close_remainder,
    discretise,
    servo_hydraulic_model,
    siso_transfer_function,
)
from plants.actuator.options import ServoHydraulicOptions
from plants.actuator.parameters import (
    BENCHMARK,
    BenchmarkParameters,
)
from plants.base import Kinematics, Specimen
from plants.device_model import DeviceModel
from plants.linear_specimen import LinearSpecimen
from rths.core.channels import Channel
from rths.core.errors import (
    ParameterError,
    check_nonnegative,
    check_positive,
    check_positive_int,
)
from rths.core.registry import ACTUATORS

__all__ = ["MAX_SUBSTEP", "ServoHydraulicActuator", "default_substeps"]


#: Longest internal sub-step [s] of :class:`ServoHydraulicActuator` by default.  The explicit
#: (ZOH-held) remainder force lowers the damping of the benchmark's lightly damped oil-column
#: mode (-8 +/- 422j rad/s, zeta 0.019): at 1/16384 s (omega*h = 0.026) to zeta 0.0173 (-8 %),
#: against 0.0126 (-34 %) at 1/4096 s, while the response below 10 Hz changes by < 0.1 %.
MAX_SUBSTEP = 1.0 / 16384.0


def default_substeps(dt: float) -> int:
    """Fewest sub-steps per loop step ``dt`` [s] keeping the sub-step <= :data:`MAX_SUBSTEP`.

    Parameters
    ----------
    dt
        Loop step [s], > 0 (the vRTHS benchmark's: 1/4096 s, giving 4 sub-steps).

    Returns
    -------
    int
        ``ceil(dt / MAX_SUBSTEP)``, at least 1.

    Raises
    ------
    ParameterError
        If ``dt`` is not a positive finite number.
    """
    dt = check_positive(dt, "time step dt")
    return max(1, math.ceil(dt / MAX_SUBSTEP - 1e-9))


@ACTUATORS.register("servo_hydraulic", ServoHydraulicOptions)
class ServoHydraulicActuator(Actuator):
    """The vRTHS benchmark servo-hydraulic actuator coupled to its specimen (CSI).

    The linear loop is built with python-control (``interconnect``), with inputs
    ``[command, F_rest]`` and outputs ``[x, xdot, xddot, F_a]``, and discretised by zero-order
    hold (``control.c2d``) over ``substeps`` sub-steps per loop step.  Each sub-step advances
    the linear state with the (delayed) command and the remainder force of the previous
    sub-step, drives the specimen to the new ``(x, xdot, xddot)`` and computes the new remainder
    ``F_rest = F - m_r xddot - c_r xdot``.  The linear loop is exact for a command held over the
    step; only ``F_rest`` lags (a zero-order hold over one sub-step).

    Parameters
    ----------
    specimen
        The specimen driven by the piston; its ``rigid_inertance`` [kg] and ``rigid_damping``
        [N s/m] are read once here.
    dt
        Loop step [s].
    parameters
        Actuator parameters (:data:`BENCHMARK` for light specimens,
        :data:`HEAVY_INERTIAL_LOAD` for inerters of ~1.6 t).
    substeps
        Internal sub-steps per loop step; default :func:`default_substeps` (sub-step <=
        :data:`MAX_SUBSTEP`).
    delay
        Pure delay [s] on the command path (linear interpolation between loop samples), >= 0.
    velocity_limit
        Flow limit ``v_max = Q_max / A`` [m/s] of the displacement, applied per sub-step after
        the linear dynamics; ``None`` for none.
    use_jit
        With a :class:`LinearSpecimen` (exactly that class), run each loop step as one compiled
        call (:func:`plants.actuator.kernel.servo_hydraulic_step`: sub-steps, limiter and the
        specimen's force law; equal to the Python path to round-off); ``False`` (or any other
        specimen) steps in Python, the reference path.

    Attributes
    ----------
    substep : float
        Internal sub-step [s] (``dt / substeps``).
    rigid_mass, rigid_damping : float
        The specimen's rigid part [kg], [N s/m] integrated with the piston.
    open_loop : control.StateSpace
        The continuous model, inputs ``[command, remainder_force]``, outputs
        ``[displacement, velocity, acceleration, hydraulic_force]``.

    Raises
    ------
    ParameterError
        If the moving mass ``m_p + m_r`` is not positive, or the linear loop (with the
        stiffness of a :class:`LinearSpecimen`, and for that case also its sub-stepped
        discretisation) is unstable; the message lists the offending poles.
    """

    def __init__(
        self,
        specimen: Specimen,
        dt: float,
        parameters: BenchmarkParameters = BENCHMARK,
        *,
        substeps: int | None = None,
        delay: float = 0.0,
        velocity_limit: float | None = None,
        use_jit: bool = True,
    ) -> None:
        if not isinstance(parameters, BenchmarkParameters):
            raise ParameterError(f"parameters must be BenchmarkParameters; got {parameters!r}")
        if substeps is None:
            substeps = default_substeps(check_positive(dt, "time step dt"))
        self.substeps: int = check_positive_int(substeps, "substeps")
        super().__init__(
            specimen,
            dt,
            delay=delay,
            velocity_limit=velocity_limit,
            limiter_step=dt / self.substeps,
        )
        self.parameters: BenchmarkParameters = parameters
        self.substep: float = self.dt / self.substeps
        self.rigid_mass: float = check_nonnegative(
            specimen.rigid_inertance, "specimen rigid_inertance"
        )
        self.rigid_damping: float = check_nonnegative(
            specimen.rigid_damping, "specimen rigid_damping"
        )
        mass = parameters.piston_mass + self.rigid_mass
        if mass <= 0.0:
            raise ParameterError(
                "moving mass (piston_mass + specimen rigid_inertance) must be positive; got "
                f"{parameters.piston_mass!r} + {self.rigid_mass!r} kg"
            )
        self.open_loop: control.StateSpace = servo_hydraulic_model(
            parameters, mass, parameters.piston_damping + self.rigid_damping
        )
        what = f"servo-hydraulic loop with moving mass {mass:.6g} kg"
        stiffness = specimen.stiffness if isinstance(specimen, LinearSpecimen) else 0.0
        check_stable(close_remainder(self.open_loop, stiffness).poles(), what)
        self._model = discretise(self.open_loop, self.substep)
        if stiffness > 0.0:
            self._check_substeps(stiffness, what)
        m = self._model
        # Stacked update: [z+; y] = [A; CA] z + [B; CB + D] w, w = [command, F_rest].
        self._advance = np.vstack([m.A, m.C @ m.A])
        gain = np.vstack([m.B, m.C @ m.B + m.D])
        self._by_command = np.ascontiguousarray(gain[:, 0])
        self._by_remainder = np.ascontiguousarray(gain[:, 1])
        self._n_states = m.A.shape[0]
        # the compiled path (plants.base hot-path convention): the specimen's force law inline
        self.use_jit: bool = bool(use_jit) and type(specimen) is LinearSpecimen
        self._gain = np.ascontiguousarray(
            np.column_stack([self._advance, self._by_command, self._by_remainder])
        )
        self._params = np.zeros(len(SERVO_PARAMS))
        if self.use_jit:
            assert isinstance(specimen, LinearSpecimen)
            self._specimen_stepped = specimen.stepped_by_kernel
            limiter = self.limiter
            self._params[:] = (
                self.substeps, self.rigid_mass, self.rigid_damping,
                specimen.mass, specimen.damping, specimen.stiffness,
                0.0 if limiter is None else 1.0,
                0.0 if limiter is None else limiter.velocity_limit * limiter.dt,
                0.0 if limiter is None else limiter.velocity_limit,
            )  # fmt: skip
        self._state = np.zeros(self._n_states + 3)
        self._out = np.zeros(len(SERVO_OUTPUTS))
        self.reset()

    @classmethod
    def from_options(
        cls,
        options: ServoHydraulicOptions,
        *,
        specimen: Specimen,
        dt: float,
        rng: np.random.Generator | None = None,
        **_: object,
    ) -> ServoHydraulicActuator:
        """The ``servo_hydraulic`` kind driving ``specimen`` (``rng``: a Monte-Carlo draw of
        the benchmark's uncertain hydraulics, :meth:`BenchmarkParameters.sample`)."""
        hydraulics = options.hydraulics
        if rng is not None:
            hydraulics = hydraulics.sample(rng)
        return cls(
            specimen,
            dt,
            hydraulics,
            substeps=options.substeps,
            delay=options.delay,
            velocity_limit=options.velocity_limit,
        )

    @classmethod
    def nominal_plant(
        cls, options: ServoHydraulicOptions, *, model: DeviceModel | None, dt: float
    ) -> tuple[control.TransferFunction, float]:
        """The compensator's command→measured model and delay [s]: the loop linearised with the
        ``[model]`` device installed (the lab engineer identifies the transfer system with the
        specimen on it); S0 Eq.12's series spring enters as the dynamic stiffness of the rest."""
        remainder: Any = None
        if model is None:
            device = LinearSpecimen(0.0, 0.0, 0.0)
        elif model.series_stiffness is None:
            device = LinearSpecimen(model.inertance, model.damping, model.stiffness)
        else:
            device = LinearSpecimen(0.0, 0.0, 0.0)
            remainder = model.dynamic_stiffness()
        act = cls(device, dt, options.hydraulics)
        return control.minreal(act.transfer_function(remainder), verbose=False), options.delay

    def _check_substeps(self, stiffness: float, what: str) -> None:
        """Stability of the sub-stepped loop with ``F_rest = k x`` held over each sub-step."""
        m = self._model
        z = np.linalg.eigvals(m.A + np.outer(m.B[:, 1], m.C[0]) * stiffness)
        if np.max(np.abs(z)) >= 1.0:
            check_stable(
                np.log(z.astype(complex)) / self.substep,
                f"{what} stepped with {self.substeps} sub-steps of {self.substep:.3g} s "
                "(increase substeps)",
            )

    def _reset_impl(self) -> None:
        """Return the linear state and the remainder force to rest."""
        self._z = np.zeros(self._n_states)
        self._remainder = 0.0
        self._outputs = (0.0, 0.0, 0.0, 0.0)
        self._kinematics = Kinematics(0.0, 0.0, 0.0)
        self._force = 0.0
        self._state[:] = 0.0

    def _step_impl(self, command: float) -> tuple[Kinematics, float]:
        if self.use_jit:
            return self._step_compiled(command)
        u = command
        n, h = self._n_states, self.substep
        m_r, c_r, limiter = self.rigid_mass, self.rigid_damping, self.limiter
        advance, by_remainder = self._advance, self._by_remainder
        held = self._by_command * u
        z, remainder = self._z, self._remainder
        for _ in range(self.substeps):
            stacked = advance @ z + held + by_remainder * remainder
            z = stacked[:n]
            outputs = stacked[n:].tolist()
            x, v, a, _ = outputs
            if limiter is not None:
                x = limiter.step(x)
                v, a = limiter.clip(v, a)
            force = self.specimen.step(x, v, a, h)
            remainder = force - m_r * a - c_r * v
        self._z, self._remainder = z, remainder
        self._outputs = tuple(outputs)
        self._kinematics, self._force = Kinematics(x, v, a), force
        return self._kinematics, force

    def _step_compiled(self, command: float) -> tuple[Kinematics, float]:
        """:meth:`_step_impl` as one compiled call; the specimen and the limiter are told the
        state the kernel left them in (for their ``state()`` and step counts)."""
        state = self._state
        servo_hydraulic_step(self._gain, state, self._params, self._out, command)
        x, v, a, force, x_lin, v_lin, a_lin, f_a = self._out.tolist()
        self._outputs = (x_lin, v_lin, a_lin, f_a)
        self._specimen_stepped(x, self.substeps)
        limiter = self.limiter
        if limiter is not None:
            n = self._n_states
            limiter.output, limiter.limiting = float(state[n + 1]), int(state[n + 2])
        self._kinematics, self._force = Kinematics(x, v, a), force
        return self._kinematics, force

    def closed_loop(self, remainder: float | control.LTI | None = None) -> control.StateSpace:
        """The continuous loop with the specimen remainder closed, input ``command`` [m].

        Parameters
        ----------
        remainder
            Stiffness [N/m] or python-control LTI model of ``F_rest(s)/x(s)`` [N/m]; by default
            the stiffness of a :class:`LinearSpecimen`, else 0 (rigid part only).

        Returns
        -------
        control.StateSpace
            Outputs ``[displacement, velocity, acceleration, hydraulic_force]``.
        """
        if remainder is None:
            remainder = (
                self.specimen.stiffness if isinstance(self.specimen, LinearSpecimen) else 0.0
            )
        return close_remainder(self.open_loop, remainder)

    def transfer_function(
        self, remainder: float | control.LTI | None = None
    ) -> control.TransferFunction:
        """Rational command→displacement model (the :attr:`delay` is not included).

        Includes the specimen's rigid part and, by default, the stiffness of a
        :class:`LinearSpecimen` (see :meth:`closed_loop` for ``remainder``).
        """
        return siso_transfer_function(self.closed_loop(remainder)[0, 0])

    @property
    def hydraulic_force(self) -> float:
        """Hydraulic force ``F_a`` [N] at the end of the last step."""
        return self._outputs[3]

    def _state_impl(self) -> dict[str, float]:
        """``hydraulic_force`` [N] and ``displacement_linear`` (before the rate limiter) [m]."""
        x, _, _, f_a = self._outputs
        return {"hydraulic_force": f_a, "displacement_linear": x}

    def _channels_impl(self) -> tuple[Channel, ...]:
        """``hydraulic_force`` [N], ``displacement_linear`` [m]."""
        return (
            Channel("hydraulic_force", "N", "hydraulic force F_a on the piston"),
            Channel("displacement_linear", "m", "displacement before the rate limiter"),
        )

    def _write_own(self, out: np.ndarray) -> None:
        out[0] = self._outputs[3]
        out[1] = self._outputs[0]
