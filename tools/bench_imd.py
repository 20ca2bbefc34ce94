"""Per-step cost of the IMD specimen models at a 4096 Hz drive rate.

Run:  python tools/bench_imd.py [--steps N] [--repeats R]

Each model is driven through a 2 Hz, 5 mm sine (precomputed arrays, so only ``step`` is timed);
the cost of one ``step`` call is the median over the repeats of (wall time / steps), measured with
``time.perf_counter``.  The numba kernel is compiled (or loaded from its cache) before timing.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from dataclasses import replace

import numpy as np

from plants.base import Specimen
from plants.imd.models import IMDParameters, InternalStiffnessIMD, SimplifiedIMD

FS = 4096.0


def cases() -> dict[str, Specimen]:
    """The benchmarked configurations, by label."""
    type_ii = IMDParameters.preset("type_ii")
    everything = replace(type_ii, free_length=0.5, clearance=0.02e-3, friction=30.0)
    return {
        "simplified (Type II, S0 Eq.1)": SimplifiedIMD(type_ii),
        "internal stiffness (Type II, Eq.12)": InternalStiffnessIMD(type_ii),
        "backlash (EIMD small, Table 6)": InternalStiffnessIMD(IMDParameters.preset("eimd_small")),
        "all effects on (Type II)": InternalStiffnessIMD(everything),
        "all effects on, pure Python ref.": InternalStiffnessIMD(everything, use_jit=False),
    }


def per_step_us(model: Specimen, steps: int, repeats: int) -> tuple[float, int]:
    """Median cost of one step [us] and the sub-steps the model chose at this rate."""
    t = np.arange(1, steps + 1) / FS
    w = 2 * math.pi * 2.0
    u, v, a = 5e-3 * np.sin(w * t), 5e-3 * w * np.cos(w * t), -5e-3 * w * w * np.sin(w * t)
    u, v, a = u.tolist(), v.tolist(), a.tolist()  # Python floats, as the loop passes them
    dt = 1.0 / FS
    model.reset()
    model.step(u[0], v[0], a[0], dt)  # compile / load the kernel
    samples = []
    for _ in range(repeats):
        model.reset()
        step = model.step
        t0 = time.perf_counter()
        for i in range(steps):
            step(u[i], v[i], a[i], dt)
        samples.append((time.perf_counter() - t0) / steps * 1e6)
    n_sub = model.substeps(dt, 0.0, 5e-3) if isinstance(model, InternalStiffnessIMD) else 0
    return statistics.median(samples), n_sub


def main() -> None:
    """Print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=4096 * 5, help="steps per repeat")
    parser.add_argument("--repeats", type=int, default=7, help="repeats (median reported)")
    args = parser.parse_args()
    print(f"IMD per-step cost at {FS:.0f} Hz, {args.steps} steps x {args.repeats} repeats")
    print(f"{'model':40s} {'us/step':>8s} {'sub-steps':>9s}")
    for label, model in cases().items():
        cost, n_sub = per_step_us(model, args.steps, args.repeats)
        print(f"{label:40s} {cost:8.2f} {n_sub if n_sub else '-':>9}")


if __name__ == "__main__":
    main()
