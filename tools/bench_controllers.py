"""Benchmark of the compensators: per-step cost and closed-loop J2 on perturbed vRTHS plants.

Usage::

    python tools/bench_controllers.py                 # per-step cost of every kind
    python tools/bench_controllers.py --plants 20     # ... plus J2 over 20 perturbed plants

Per-step cost: each compensator (built by ``make_compensator`` for the vRTHS benchmark nominal
model at 4096 Hz) is stepped through a 1-5 Hz multi-sine with measurements from the nominal
plant under feedforward; after a warm-up that fills the ATS window, ``time.perf_counter`` over
``--repeats`` blocks of ``--steps`` steps, median reported in microseconds per step, plus the
99th percentile of single steps (the ATS least-squares update runs on every 16th step; the
maximum is not reported because a shared machine's scheduler dominates it).

J2: RMS(y - r)/RMS(r) of the true displacement, 1-5 Hz multi-sine (2 mm per sine), sensor
noise 2e-5 m RMS, over ``[--skip, --duration]`` s, plants drawn from the benchmark's parameter
uncertainty (a3, beta1, beta2, k normal; Silva et al. 2020).
"""

from __future__ import annotations

import argparse
import statistics
import time

import control
import numpy as np

from controllers._lti import balanced_realization, siso_polynomials
from controllers.factory import kinds, make_compensator
from plants.base import Kinematics

DT = 1.0 / 4096.0
NOMINAL = {"a3": 3.3, "b1": 425.0, "b2": 9.9976e4, "k": 1.19e6}
SIGMA = {"a3": 1.3, "b1": 3.3, "b2": 3.3e3, "k": 5.0e4}


def benchmark_plant(a3: float, b1: float, b2: float, k: float) -> control.TransferFunction:
    """vRTHS benchmark command -> displacement transfer function (Silva et al. 2020)."""
    s = control.tf("s")
    a1b0, a2, gain, m = 2.1283e13, 4.2297e6, 1.0261, 29.13
    c = 2.0 * 0.0097 * np.sqrt(k * m)
    g0 = control.feedback(1 / (s + a3) * (1 / (m * s**2 + c * s + k)), a2 * s)
    return control.minreal(
        gain * control.feedback(a1b0 / (s**2 + b1 * s + b2) * g0, 1), verbose=False
    )


def multisine(duration: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """1-5 Hz multi-sine, 2 mm per component, C2 fade-in over 0.5 s: (r, v, a)."""
    t = np.arange(int(round(duration / DT)) + 1) * DT
    r, v, a = (np.zeros_like(t) for _ in range(3))
    for i, f in enumerate((1.0, 2.0, 3.0, 4.0, 5.0)):
        w, ph = 2 * np.pi * f, 1.3 * i * i
        r += 2e-3 * np.sin(w * t + ph)
        v += 2e-3 * w * np.cos(w * t + ph)
        a -= 2e-3 * w * w * np.sin(w * t + ph)
    x = np.clip(t / 0.5, 0.0, 1.0)
    inside = (t < 0.5).astype(float)
    w0 = x**3 * (10 - 15 * x + 6 * x**2)
    w1 = inside * 60 * x**2 * (1 - x) ** 2
    w2 = inside * 240 * x * (1 - x) * (1 - 2 * x)
    return w0 * r, w1 * r + w0 * v, w2 * r + 2 * w1 * v + w0 * a


def discretize(plant: control.TransferFunction) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    num, den = siso_polynomials(plant)
    a, b, c, _ = balanced_realization(num, den)
    sd = control.c2d(control.ss(a, b, c, 0.0), DT, method="zoh")
    return np.asarray(sd.A), np.asarray(sd.B)[:, 0], np.asarray(sd.C)[0, :]


def closed_loop(comp, plant, target, noise_rms: float, rng: np.random.Generator) -> np.ndarray:
    a, b, c = plant
    r, v, acc = target
    n = r.size - 1
    noise = rng.normal(0.0, noise_rms, n + 1)
    x = np.zeros(a.shape[0])
    y = np.zeros(n + 1)
    comp.reset()
    for k in range(n):
        u = comp.step(Kinematics(r[k + 1], v[k + 1], acc[k + 1]), y[k] + noise[k])
        x = a @ x + b * u
        y[k + 1] = c @ x
    return y


def per_step_cost(steps: int, repeats: int) -> None:
    """Median cost of ``steps`` consecutive steps after a 2-block warm-up (the ATS window fills)."""
    nominal = benchmark_plant(**NOMINAL)
    warmup = 2 * max(steps, int(1.0 / DT))
    n = warmup + steps * repeats
    r, v, a = multisine(n * DT)
    y = closed_loop(
        make_compensator("ff", DT, nominal),
        discretize(nominal),
        (r, v, a),
        0.0,
        np.random.default_rng(0),
    )
    targets = [Kinematics(r[k + 1], v[k + 1], a[k + 1]) for k in range(n)]
    print(
        f"per-step cost at dt = 1/{1 / DT:.0f} s (median of {repeats} blocks of {steps} steps "
        "after warm-up; 99th percentile of single steps):"
    )
    for kind in kinds():
        comp = make_compensator(kind, DT, nominal)
        for k in range(warmup):
            comp.step(targets[k], y[k])
        times = []
        for i in range(repeats):
            k0 = warmup + i * steps
            t0 = time.perf_counter()
            for k in range(k0, k0 + steps):
                comp.step(targets[k], y[k])
            times.append((time.perf_counter() - t0) / steps * 1e6)
        single = np.empty(steps)
        for j, k in enumerate(range(n - steps, n)):
            t0 = time.perf_counter()
            comp.step(targets[k], y[k])
            single[j] = time.perf_counter() - t0
        p99 = np.percentile(single, 99) * 1e6
        print(
            f"  {kind:<11s} {statistics.median(times):7.2f} us/step   "
            f"(99th percentile step {p99:.1f} us)"
        )


def monte_carlo(n_plants: int, duration: float, skip: float, seed: int) -> None:
    nominal = benchmark_plant(**NOMINAL)
    rng = np.random.default_rng(seed)
    plants = []
    for _ in range(n_plants):
        p = {key: rng.normal(NOMINAL[key], SIGMA[key]) for key in NOMINAL}
        p["a3"] = max(p["a3"], 0.5)
        plants.append(discretize(benchmark_plant(**p)))
    target = multisine(duration)
    i0 = int(round(skip / DT))
    r = target[0][i0:]
    print(
        f"J2 over {n_plants} perturbed benchmark plants ({duration:g} s 1-5 Hz multi-sine, "
        f"J2 over t >= {skip:g} s, sensor noise 2e-5 m):"
    )
    nominal_d = discretize(nominal)
    for kind in kinds():
        comp = make_compensator(kind, DT, nominal)
        t0 = time.perf_counter()
        j2 = []
        for i, plant in enumerate(plants):
            y = closed_loop(comp, plant, target, 2e-5, np.random.default_rng(i))[i0:]
            j2.append(np.sqrt(np.mean((y - r) ** 2) / np.mean(r**2)))
        y = closed_loop(comp, nominal_d, target, 2e-5, np.random.default_rng(99))[i0:]
        j_nom = np.sqrt(np.mean((y - r) ** 2) / np.mean(r**2))
        print(
            f"  {kind:<11s} median {np.median(j2):.4f}  worst {np.max(j2):.4f}  "
            f"nominal plant {j_nom:.4f}   ({time.perf_counter() - t0:.1f} s)"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--steps", type=int, default=4096, help="steps per timed block")
    parser.add_argument("--repeats", type=int, default=15, help="timed blocks per compensator")
    parser.add_argument("--plants", type=int, default=0, help="perturbed plants for J2 (0: skip)")
    parser.add_argument("--duration", type=float, default=6.0, help="closed-loop run length [s]")
    parser.add_argument("--skip", type=float, default=2.0, help="start of the J2 window [s]")
    parser.add_argument("--seed", type=int, default=2024, help="seed of the plant draws")
    args = parser.parse_args()
    per_step_cost(args.steps, args.repeats)
    if args.plants > 0:
        monte_carlo(args.plants, args.duration, args.skip, args.seed)


if __name__ == "__main__":
    main()
