"""Per-step cost of the S1 plants: rack-and-pinion inerter, TMDIStructure, TMDISubstructure.

Usage::

    python tools/bench_tmdi.py [--repeats 7] [--seconds 20] [--rates 1000 2000 4096]

Prints, as the median over ``--repeats`` runs (``time.perf_counter``):

* the rack-and-pinion inerter specimen (NF, IF, LF flywheels of S1 Table 1) driven by a sine of
  10 mm at 2.25 Hz through ``Specimen.step`` from Python: microseconds per call and internal
  sub-steps per call;
* ``TMDIStructure.run`` for the IM secondary mass (S1 Table 1) with the ideal inerter, the
  rack-and-pinion inerter (NF, IF, LF) and without inerter, plus the uncontrolled PS, with the
  viscous S1 §4.2 HDRBs and (``amp``) with the amplitude-dependent dashpots, under
  ``--seconds`` of a 0.10 g, 2.25 Hz ground acceleration: microseconds per step and wall seconds
  per simulated second (the cost of a 500-900 s stepped sweep is that number times 500-900);
* ``TMDISubstructure.step`` (IM, sampled excitation): microseconds per call.

The first call of each model is a warm-up that loads (or compiles) the numba kernel.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from collections.abc import Callable

import numpy as np

from plants.tmdi import TMDIStructure, TMDISubstructure, s1_configuration
from plants.tmdi.inerter import RackPinionInerter, rack_pinion_preset

G = 9.81
FREQ = 2.25  # Hz, f_0 of S1 Fig.12
PGA = 0.10  # g


def median_seconds(run: Callable[[], object], repeats: int) -> float:
    """Median wall time [s] of ``run()`` over ``repeats`` calls after one warm-up call."""
    run()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def bench_specimen(rate: float, seconds: float, repeats: int) -> None:
    dt = 1.0 / rate
    t = np.arange(0.0, seconds, dt)
    w = 2.0 * math.pi * FREQ
    u = (0.01 * np.sin(w * t)).tolist()
    v = (0.01 * w * np.cos(w * t)).tolist()
    a = (-0.01 * w * w * np.sin(w * t)).tolist()
    for flywheel in ("NF", "IF", "LF"):
        spec = RackPinionInerter(rack_pinion_preset(flywheel))

        def run(spec: RackPinionInerter = spec) -> None:
            spec.reset()
            step = spec.step
            for k in range(len(u)):
                step(u[k], v[k], a[k], dt)

        per_step = median_seconds(run, repeats) / len(u) * 1e6
        print(
            f"  rack-and-pinion {flywheel}  {rate:7.0f} Hz  {spec.substeps(dt):4d} sub-steps"
            f"  {per_step:8.2f} us/step"
        )


def bench_structure(rate: float, seconds: float, repeats: int) -> None:
    dt = 1.0 / rate
    t = np.arange(0.0, seconds, dt)
    ag = PGA * G * np.sin(2.0 * math.pi * FREQ * t)
    cases = [
        ("PS (no TMDI)", *s1_configuration(None)),
        ("PS amp", *s1_configuration(None, hdrb="amplitude")),
        ("IM, no inerter", *s1_configuration("IM")),
        ("IM-IF ideal", *s1_configuration("IM", "IF", inerter="ideal")),
        ("IM-IF ideal amp", *s1_configuration("IM", "IF", inerter="ideal", hdrb="amplitude")),
        ("IM-NF rack", *s1_configuration("IM", "NF")),
        ("IM-IF rack", *s1_configuration("IM", "IF")),
        ("IM-IF rack amp", *s1_configuration("IM", "IF", hdrb="amplitude")),
        ("IM-LF rack", *s1_configuration("IM", "LF")),
    ]
    for name, par, inerter in cases:
        structure = TMDIStructure(par, inerter, dt)
        wall = median_seconds(lambda s=structure: s.run(ag), repeats)
        print(
            f"  TMDIStructure {name:15s} {rate:7.0f} Hz  {structure.substeps:4d} sub-steps"
            f"  {wall / t.size * 1e6:8.2f} us/step  {wall / seconds:8.5f} s/s"
            f"  (900 s sweep: {900.0 * wall / seconds:6.1f} s)"
        )


def bench_substructure(rate: float, seconds: float, repeats: int) -> None:
    dt = 1.0 / rate
    t = np.arange(0.0, seconds, dt)
    ag = PGA * G * np.sin(2.0 * math.pi * FREQ * t)
    par, _ = s1_configuration("IM", "IF")
    sub = TMDISubstructure(par, ag, dt)
    forces = (10.0 * np.sin(2.0 * math.pi * FREQ * t)).tolist()

    def run() -> None:
        sub.reset()
        step = sub.step
        for f in forces:
            step(f)

    per_step = median_seconds(run, repeats) / len(forces) * 1e6
    print(f"  TMDISubstructure.step IM    {rate:7.0f} Hz  {per_step:8.2f} us/step")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7, help="timed runs per case (median)")
    parser.add_argument("--seconds", type=float, default=20.0, help="simulated seconds per run")
    parser.add_argument(
        "--rates",
        type=float,
        nargs="+",
        default=[1000.0, 2000.0, 4096.0],
        help="loop / sampling rates [Hz]",
    )
    args = parser.parse_args()
    specimen_seconds = min(args.seconds, 5.0)  # Python-loop benchmarks: keep them short
    for rate in args.rates:
        print(f"--- {rate:.0f} Hz ---")
        bench_specimen(rate, specimen_seconds, args.repeats)
        bench_structure(rate, args.seconds, args.repeats)
        bench_substructure(rate, specimen_seconds, args.repeats)


if __name__ == "__main__":
    main()
