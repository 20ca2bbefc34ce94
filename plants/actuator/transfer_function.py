"""A command→displacement transfer function ``num(s)/den(s)`` identified with the specimen attached
(no control-structure interaction): the form of the diagnosis contract's ``NOMINAL.toml
[actuator]`` (design.md section 7).  The pure delay and the velocity (flow) limit are the base
class's (:class:`plants.actuator.base.Actuator`)."""

from __future__ import annotations

import control
import numpy as np
from numpy.typing import ArrayLike, NDArray

from plants.actuator.base import Actuator
from plants.actuator.kernel import TF_STATE, state_space_step
from plants.actuator.linear import (
    derivative_model,
    discretise,
)
from plants.actuator.options import TransferFunctionOptions
from plants.base import Kinematics, Specimen
from plants.device_model import DeviceModel
from rths.core.channels import Channel
from rths.core.compiled import CompiledStep
from rths.core.registry import ACTUATORS

__all__ = ["TransferFunctionActuator"]


@ACTUATORS.register("transfer_function", TransferFunctionOptions)
class TransferFunctionActuator(Actuator):
    """Command→displacement transfer function ``num(s)/den(s)`` with optional delay/rate limit.

    The TF is understood as identified with the specimen attached, so there is no CSI: the
    specimen is driven by the actuator output and its force does not act back.  The model is
    realised by python-control (``tf2ss``) and discretised exactly by zero-order hold at the
    loop step ``dt`` (no sub-steps; the specimen interpolates internally).

    Drive kinematics: with relative degree ``r = deg den - deg num`` the derivatives of order
    ``i < r`` are the exact state outputs ``C A^i z`` (continuous across steps); those of order
    ``i >= r`` would jump or carry impulses where the held command jumps, so they are backward
    differences over ``dt`` of the next lower derivative sent to the specimen (lag ``dt/2``
    each).  For ``r >= 3`` (e.g. the ``b0/(s^3 + a2 s^2 + a1 s + a0)`` of ``NOMINAL.toml``) all
    three are exact.  With a rate limiter the displacement is limited first, differences are
    taken of the limited signal, and :meth:`RateLimiter.clip` bounds the velocity.

    Parameters
    ----------
    num, den
        Coefficients in descending powers of ``s``; proper and stable.
    specimen
        The specimen driven by the displacement.
    dt
        Loop step [s].
    delay
        Pure delay [s] on the command path, >= 0 (:class:`DelayLine`).
    velocity_limit
        Rate limit ``v_max`` [m/s] on the displacement (:class:`RateLimiter`), ``None`` for none.
    use_jit
        Advance the state with the compiled kernel (:mod:`plants.actuator.kernel`, default) or
        with the NumPy expressions (the reference path; equal to round-off).
    """

    def __init__(
        self,
        num: ArrayLike,
        den: ArrayLike,
        specimen: Specimen,
        dt: float,
        *,
        delay: float = 0.0,
        velocity_limit: float | None = None,
        use_jit: bool = True,
    ) -> None:
        super().__init__(specimen, dt, delay=delay, velocity_limit=velocity_limit)
        self.use_jit = bool(use_jit)
        model, self._tf, self.relative_degree = derivative_model(num, den)
        self._model = discretise(model, self.dt)
        m = self._model
        self._A, self._B = m.A, m.B[:, 0].copy()
        self._C, self._D = np.ascontiguousarray(m.C), m.D[:, 0].copy()
        self._A = np.ascontiguousarray(self._A)
        self._y = np.zeros(self._C.shape[0])  # (x, v, a) of the last step (compiled path)
        self.reset()

    @classmethod
    def from_options(
        cls, options: TransferFunctionOptions, *, specimen: Specimen, dt: float, **_: object
    ) -> TransferFunctionActuator:
        """The ``transfer_function`` kind driving ``specimen``."""
        assert options.num is not None and options.den is not None  # options validate it
        return cls(
            list(options.num),
            list(options.den),
            specimen,
            dt,
            delay=options.delay,
            velocity_limit=options.velocity_limit,
        )

    @classmethod
    def nominal_plant(
        cls, options: TransferFunctionOptions, *, model: DeviceModel | None, dt: float
    ) -> tuple[control.TransferFunction, float]:
        """The compensator's model: the TF itself (it was identified with the specimen on) or
        ``nominal_num``/``nominal_den``, and the delay [s]."""
        num, den = options.nominal
        return control.tf(list(num), list(den)), options.delay

    def _reset_impl(self) -> None:
        """Return the state and the drive history to rest."""
        self._z = np.zeros(self._A.shape[0])
        self._drive = (0.0, 0.0, 0.0)
        self._linear = 0.0
        self._force = 0.0

    def _step_impl(self, command: float) -> tuple[Kinematics, float]:
        u = command
        if self.use_jit:
            state_space_step(self._A, self._B, self._C, self._D, self._z, u, self._y)
            x, v, a = self._y.tolist()
        else:
            self._z = self._A @ self._z + self._B * u
            x, v, a = (self._C @ self._z + self._D * u).tolist()
        self._linear = x
        x_old, v_old, _ = self._drive
        limiter = self.limiter
        if limiter is not None:
            x = limiter.step(x)
        if self.relative_degree <= 1:
            v = (x - x_old) / self.dt
        if self.relative_degree <= 2:
            a = (v - v_old) / self.dt
        if limiter is not None:
            v, a = limiter.clip(v, a)
        self._drive = (x, v, a)
        self._force = self.specimen.step(x, v, a, self.dt)
        return Kinematics(x, v, a), self._force

    def compiled_step(self) -> CompiledStep | None:
        """This actuator with its specimen for the loop's fused kernel
        (:mod:`rths.core.compiled`; family ``"transfer_function_imd"``: constants ``A, B, C, D,
        cfg`` then the specimen's, state ``z, y,`` :data:`plants.actuator.kernel.TF_STATE` then
        the specimen's), or None with a delay line, a rate limiter, the reference path or a
        specimen without a compiled step."""
        offer = getattr(self.specimen, "compiled_step", None)
        spec = offer() if offer is not None else None
        if (
            spec is None
            or not spec.family.startswith("imd_")
            or not self.use_jit
            or self._delay_line is not None
            or self.limiter is not None
        ):
            return None
        cfg = np.array([self.dt, float(self.relative_degree)])
        s = np.zeros(len(TF_STATE))
        s[0], s[1], s[2:5], s[5], s[6] = (
            self._command,
            self._linear,
            self._drive,
            self._force,
            self._steps,
        )

        def commit() -> None:
            spec.commit()
            self._command, self._linear = float(s[0]), float(s[1])
            self._drive = (float(s[2]), float(s[3]), float(s[4]))
            self._force, self._steps = float(s[5]), int(s[6])

        constants = (self._A, self._B, self._C, self._D, cfg, *spec.constants)
        return CompiledStep(
            "transfer_function_imd", constants, (self._z, self._y, s, *spec.state), commit
        )

    def transfer_function(self) -> control.TransferFunction:
        """The rational part ``num(s)/den(s)``; the :attr:`delay` [s] is separate."""
        return self._tf

    def _state_impl(self) -> dict[str, float]:
        """``displacement_linear`` (before the rate limiter) [m]."""
        return {"displacement_linear": self._linear}

    def _channels_impl(self) -> tuple[Channel, ...]:
        """``displacement_linear`` [m]."""
        return (Channel("displacement_linear", "m", "displacement before the rate limiter"),)

    def _write_own(self, out: NDArray[np.float64]) -> None:
        out[0] = self._linear
