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
internal_stiffness   specimen   f_e = sqrt(k_s/m)/2pi, kappa         S0 Eq.12 (series spring)
backlash             specimen   gap, contact f_c, kappa              S0 Table 6, S1 Eq.11
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

    def prepare(self, channel: Channel, base: dict[str, float]) -> None:  # noqa: B027
        """Take what the model needs from the re-calibrated baseline (default: nothing)."""

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


#: ``A_0`` [m] of the amplitude-dependent damping re-calibration ``c + c_A A_0/(A + A_0)``: the
#: ``c_2`` of S0 Eq.18 for the Type II damper (0.153 mm; Type I: 0.236 mm).
AMPLITUDE_SCALE: float = 0.153e-3


def _amplitude_weight(channel: Channel, seg: Segment) -> NDArray:
    """``A_0/(A + A_0)`` per sample, ``A`` the load amplitude of S0 Eq.17-18 on the drive.

    ``A`` is tracked as the emulated IMD does (:class:`plants._imd_amplitude.AmplitudeTracker`:
    half the peak-to-peak between the last two reversals, 0 until two reversals), with a
    hysteresis of five times the smoothed drive noise so that noise makes no reversals.
    """
    if "amplitude_weight" not in seg.cache:
        from plants._imd_amplitude import AmplitudeTracker
        from rths.diagnose._signals import impulse_kernel

        assert seg.sos is not None
        gain = float(np.sqrt(np.sum(impulse_kernel(seg.sos, seg.dt) ** 2)))
        tracker = AmplitudeTracker(max(1e-6, 5.0 * channel.noise["drive"] * gain))
        amplitude = np.empty(seg.observed.size)
        for i, value in enumerate(seg.signals["x"].tolist()):
            tracker.update(value)
            amplitude[i] = tracker.amplitude
        seg.cache["amplitude_weight"] = AMPLITUDE_SCALE / (amplitude + AMPLITUDE_SCALE)
    return seg.cache["amplitude_weight"]


def _amplitude_damping(channel: Channel, seg: Segment) -> NDArray:
    """``h * (v A_0/(A + A_0))``: the regressor of the amplitude-dependent damping ``c_A``."""
    return _smoothed(seg, "amplitude_damping",
                     lambda: seg.signals["v"] * _amplitude_weight(channel, seg))  # fmt: skip


class _Flywheel(Model):
    """Shared part of the series models: the baseline's damping law moved onto the flywheel.

    The re-calibrated baseline damping ``c + c_A A_0/(A + A_0)`` (per unit inertance) is put
    behind the series element, scaled by a factor ``kappa`` (a nonlinear parameter, 1 when
    the baseline's split holds), exactly as S0 Eq.12 puts ``c_d`` (with its amplitude law,
    Eq.18) on the flywheel.
    """

    _law: tuple[float, float] = (0.0, 0.0)

    def prepare(self, channel: Channel, base: dict[str, float]) -> None:
        m = base.get("inertance", channel.nominal.specimen.inertance)
        if m > 0.0:
            self._law = (base.get("damping", 0.0) / m, base.get("amplitude_damping", 0.0) / m)
        else:
            self._law = (1.0, 0.0)

    def _damping(self, channel: Channel, seg: Segment, kappa: float) -> NDArray:
        c0, ca = self._law
        law = c0 + ca * _amplitude_weight(channel, seg)
        return np.clip(kappa * law, 0.0, None)

    def _scaled(self, kappa: float, m: float) -> dict[str, float]:
        return {"damping": kappa * self._law[0] * m, "amplitude_damping": kappa * self._law[1] * m}


def _nominal_friction(channel: Channel, seg: Segment) -> NDArray:
    return channel.nominal.specimen.friction * _sign(channel, seg)


class SpecimenBaseline(Model):
    """Re-calibrated nominal specimen: ``F = m a + c v + k x + F_r0 sign(v) + b`` (S0 Eq.1)."""

    name = "baseline"
    subsystem = "specimen"

    def columns(self, channel: Channel, seg: Segment, theta: NDArray) -> Columns:
        a, v, x = _rigid(seg)
        va = _amplitude_damping(channel, seg)
        return np.column_stack([a, v, x, va, np.ones_like(x)]), _nominal_friction(channel, seg)

    def prior(self, channel: Channel) -> NDArray:
        s = channel.nominal.specimen
        return np.array([s.inertance, s.damping, s.stiffness, 0.0, 0.0])

    def describe(self, channel: Channel, theta: NDArray, beta: NDArray):  # noqa: ANN201
        m, c, k, ca, b = (float(q) for q in beta)
        return {}, {"inertance": m, "damping": c, "stiffness": k, "amplitude_damping": ca,
                    "offset": b}  # fmt: skip


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
        va = _amplitude_damping(channel, seg)
        return np.column_stack([a, v, x, va, s, np.ones_like(x)]), np.zeros_like(x)

    def prior(self, channel: Channel) -> NDArray:
        s = channel.nominal.specimen
        return np.array([s.inertance, s.damping, s.stiffness, 0.0, s.friction, 0.0])

    def describe(self, channel: Channel, theta: NDArray, beta: NDArray):  # noqa: ANN201
        m, c, k, ca, fr, b = (float(q) for q in beta)
        return {"friction": fr}, {"inertance": m, "damping": c, "stiffness": k,
                                  "amplitude_damping": ca, "offset": b}  # fmt: skip

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


class InternalStiffness(_Flywheel):
    """Series internal stiffness, S0 Eq.12: ``F = k_s (x - x_i) + k x + F_r0 sign(v) + b``.

    The nominal inertance and (amplitude-dependent) damping move behind the spring onto the
    flywheel, ``m x_i'' + c(A) x_i' = k_s (x - x_i)``; with a constant ``c`` this is
    ``F/x = k_s (1 - G)``, ``G = w_e^2/(s^2 + (c/m) s + w_e^2)``, ``w_e = sqrt(k_s/m)``.
    Simulated by the emulated IMD's own kernel (:func:`series_force_per_mass`, no gap).
    ``theta = (f_e [Hz], kappa)``; ``beta = (m, k, b)``; reported ``stiffness = m w_e^2``.
    """

    name = "internal_stiffness"
    subsystem = "specimen"
    n_effect = 1

    def columns(self, channel: Channel, seg: Segment, theta: NDArray) -> Columns:
        omega = 2.0 * math.pi * float(theta[0])
        s = seg.signals
        damping = self._damping(channel, seg, float(theta[1]))
        per_mass = series_force_per_mass(s["x"], s["v"], seg.dt, damping, omega, 0.0)
        _, _, xs = _rigid(seg)
        cols = np.column_stack([seg.h(per_mass), xs, np.ones_like(xs)])
        return cols, _nominal_friction(channel, seg)

    def _top(self, channel: Channel) -> float:
        return min(0.4 / channel.dt, 4.0 * (channel.cutoff or 0.2 / channel.dt))

    def starts(self, channel: Channel, base: dict[str, float]) -> list[NDArray]:
        return [np.array([f, kappa]) for f in np.geomspace(1.0, self._top(channel), 28)
                for kappa in (0.3, 1.0, 3.0)]  # fmt: skip

    def bounds(self, channel: Channel, base: dict[str, float]):  # noqa: ANN201
        return np.array([0.5, 1e-3]), np.array([self._top(channel), 1e3])

    def prior(self, channel: Channel) -> NDArray:
        s = channel.nominal.specimen
        return np.array([s.inertance, s.stiffness, 0.0])

    def describe(self, channel: Channel, theta: NDArray, beta: NDArray):  # noqa: ANN201
        f, kappa = float(theta[0]), float(theta[1])
        m, k, b = (float(q) for q in beta)
        w = 2.0 * math.pi * f
        return {"stiffness": m * w * w, "frequency": f}, {
            "inertance": m, **self._scaled(kappa, m), "stiffness": k, "offset": b,
        }  # fmt: skip

    def physical(self, channel: Channel, params: dict[str, float]) -> bool:
        return params["stiffness"] > 0.0


class Backlash(_Flywheel):
    """Backlash (total clearance ``gap``) in series with a contact spring before the flywheel.

    The force path is open while the gap is crossed and the flywheel coasts (S0 Table 6 EIMD,
    S1 Eq.11); simulated by :func:`rths.diagnose._kernels.series_force_per_mass`, the emulated
    lab's own kernel, with the baseline's damping law on the flywheel (:class:`_Flywheel`).
    ``theta = (gap [m], f_c [Hz], kappa)`` with ``f_c = sqrt(k_c/m)/2pi``;
    ``beta = (m, k, b)``; reported ``gap`` and the contact ``stiffness = m (2 pi f_c)^2``.  With
    ``gap -> 0`` this is :class:`InternalStiffness`, hence one more penalised parameter.
    """

    name = "backlash"
    subsystem = "specimen"
    n_effect = 2
    polish = True
    #: Highest contact frequency searched [Hz] (the default emulated contact is 100 Hz).
    max_frequency: ClassVar[float] = 200.0

    def columns(self, channel: Channel, seg: Segment, theta: NDArray) -> Columns:
        gap, f, kappa = (float(q) for q in theta)
        s = seg.signals
        damping = self._damping(channel, seg, kappa)
        per_mass = series_force_per_mass(s["x"], s["v"], seg.dt, damping, 2.0 * math.pi * f, gap)
        _, _, xs = _rigid(seg)
        cols = np.column_stack([seg.h(per_mass), xs, np.ones_like(xs)])
        return cols, _nominal_friction(channel, seg)

    @staticmethod
    def _scale(channel: Channel) -> float:
        return float(np.std(channel.stack("x")))

    def _top(self, channel: Channel) -> float:
        return min(self.max_frequency, 0.4 / channel.dt)

    def starts(self, channel: Channel, base: dict[str, float]) -> list[NDArray]:
        scale = self._scale(channel)
        grid = [
            np.array([gap, f, kappa])
            for f in np.geomspace(5.0, self._top(channel), 11)
            for gap in np.geomspace(3e-3 * scale, 0.3 * scale, 8)
            for kappa in (0.5, 1.0, 2.0)
        ]
        # and the internal-stiffness limit (no gap) on a finer frequency grid
        return grid + [np.array([1e-4 * scale, f, 1.0])
                       for f in np.geomspace(2.0, self._top(channel), 28)]  # fmt: skip

    def bounds(self, channel: Channel, base: dict[str, float]):  # noqa: ANN201
        return (np.array([0.0, 2.0, 1e-2]),
                np.array([self._scale(channel), self._top(channel), 1e2]))  # fmt: skip

    def prior(self, channel: Channel) -> NDArray:
        s = channel.nominal.specimen
        return np.array([s.inertance, s.stiffness, 0.0])

    def describe(self, channel: Channel, theta: NDArray, beta: NDArray):  # noqa: ANN201
        gap, f, kappa = (float(q) for q in theta)
        m, k, b = (float(q) for q in beta)
        w = 2.0 * math.pi * f
        return {"gap": gap, "stiffness": m * w * w, "frequency": f}, {
            "inertance": m, **self._scaled(kappa, m), "stiffness": k, "offset": b,
        }  # fmt: skip

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
