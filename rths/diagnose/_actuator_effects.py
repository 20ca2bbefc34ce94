"""Actuator-channel models: the re-calibrated nominal transfer system, extra delay, rate limit."""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from plants.actuator import delayed, rate_limited
from rths.diagnose._model import Columns, Model
from rths.diagnose.channels import Channel, Segment

__all__ = ["SECANT_WINDOW", "ActuatorBaseline", "ActuatorDelay", "RateLimit"]


def _nominal_motion(channel: Channel, seg: Segment, extra_delay: float = 0.0) -> NDArray:
    """Nominal TF response delayed by the nominal delay plus ``extra_delay`` [s]."""
    key = f"nominal_motion:{extra_delay!r}"
    if key not in seg.cache:
        total = channel.nominal.actuator.delay + extra_delay
        seg.cache[key] = delayed(seg.signals["replay"], max(total, 0.0), seg.dt)
    return seg.cache[key]


class ActuatorBaseline(Model):
    """Re-calibrated nominal transfer system: ``y = g e^{-s tau_0} G(s) u + b`` (gain, offset)."""

    name = "baseline"
    subsystem = "actuator"

    def columns(self, channel: Channel, seg: Segment, theta: NDArray) -> Columns:
        y = _nominal_motion(channel, seg)
        return np.column_stack([y, np.ones_like(y)]), np.zeros_like(y)

    def prior(self, channel: Channel) -> NDArray:
        return np.array([1.0, 0.0])  # nominal gain, no offset

    def describe(self, channel: Channel, theta: NDArray, beta: NDArray):
        return {}, {"gain": float(beta[0]), "offset": float(beta[1])}


class ActuatorDelay(Model):
    """Extra pure delay on the command: ``y = g e^{-s (tau_0 + tau)} G(s) u + b``.

    The delay is applied to the nominal response rather than to the command, which is exact
    for an LTI ``G`` (both are the same linear-interpolation FIR of
    :func:`plants.actuator.delayed`).  ``tau`` may be negative down to ``-tau_0`` (a nominal
    that over-states the delay).
    """

    name = "actuator_delay"
    subsystem = "actuator"
    n_effect = 1
    #: Longest extra delay searched [s].
    max_delay: ClassVar[float] = 0.1

    def columns(self, channel: Channel, seg: Segment, theta: NDArray) -> Columns:
        total = max(channel.nominal.actuator.delay + float(theta[0]), 0.0)
        y = delayed(seg.signals["replay"], total, seg.dt)
        return np.column_stack([y, np.ones_like(y)]), np.zeros_like(y)

    def starts(self, channel: Channel, base: dict[str, float]) -> list[NDArray]:
        lo, hi = self.bounds(channel, base)
        step = max(channel.dt, 1e-3)
        return [np.array([t]) for t in np.arange(lo[0], hi[0], step)]

    def bounds(self, channel: Channel, base: dict[str, float]):
        return np.array([-channel.nominal.actuator.delay]), np.array([self.max_delay])

    def prior(self, channel: Channel) -> NDArray:
        return np.array([1.0, 0.0])  # nominal gain, no offset

    def describe(self, channel: Channel, theta: NDArray, beta: NDArray):
        return {"delay": float(theta[0])}, {"gain": float(beta[0]), "offset": float(beta[1])}


#: Window [s] of the secant slope the rate-limit candidate is checked against.
SECANT_WINDOW: float = 0.01


class RateLimit(Model):
    """Velocity (flow) limit after the linear dynamics: ``y = RL(g e^{-s tau_0} G u; v_max) + b``.

    ``RL`` is :func:`plants.actuator.rate_limited` (Simulink Rate Limiter semantics), exactly
    the limiter of the emulated actuators.  The gain sits inside the limiter, so it is a
    nonlinear parameter here: ``theta = (g, v_max)``.
    """

    name = "rate_limit"
    subsystem = "actuator"
    n_effect = 1
    polish = True

    def columns(self, channel: Channel, seg: Segment, theta: NDArray) -> Columns:
        y = rate_limited(float(theta[0]) * _nominal_motion(channel, seg), float(theta[1]), seg.dt)
        return np.ones((y.size, 1)), y

    @staticmethod
    def _peak_velocity(channel: Channel, gain: float) -> float:
        return max(
            float(np.max(np.abs(np.diff(gain * _nominal_motion(channel, s))))) / s.dt
            for s in channel.segments
        )

    def starts(self, channel: Channel, base: dict[str, float]) -> list[NDArray]:
        peak = self._peak_velocity(channel, 1.0)
        gains = sorted({1.0, min(max(base["gain"], 0.5), 1.5)})
        return [np.array([g, peak * q]) for g in gains for q in np.geomspace(0.1, 1.0, 31)]

    def bounds(self, channel: Channel, base: dict[str, float]):
        """Gain re-calibration within [0.5, 1.5] of the nominal; limit up to twice the peak."""
        peak = self._peak_velocity(channel, 1.0)
        return np.array([0.5, 0.02 * peak]), np.array([1.5, 2.0 * peak])

    def prior(self, channel: Channel) -> NDArray:
        return np.zeros(1)  # no offset

    def describe(self, channel: Channel, theta: NDArray, beta: NDArray):
        return {"velocity_limit": float(theta[1])}, {
            "gain": float(theta[0]),
            "offset": float(beta[0]),
        }

    def physical(self, channel: Channel, params: dict[str, float]) -> bool:
        """The measured displacement must never move faster than the limit.

        The speed is the secant slope over :data:`SECANT_WINDOW` (by the mean-value theorem
        it never exceeds the largest true slope, so it cannot overshoot as a filtered
        derivative would at the limiter's kinks; noise RMS ``sqrt(2) s_x / window``); its
        99.9th percentile may exceed ``v_max`` by 5 % plus four noise RMS.  A linear actuator
        whose attenuation a limiter mimics in a sweep fails this test.
        """
        v_max = params["velocity_limit"]
        if v_max <= 0.0:
            return False
        k = max(1, int(round(0.5 * SECANT_WINDOW / channel.dt)))
        window = 2 * k * channel.dt
        speed = np.concatenate(
            [np.abs(s.observed[2 * k :] - s.observed[: -2 * k]) / window for s in channel.segments]
        )
        noise = math.sqrt(2.0) * channel.noise["measured"] / window
        return float(np.percentile(speed, 99.9)) <= 1.05 * v_max + 4.0 * noise
