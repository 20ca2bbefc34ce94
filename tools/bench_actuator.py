"""Per-step cost of the actuator models and the emulated lab, and the presets' characteristics.

Usage::

    python tools/bench_actuator.py [--blocks 30] [--block-steps 1000]

Prints the median cost in microseconds per loop step (``time.perf_counter`` over ``--blocks``
blocks of ``--block-steps`` steps, sine command) at the benchmark's 4096 Hz loop rate for:

* the vRTHS benchmark actuator with its LinearSpecimen (default sub-steps),
* the generic transfer-function actuator (third-order model, LinearSpecimen),
* the whole ``EmulatedLab.step`` (DAC, benchmark actuator, two noisy ADCs),

then the closed-loop poles and the gain / phase delay at 1, 2, 3, 5 Hz of the two presets
(BENCHMARK with the benchmark specimen; HEAVY_INERTIAL_LOAD with the Type II IMD of S0 Table 4
as a rigid 1589 kg inertance and behind its internal stiffness k0 = 1.2e7 N/m, S0 Eq.12).
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from collections.abc import Callable

import control
import numpy as np

from plants.actuator import (
    BENCHMARK,
    HEAVY_INERTIAL_LOAD,
    ServoHydraulicActuator,
    TransferFunctionActuator,
)
from plants.lab import EmulatedLab
from plants.linear_specimen import LinearSpecimen, benchmark_specimen
from rths.core.errors import ParameterError

DT = 1.0 / 4096.0
IMD_MASS, IMD_K0 = 1589.0, 1.2e7  # S0 Table 4, Type II


def median_step_us(step: Callable[[float], object], blocks: int, block_steps: int) -> float:
    """Median over blocks of the mean wall time per call [us], sine command 5 mm at 2 Hz."""
    command = (0.005 * np.sin(2 * math.pi * 2.0 * DT * np.arange(block_steps))).tolist()
    for u in command[:200]:  # warm-up (numba, caches)
        step(u)
    per_step = []
    for _ in range(blocks):
        start = time.perf_counter()
        for u in command:
            step(u)
        per_step.append((time.perf_counter() - start) / block_steps * 1e6)
    return statistics.median(per_step)


def describe(name: str, system: control.LTI) -> None:
    """Print poles (with damping ratios) and gain / phase delay at 1, 2, 3, 5 Hz."""
    poles = system.poles()
    print(f"\n{name}")
    for p in sorted(poles, key=lambda z: (abs(z), z.imag)):
        if p.imag >= 0:
            print(f"  pole {p.real:9.2f} {p.imag:+9.2f}j rad/s   zeta {-p.real / abs(p):.3f}")
    for f in (1.0, 2.0, 3.0, 5.0):
        h = complex(system(2j * math.pi * f))
        delay_ms = -np.angle(h) / (2 * math.pi * f) * 1e3
        print(f"  {f:3.0f} Hz  gain {abs(h):.4f}  phase delay {delay_ms:6.2f} ms")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--blocks", type=int, default=30)
    parser.add_argument("--block-steps", type=int, default=1000)
    args = parser.parse_args()

    benchmark = ServoHydraulicActuator(benchmark_specimen(), DT)
    generic = TransferFunctionActuator(
        [50.0 * 102500.0],
        np.polymul([1.0, 50.0], [1.0, 400.0, 102500.0]),
        LinearSpecimen(29.13, 114.0, 1.19e6),
        DT,
    )
    lab = EmulatedLab(ServoHydraulicActuator(benchmark_specimen(), DT), seed=0)
    print(f"loop rate {1 / DT:.0f} Hz, {args.blocks} blocks x {args.block_steps} steps, median")
    for name, step in (
        (f"benchmark actuator + LinearSpecimen ({benchmark.substeps} sub-steps)", benchmark.step),
        ("generic TF actuator (3rd order) + LinearSpecimen", generic.step),
        ("EmulatedLab.step (DAC + benchmark actuator + 2 ADCs)", lab.step),
    ):
        print(f"  {name:58s} {median_step_us(step, args.blocks, args.block_steps):7.2f} us/step")

    describe(
        "BENCHMARK + LinearSpecimen(29.13 kg, 114.2 N s/m, 1.19e6 N/m), command -> x",
        benchmark.closed_loop()[0, 0],
    )
    rigid = ServoHydraulicActuator(LinearSpecimen(IMD_MASS, 0.0, 0.0), DT, HEAVY_INERTIAL_LOAD)
    describe("HEAVY_INERTIAL_LOAD + rigid 1589 kg inertance", rigid.closed_loop()[0, 0])
    piston_only = ServoHydraulicActuator(LinearSpecimen(0.0, 0.0, 0.0), DT, HEAVY_INERTIAL_LOAD)
    series = control.tf([IMD_K0 * IMD_MASS, 0.0, 0.0], [IMD_MASS, 0.0, IMD_K0])
    describe(
        "HEAVY_INERTIAL_LOAD + 1589 kg behind k0 = 1.2e7 N/m (S0 Eq.12, no internal damping)",
        piston_only.closed_loop(series)[0, 0],
    )
    try:
        ServoHydraulicActuator(LinearSpecimen(IMD_MASS, 0.0, 0.0), DT, BENCHMARK)
    except ParameterError as exc:
        print(f"\nBENCHMARK + rigid 1589 kg inertance: {exc}")


if __name__ == "__main__":
    main()
