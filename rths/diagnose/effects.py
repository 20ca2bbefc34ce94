"""Candidate effects: grey-box extensions of the nominal model with few parameters.

Every model, baseline or effect, predicts its channel's observation as

.. math:: \\hat y(\\theta, \\beta) = X(\\theta)\\,\\beta + f(\\theta)

with few nonlinear parameters ``theta`` (searched by :mod:`rths.diagnose.identify`) and linear
ones ``beta`` (solved by least squares for each ``theta``: variable projection).  ``beta`` always
holds the nominal model's own parameters -- the baseline re-calibration of design.md section 7
(actuator gain; inertance, damping, stiffness) -- plus a sensor offset, so each effect is fitted
*jointly* with the re-calibrated baseline and never gets credit for a mis-calibration.

===================  =========  ===================================  ============================
model                subsystem  effect parameters (theta)            source
===================  =========  ===================================  ============================
baseline (actuator)  actuator   --                                   nominal TF + delay, gain
actuator_delay       actuator   extra delay tau [s]                  pure delay on the command
rate_limit           actuator   velocity_limit [m/s] (+ gain)        valve flow limit (Simulink)
baseline (specimen)  specimen   --                                   S0 Eq.1 + spring
coulomb_friction     specimen   friction F_r [N] (linear)            S0 Eq.1 friction term
internal_stiffness   specimen   f_e = sqrt(k_s/m)/2pi, zeta          S0 Eq.12 (series spring)
backlash             specimen   gap, contact f_c, c/m                S0 Table 6, S1 Eq.11
===================  =========  ===================================  ============================

Adding an effect: subclass :class:`Model` (``name``, ``subsystem``, ``n_effect``,
``columns``, ``starts``, ``bounds``, ``describe``) and add it to :data:`EFFECTS`.  The name
is the verdict users see.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import ClassVar, Literal

import numpy as np
from numpy.typing import NDArray
from scipy import signal

from plants.actuator import delayed, rate_limited
from rths.diagnose._kernels import series_force_per_mass
from rths.diagnose.channels import Channel, Segment

__all__ = [
    "EFFECTS",
    "ActuatorBaseline",
    "ActuatorDelay",
    "Backlash",
    "CoulombFriction",
    "InternalStiffness",
    "Model",
    "RateLimit",
    "SpecimenBaseline",
    "baseline_for",
]

Columns = tuple[NDArray[np.float64], NDArray[np.float64]]


class Model(ABC):
    """A baseline or candidate model of one channel (module docstring for the form)."""

    #: Verdict name (``"baseline"`` for the re-calibrated nominal).
    name: ClassVar[str] = ""
    #: ``"actuator"`` or ``"specimen"``: the channel the model explains.
    subsystem: ClassVar[Literal["actuator", "specimen"]]
    #: Effect parameters counted by the complexity penalty (0 for a baseline).
    n_effect: ClassVar[int] = 0
    #: Polish the search with Nelder-Mead (cost surfaces with kinks: limiters, dead zones).
    polish: ClassVar[bool] = False

    @abstractmethod
    def columns(self, channel: Channel, seg: Segment, theta: NDArray[np.float64]) -> Columns:
        """Regressors ``X`` (shape ``(n, p)``) and fixed part ``f`` (shape ``(n,)``)."""

    def starts(self, channel: Channel, base: dict[str, float]) -> list[NDArray[np.float64]]:
        """Starting points of the search over ``theta`` (empty: no nonlinear parameters).

        ``base`` is the re-calibrated baseline (:meth:`describe` of the baseline model).
        """
        return []

    def bounds(
        self, channel: Channel, base: dict[str, float]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Lower and upper bounds of ``theta``."""
        return np.empty(0), np.empty(0)

    @abstractmethod
    def describe(
        self, channel: Channel, theta: NDArray[np.float64], beta: NDArray[np.float64]
    ) -> tuple[dict[str, float], dict[str, float]]:
        """``(effect parameters, re-calibrated baseline)`` named in SI units."""

    def physical(self, channel: Channel, params: dict[str, float]) -> bool:
        """False when the identified effect parameters are unphysical (e.g. negative) or
        contradicted by the record."""
        return True

    @abstractmethod
    def prior(self, channel: Channel) -> NDArray[np.float64]:
        """The nominal values of ``beta`` (what the re-calibration shrinks towards where the
        data do not determine it, e.g. inertance against stiffness under a single sine)."""


# --------------------------------------------------------------------------------------------
# actuator channel


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

    def describe(self, channel: Channel, theta: NDArray, beta: NDArray):  # noqa: ANN201
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

    def bounds(self, channel: Channel, base: dict[str, float]):  # noqa: ANN201
        return np.array([-channel.nominal.actuator.delay]), np.array([self.max_delay])

    def prior(self, channel: Channel) -> NDArray:
        return np.array([1.0, 0.0])  # nominal gain, no offset

    def describe(self, channel: Channel, theta: NDArray, beta: NDArray):  # noqa: ANN201
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

    def bounds(self, channel: Channel, base: dict[str, float]):  # noqa: ANN201
        """Gain re-calibration within [0.5, 1.5] of the nominal; limit up to twice the peak."""
        peak = self._peak_velocity(channel, 1.0)
        return np.array([0.5, 0.02 * peak]), np.array([1.5, 2.0 * peak])

    def prior(self, channel: Channel) -> NDArray:
        return np.zeros(1)  # no offset

    def describe(self, channel: Channel, theta: NDArray, beta: NDArray):  # noqa: ANN201
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
        speed = np.concatenate([np.abs(s.observed[2 * k :] - s.observed[: -2 * k]) / window
                                for s in channel.segments])  # fmt: skip
        noise = math.sqrt(2.0) * channel.noise["measured"] / window
        return float(np.percentile(speed, 99.9)) <= 1.05 * v_max + 4.0 * noise


# --------------------------------------------------------------------------------------------
# specimen channel


def _smoothed(seg: Segment, key: str, make) -> NDArray:  # noqa: ANN001
    """Cached ``h * make()`` on a segment."""
    if key not in seg.cache:
        seg.cache[key] = seg.h(make())
    return seg.cache[key]


def _sign(channel: Channel, seg: Segment) -> NDArray:
    """``h * tanh(v/eps)``: the smoothed regularised sign of the drive velocity."""
    return _smoothed(seg, "sign", lambda: np.tanh(seg.signals["v"] / channel.friction_scale))


def _rigid(seg: Segment) -> tuple[NDArray, NDArray, NDArray]:
    s = seg.signals
    return (
        _smoothed(seg, "a", lambda: s["a"]),
        _smoothed(seg, "v", lambda: s["v"]),
        _smoothed(seg, "x", lambda: s["x"]),
    )


def _nominal_friction(channel: Channel, seg: Segment) -> NDArray:
    return channel.nominal.specimen.friction * _sign(channel, seg)


class SpecimenBaseline(Model):
    """Re-calibrated nominal specimen: ``F = m a + c v + k x + F_r0 sign(v) + b`` (S0 Eq.1)."""

    name = "baseline"
    subsystem = "specimen"

    def columns(self, channel: Channel, seg: Segment, theta: NDArray) -> Columns:
        a, v, x = _rigid(seg)
        return np.column_stack([a, v, x, np.ones_like(x)]), _nominal_friction(channel, seg)

    def prior(self, channel: Channel) -> NDArray:
        s = channel.nominal.specimen
        return np.array([s.inertance, s.damping, s.stiffness, 0.0])

    def describe(self, channel: Channel, theta: NDArray, beta: NDArray):  # noqa: ANN201
        m, c, k, b = (float(q) for q in beta)
        return {}, {"inertance": m, "damping": c, "stiffness": k, "offset": b}


class CoulombFriction(Model):
    """Coulomb friction at the driven end, ``+ F_r tanh(v/eps)`` with ``F_r`` free (S0 Eq.1).

    Linear in ``F_r``: identified in one least-squares solve with the baseline.  ``F_r`` is the
    total friction (the nominal's value is replaced, not added to).
    """

    name = "coulomb_friction"
    subsystem = "specimen"
    n_effect = 1

    def columns(self, channel: Channel, seg: Segment, theta: NDArray) -> Columns:
        a, v, x = _rigid(seg)
        s = _sign(channel, seg)
        return np.column_stack([a, v, x, s, np.ones_like(x)]), np.zeros_like(x)

    def prior(self, channel: Channel) -> NDArray:
        s = channel.nominal.specimen
        return np.array([s.inertance, s.damping, s.stiffness, s.friction, 0.0])

    def describe(self, channel: Channel, theta: NDArray, beta: NDArray):  # noqa: ANN201
        m, c, k, fr, b = (float(q) for q in beta)
        return {"friction": fr}, {"inertance": m, "damping": c, "stiffness": k, "offset": b}

    def physical(self, channel: Channel, params: dict[str, float]) -> bool:
        return params["friction"] > 0.0


def flywheel_displacement(
    x: NDArray[np.float64], dt: float, omega: float, zeta: float
) -> NDArray[np.float64]:
    """``x_i = G x`` with ``G = w^2/(s^2 + 2 zeta w s + w^2)`` (S0 Eq.12 flywheel), FOH-exact.

    The drive is taken piecewise linear between samples (first-order hold,
    ``scipy.signal.cont2discrete(method="foh")``) and the flywheel starts at rest at ``x[0]``.
    """
    num, den = [omega * omega], [1.0, 2.0 * zeta * omega, omega * omega]
    b, a, _ = signal.cont2discrete((num, den), dt, method="foh")
    b = np.ravel(b)
    zi = signal.lfiltic(b, a, np.full(2, x[0]), np.full(2, x[0]))
    return signal.lfilter(b, a, x, zi=zi)[0]


class InternalStiffness(Model):
    """Series internal stiffness, S0 Eq.12: ``F = k_s (x - x_i) + k x + F_r0 sign(v) + b``.

    The nominal inertance and damping move behind the spring onto the flywheel,
    ``m x_i'' + c x_i' = k_s (x - x_i)``, so ``F/x = k_s (1 - G)`` with
    ``G = w_e^2/(s^2 + 2 zeta w_e s + w_e^2)``, ``w_e = sqrt(k_s/m)``, ``c = 2 zeta w_e m``.
    ``theta = (f_e [Hz], zeta)``; ``beta = (m, k, b)``; reported ``stiffness = m w_e^2``.
    """

    name = "internal_stiffness"
    subsystem = "specimen"
    n_effect = 1

    def columns(self, channel: Channel, seg: Segment, theta: NDArray) -> Columns:
        omega = 2.0 * math.pi * float(theta[0])
        x = seg.signals["x"]
        per_mass = omega * omega * (x - flywheel_displacement(x, seg.dt, omega, float(theta[1])))
        _, _, xs = _rigid(seg)
        cols = np.column_stack([seg.h(per_mass), xs, np.ones_like(xs)])
        return cols, _nominal_friction(channel, seg)

    def _top(self, channel: Channel) -> float:
        return min(0.4 / channel.dt, 4.0 * (channel.cutoff or 0.2 / channel.dt))

    def starts(self, channel: Channel, base: dict[str, float]) -> list[NDArray]:
        out = []
        for f in np.geomspace(1.0, self._top(channel), 28):
            w = 2.0 * math.pi * f
            z0 = base["damping"] / (2.0 * w * base["inertance"]) if base["inertance"] > 0 else 0.05
            for z in sorted({min(max(z0, 0.003), 2.0), 0.05, 0.3}):
                out.append(np.array([f, z]))
        return out

    def bounds(self, channel: Channel, base: dict[str, float]):  # noqa: ANN201
        return np.array([0.5, 1e-3]), np.array([self._top(channel), 3.0])

    def prior(self, channel: Channel) -> NDArray:
        s = channel.nominal.specimen
        return np.array([s.inertance, s.stiffness, 0.0])

    def describe(self, channel: Channel, theta: NDArray, beta: NDArray):  # noqa: ANN201
        f, z = float(theta[0]), float(theta[1])
        m, k, b = (float(q) for q in beta)
        w = 2.0 * math.pi * f
        return {"stiffness": m * w * w, "frequency": f}, {
            "inertance": m,
            "damping": 2.0 * z * w * m,
            "stiffness": k,
            "offset": b,
        }

    def physical(self, channel: Channel, params: dict[str, float]) -> bool:
        return params["stiffness"] > 0.0


class Backlash(Model):
    """Backlash (total clearance ``gap``) in series with a contact spring before the flywheel.

    The force path is open while the gap is crossed and the flywheel coasts (S0 Table 6 EIMD,
    S1 Eq.11); simulated by :func:`rths.diagnose._kernels.series_force_per_mass`, the emulated
    lab's own kernel.  ``theta = (gap [m], f_c [Hz], c/m [1/s])`` with ``f_c = sqrt(k_c/m)/2pi``
    and the damping per unit inertance on the flywheel (started from the baseline's ``c/m``,
    which does not depend on ``f_c``); ``beta = (m, k, b)``; reported ``gap`` and the contact
    ``stiffness = m (2 pi f_c)^2``.  With ``gap -> 0`` this is :class:`InternalStiffness`,
    hence one more penalised parameter.
    """

    name = "backlash"
    subsystem = "specimen"
    n_effect = 2
    polish = True
    #: Highest contact frequency searched [Hz] (the default emulated contact is 100 Hz).
    max_frequency: ClassVar[float] = 200.0

    def columns(self, channel: Channel, seg: Segment, theta: NDArray) -> Columns:
        gap, f, c_per_m = (float(q) for q in theta)
        s = seg.signals
        per_mass = series_force_per_mass(
            s["x"], s["v"], seg.dt, c_per_m, 2.0 * math.pi * f, gap
        )
        _, _, xs = _rigid(seg)
        cols = np.column_stack([seg.h(per_mass), xs, np.ones_like(xs)])
        return cols, _nominal_friction(channel, seg)

    @staticmethod
    def _scale(channel: Channel) -> float:
        return float(np.std(channel.stack("x")))

    @staticmethod
    def _damping(base: dict[str, float]) -> float:
        m = base.get("inertance", 0.0)
        return max(base.get("damping", 0.0) / m, 0.1) if m > 0.0 else 1.0

    def _top(self, channel: Channel) -> float:
        return min(self.max_frequency, 0.4 / channel.dt)

    def starts(self, channel: Channel, base: dict[str, float]) -> list[NDArray]:
        scale, c0 = self._scale(channel), self._damping(base)
        return [
            np.array([gap, f, c])
            for f in np.geomspace(5.0, self._top(channel), 11)
            for gap in np.geomspace(3e-3 * scale, 0.3 * scale, 8)
            for c in (0.5 * c0, c0, 2.0 * c0)
        ]

    def bounds(self, channel: Channel, base: dict[str, float]):  # noqa: ANN201
        c0 = self._damping(base)
        return (np.array([0.0, 2.0, 0.01 * c0]),
                np.array([self._scale(channel), self._top(channel), 100.0 * c0]))  # fmt: skip

    def prior(self, channel: Channel) -> NDArray:
        s = channel.nominal.specimen
        return np.array([s.inertance, s.stiffness, 0.0])

    def describe(self, channel: Channel, theta: NDArray, beta: NDArray):  # noqa: ANN201
        gap, f, c_per_m = (float(q) for q in theta)
        m, k, b = (float(q) for q in beta)
        w = 2.0 * math.pi * f
        return {"gap": gap, "stiffness": m * w * w, "frequency": f}, {
            "inertance": m,
            "damping": c_per_m * m,
            "stiffness": k,
            "offset": b,
        }

    def physical(self, channel: Channel, params: dict[str, float]) -> bool:
        return params["gap"] > 0.0 and params["stiffness"] > 0.0


#: The candidate effects by verdict name ("room to add more": see the module docstring).
EFFECTS: dict[str, type[Model]] = {
    m.name: m
    for m in (InternalStiffness, Backlash, CoulombFriction, ActuatorDelay, RateLimit)
}


def baseline_for(subsystem: str) -> Model:
    """The re-calibrated nominal model of a subsystem's channel."""
    return ActuatorBaseline() if subsystem == "actuator" else SpecimenBaseline()
