"""Specimen-channel models: the re-calibrated nominal specimen (S0 Eq.1 with an amplitude-dependent
damping, S0 Eq.17-18), Coulomb friction, internal stiffness (S0 Eq.12) and backlash."""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray
from scipy import signal

from rths.diagnose._kernels import series_force_per_mass
from rths.diagnose._model import Columns, Model
from rths.diagnose.channels import Channel, Segment

__all__ = [
    "AMPLITUDE_SCALE",
    "Backlash",
    "CoulombFriction",
    "InternalStiffness",
    "SpecimenBaseline",
    "flywheel_displacement",
]


def _smoothed(seg: Segment, key: str, make) -> NDArray:
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

    ``A`` is tracked as the emulated IMD does (:class:`plants.imd.amplitude.AmplitudeTracker`:
    half the peak-to-peak between the last two reversals, 0 until two reversals), with a
    hysteresis of five times the smoothed drive noise so that noise makes no reversals.
    """
    if "amplitude_weight" not in seg.cache:
        from plants.imd.amplitude import AmplitudeTracker
        from rths.diagnose._signals import impulse_kernel

        assert seg.sos is not None
        gain = float(np.sqrt(np.sum(impulse_kernel(seg.sos, seg.dt) ** 2)))
        tracker = AmplitudeTracker(max(1e-6, 5.0 * channel.noise["drive"] * gain), 0.1)
        amplitude = np.empty(seg.observed.size)
        for i, value in enumerate(seg.signals["x"].tolist()):
            tracker.update(value)
            amplitude[i] = tracker.amplitude
        seg.cache["amplitude_weight"] = AMPLITUDE_SCALE / (amplitude + AMPLITUDE_SCALE)
    return seg.cache["amplitude_weight"]


def _amplitude_damping(channel: Channel, seg: Segment) -> NDArray:
    """``h * (v A_0/(A + A_0))``: the regressor of the amplitude-dependent damping ``c_A``."""
    return _smoothed(
        seg, "amplitude_damping", lambda: seg.signals["v"] * _amplitude_weight(channel, seg)
    )


class _Flywheel(Model):
    """Shared part of the series models: the baseline's damping law moved onto the flywheel.

    The re-calibrated baseline damping ``c + c_A A_0/(A + A_0)`` (per unit nominal inertance) is put
    behind the series element, scaled by a factor ``kappa`` (a nonlinear parameter, 1 when
    the baseline's split holds), exactly as S0 Eq.12 puts ``c_d`` (with its amplitude law,
    Eq.18) on the flywheel.
    """

    _law: tuple[float, float] = (0.0, 0.0)

    def prepare(self, channel: Channel, base: dict[str, float]) -> None:
        # per unit of the *nominal* inertance: a strong series effect can drag the baseline's
        # re-calibrated inertance far from the truth (e.g. a 10x smaller inertance under a
        # wide backlash), its damping much less
        m = channel.nominal.specimen.inertance or base.get("inertance", 0.0)
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

    def describe(self, channel: Channel, theta: NDArray, beta: NDArray):
        m, c, k, ca, b = (float(q) for q in beta)
        return {}, {
            "inertance": m,
            "damping": c,
            "stiffness": k,
            "amplitude_damping": ca,
            "offset": b,
        }


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

    def describe(self, channel: Channel, theta: NDArray, beta: NDArray):
        m, c, k, ca, fr, b = (float(q) for q in beta)
        return {"friction": fr}, {
            "inertance": m,
            "damping": c,
            "stiffness": k,
            "amplitude_damping": ca,
            "offset": b,
        }

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
        return [
            np.array([f, kappa])
            for f in np.geomspace(1.0, self._top(channel), 28)
            for kappa in (0.3, 1.0, 3.0)
        ]

    def bounds(self, channel: Channel, base: dict[str, float]):
        return np.array([0.5, 1e-3]), np.array([self._top(channel), 1e3])

    def prior(self, channel: Channel) -> NDArray:
        s = channel.nominal.specimen
        return np.array([s.inertance, s.stiffness, 0.0])

    def describe(self, channel: Channel, theta: NDArray, beta: NDArray):
        f, kappa = float(theta[0]), float(theta[1])
        m, k, b = (float(q) for q in beta)
        w = 2.0 * math.pi * f
        return {"stiffness": m * w * w, "frequency": f}, {
            "inertance": m,
            **self._scaled(kappa, m),
            "stiffness": k,
            "offset": b,
        }

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
        return grid + [
            np.array([1e-4 * scale, f, 1.0]) for f in np.geomspace(2.0, self._top(channel), 28)
        ]

    def bounds(self, channel: Channel, base: dict[str, float]):
        return (
            np.array([0.0, 2.0, 1e-2]),
            np.array([self._scale(channel), self._top(channel), 1e2]),
        )

    def prior(self, channel: Channel) -> NDArray:
        s = channel.nominal.specimen
        return np.array([s.inertance, s.stiffness, 0.0])

    def describe(self, channel: Channel, theta: NDArray, beta: NDArray):
        gap, f, kappa = (float(q) for q in theta)
        m, k, b = (float(q) for q in beta)
        w = 2.0 * math.pi * f
        return {"gap": gap, "stiffness": m * w * w, "frequency": f}, {
            "inertance": m,
            **self._scaled(kappa, m),
            "stiffness": k,
            "offset": b,
        }

    def physical(self, channel: Channel, params: dict[str, float]) -> bool:
        return params["gap"] > 0.0 and params["stiffness"] > 0.0
