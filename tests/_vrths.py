"""Test fixtures for the compensator tests: vRTHS benchmark plants, targets, a closed loop, J2.

The plants are built here with python-control from the published vRTHS benchmark transfer system
(Silva et al. 2020) so the compensator tests do not depend on ``plants.actuator``.
"""

from __future__ import annotations

from dataclasses import dataclass

import control
import numpy as np
from numpy.typing import NDArray

from controllers.base import Compensator
from rths.core.kinematics import Kinematics

FloatArray = NDArray[np.float64]

#: Nominal vRTHS benchmark parameters and their standard deviations (Silva et al. 2020).
NOMINAL = {"a3": 3.3, "b1": 425.0, "b2": 9.9976e4, "k": 1.19e6}
SIGMA = {"a3": 1.3, "b1": 3.3, "b2": 3.3e3, "k": 5.0e4}


def benchmark_plant(
    a3: float = 3.3, b1: float = 425.0, b2: float = 9.9976e4, k: float = 1.19e6
) -> control.TransferFunction:
    """vRTHS command -> measured displacement TF (5 poles, DC 1.0075, ~25 ms delay at 1 Hz)."""
    s = control.tf("s")
    a1b0, a2, gain, m = 2.1283e13, 4.2297e6, 1.0261, 29.13
    c = 2.0 * 0.0097 * np.sqrt(k * m)
    gs = a1b0 / (s**2 + b1 * s + b2)
    ga = 1 / (s + a3)
    gest = 1 / (m * s**2 + c * s + k)
    g0 = control.feedback(ga * gest, a2 * s)
    return control.minreal(gain * control.feedback(gs * g0, 1), verbose=False)


def heavy_plant() -> control.TransferFunction:
    """Actuator carrying a ~1.6 t inerter: two 2nd-order sections, 6 Hz/0.7 and 12 Hz/0.5.

    Low-frequency delay 2*0.7/w1 + 2*0.5/w2 = 50.4 ms; |G| within 1 % of 1 up to 3 Hz.
    """
    s = control.tf("s")
    w1, z1, w2, z2 = 2 * np.pi * 6.0, 0.7, 2 * np.pi * 12.0, 0.5
    return (w1**2 / (s**2 + 2 * z1 * w1 * s + w1**2)) * (w2**2 / (s**2 + 2 * z2 * w2 * s + w2**2))


def perturbed_plants(n: int, seed: int = 2024) -> list[control.TransferFunction]:
    """``n`` benchmark plants with normally distributed parameters (a3 kept >= 0.5)."""
    rng = np.random.default_rng(seed)
    plants = []
    for _ in range(n):
        p = {key: rng.normal(NOMINAL[key], SIGMA[key]) for key in NOMINAL}
        p["a3"] = max(p["a3"], 0.5)
        plants.append(benchmark_plant(**p))
    return plants


@dataclass(frozen=True)
class Target:
    """Target samples r_j, v_j, a_j at t_j = j dt, j = 0..n."""

    dt: float
    r: FloatArray
    v: FloatArray
    a: FloatArray


def multisine(
    dt: float,
    duration: float,
    freqs_hz: tuple[float, ...] = (1.0, 2.0, 3.0, 4.0, 5.0),
    amplitude: float = 2.0e-3,
    fade: float = 0.5,
) -> Target:
    """Multi-sine target with a C2-smooth fade-in over ``fade`` [s] (exact derivatives)."""
    t = np.arange(int(round(duration / dt)) + 1) * dt
    s = np.zeros_like(t)
    sd = np.zeros_like(t)
    sdd = np.zeros_like(t)
    for i, f in enumerate(freqs_hz):
        w, ph = 2 * np.pi * f, 1.3 * i * i  # Schroeder-like phases keep the crest factor low
        s += amplitude * np.sin(w * t + ph)
        sd += amplitude * w * np.cos(w * t + ph)
        sdd -= amplitude * w * w * np.sin(w * t + ph)
    x = np.clip(t / fade, 0.0, 1.0)
    inside = (t < fade).astype(float)
    w0 = x**3 * (10 - 15 * x + 6 * x**2)
    w1 = inside * 30 * x**2 * (1 - x) ** 2 / fade
    w2 = inside * 60 * x * (1 - x) * (1 - 2 * x) / fade**2
    return Target(dt, w0 * s, w1 * s + w0 * sd, w2 * s + 2 * w1 * sd + w0 * sdd)


def discretize(plant: control.LTI, dt: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    """ZOH discretisation (A, B, C) of a continuous plant in a well-scaled realisation."""
    from controllers._lti import balanced_realization, siso_polynomials

    num, den = siso_polynomials(plant, "test plant")
    a, b, c, _ = balanced_realization(num, den)
    sd = control.c2d(control.ss(a, b, c, 0.0), dt, method="zoh")
    return np.asarray(sd.A), np.asarray(sd.B)[:, 0], np.asarray(sd.C)[0, :]


def closed_loop(
    comp: Compensator,
    plant: tuple[FloatArray, FloatArray, FloatArray],
    target: Target,
    noise_rms: float = 0.0,
    output_disturbance: float = 0.0,
    disturbance_from: float = 0.0,
    seed: int = 7,
) -> tuple[FloatArray, FloatArray]:
    """Run the RTHS loop; return (true displacement y_j, command u_j) for j = 0..n.

    ``y`` includes the output disturbance (it is a displacement the specimen really has); the
    compensator sees ``y`` plus white sensor noise of RMS ``noise_rms``.
    """
    a, b, c = plant
    rng = np.random.default_rng(seed)
    n = target.r.size - 1
    noise = rng.normal(0.0, noise_rms, n + 1) if noise_rms > 0 else np.zeros(n + 1)
    y = np.zeros(n + 1)
    u = np.zeros(n + 1)
    x = np.zeros(a.shape[0])
    comp.reset()
    k_dist = int(round(disturbance_from / target.dt))
    for k in range(n):
        tgt = Kinematics(target.r[k + 1], target.v[k + 1], target.a[k + 1])
        u[k] = comp.step(tgt, y[k] + noise[k])
        x = a @ x + b * u[k]
        y[k + 1] = c @ x + (output_disturbance if k + 1 >= k_dist else 0.0)
    return y, u


def j2(y: FloatArray, r: FloatArray, skip: int) -> float:
    """Benchmark J2: RMS(y - r)/RMS(r) over samples ``skip:``."""
    e = y[skip:] - r[skip:]
    return float(np.sqrt(np.mean(e**2)) / np.sqrt(np.mean(r[skip:] ** 2)))
