"""Time to diagnose a 60 s record at 2048 Hz (goal: <= 30 s on one core).

    python tools/bench_diagnose.py [--repeats 3] [--duration 60] [--rate 2048] [--effect backlash]

One emulated-lab record (``rths.diagnose.data.synthetic``, the blind suite's lab) with a hidden
effect is diagnosed as a single file (alternating time split) with ``--drive auto`` and with
``--drive measured`` (the slower path: per-model noise floors are re-driven with synthetic
noise).  Prints the median wall time over the repeats (time.perf_counter) and the CPU time of
the process (time.process_time: what the wall time would be on an idle core).  For one core:
``OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 taskset -c 0 python tools/bench_diagnose.py``.

Measured figures are in the closing report of the change that last touched the diagnosis (the
machine is shared: quote ``uptime`` beside them).
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

import numpy as np

from rths.diagnose import Options, diagnose
from rths.diagnose.data.synthetic import LabCase, band_limited_command, lab_record

EFFECTS = {
    "internal_stiffness": 1589.0 * (2 * math.pi * 13.8) ** 2,
    "backlash": 2e-4,
    "coulomb_friction": 150.0,
    "actuator_delay": 0.006,
    "rate_limit": 0.06,
    "none": 0.0,
}


def main() -> None:
    """Command line (module docstring)."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n", 1)[0])
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--duration", type=float, default=60.0)
    p.add_argument("--rate", type=float, default=2048.0)
    p.add_argument("--effect", choices=sorted(EFFECTS), default="backlash")
    args = p.parse_args()
    dt = 1.0 / args.rate
    c = 2 * 0.15 * 1589.0 * 2 * math.pi * 20.0
    case = LabCase(args.effect, EFFECTS[args.effect], 1589.0, c, contact_frequency=20.0)
    rng = np.random.default_rng(0)
    command = band_limited_command(rng, args.duration, dt, (0.3, 6.0), 3e-3)
    t0 = time.perf_counter()
    record = lab_record(case, command, dt, seed=1, name="bench.csv")
    print(
        f"lab record: {record.n} samples ({args.duration:g} s at {args.rate:g} Hz), "
        f"generated in {time.perf_counter() - t0:.1f} s"
    )
    nominal = case.nominal(0.95 * 1589.0, 1.2 * c, 1.02)
    diagnose([record], nominal)  # warm-up: numba kernels from the on-disk cache
    for drive in ("measured", "auto"):
        times, cpu, verdict = [], [], ""
        for _ in range(args.repeats):
            t0, c0 = time.perf_counter(), time.process_time()
            d = diagnose([record], nominal, Options(drive=drive))
            times.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
            verdict = d.verdict
        print(
            f"drive={drive:9} wall median {statistics.median(times):6.2f} s  "
            f"(min {min(times):.2f}, max {max(times):.2f}, n={args.repeats}); "
            f"cpu median {statistics.median(cpu):6.2f} s  verdict {verdict}"
        )


if __name__ == "__main__":
    main()
