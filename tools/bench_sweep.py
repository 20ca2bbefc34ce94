"""Wall time of the S1 shake-table emulation (``rths sweep``) and where it goes.

Usage::

    python tools/bench_sweep.py [--scenario scenarios/tmdi_shake_table.toml] [--pga 0.1]
                                [--repeats 5]

Prints, as the median over ``--repeats`` runs (``time.perf_counter``, after one warm-up that
loads the numba kernels):

* one full sweep at one PGA -- every model of the scenario, up and down, as ``run_sweep`` does
  it -- in seconds, with the simulated seconds and microseconds per simulated sample and model;
* its parts for the up sweep: table motion (python-control ZOH model through ``lfilter``), each
  model's ``TMDIStructure.run``, and the FRF/last-cycle reduction of all nine S1 Eq.7
  quantities (``rths.experiments.s1_shake_table.frf``).
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable
from pathlib import Path

from plants.tmdi import TMDIStructure
from rths.experiments.s1_shake_table.frf import estimate_frf, steady_state_windows
from rths.experiments.s1_shake_table.sweep import (
    SteppedSine,
    build_table,
    command_amplitudes,
    load_sweep,
    model_configuration,
    run_sweep,
    step_frequencies,
)

DEFAULT_SCENARIO = Path(__file__).resolve().parents[1] / "scenarios" / "tmdi_shake_table.toml"


def median_seconds(run: Callable[[], object], repeats: int) -> float:
    """Median wall time [s] of ``run()`` over ``repeats`` calls after one warm-up call."""
    run()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n", 1)[0])
    parser.add_argument("--scenario", default=str(DEFAULT_SCENARIO))
    parser.add_argument("--pga", type=float, default=0.1, help="PGA [g]")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    cfg = load_sweep(args.scenario)
    grid = step_frequencies(cfg)
    sine = SteppedSine.sweep(grid, "up", cfg.cycles)
    samples = round(sine.duration / cfg.dt)
    runs = len(cfg.models) * len(cfg.directions)

    full = median_seconds(lambda: run_sweep(cfg, pga=[args.pga]), args.repeats)
    print(
        f"scenario {cfg.name}: {grid.size} steps, {sine.duration:.0f} s per direction at "
        f"{cfg.rate:g} Hz, table {cfg.table.kind}"
    )
    print(
        f"one full sweep at {args.pga:g} g ({len(cfg.models)} models x "
        f"{len(cfg.directions)} directions = {runs * sine.duration:.0f} s simulated): "
        f"{full:.2f} s  ({1e6 * full / (runs * samples):.2f} us per sample and model)"
    )

    table = build_table(cfg.table, cfg.dt)
    amplitudes = command_amplitudes(
        table, sine.frequencies, args.pga, cfg.dt, cfg.table.amplitude_correction
    )
    t_table = median_seconds(lambda: table.run(sine, amplitudes, cfg.dt), args.repeats)
    print(f"  table motion (up):            {t_table:7.3f} s")
    motion = table.run(sine, amplitudes, cfg.dt)
    for model in cfg.models:
        structure, inerter = model_configuration(model, cfg.mass, cfg.flywheel, cfg.hdrb)
        integrate = TMDIStructure(structure, inerter, cfg.dt)
        t_run = median_seconds(lambda: integrate.run(motion.acceleration), args.repeats)
        response = integrate.run(motion.acceleration)
        signals = {n: getattr(response, n) for n in response.quantities()}

        def reduce(signals: dict = signals) -> None:
            estimate_frf(
                signals,
                motion.acceleration,
                sine.frequencies,
                sine.boundaries,
                cfg.dt,
                cfg.steady_cycles,
                cfg.amplitude,
            )
            windows = steady_state_windows(
                sine.boundaries, sine.frequencies, cfg.dt, motion.acceleration.size, 1.0
            )
            [{n: x[w].copy() for n, x in signals.items()} for w in windows]

        t_frf = median_seconds(reduce, args.repeats)
        print(
            f"  {model:<13} TMDIStructure.run {t_run:7.3f} s "
            f"({1e6 * t_run / samples:.2f} us/sample), FRF + loops {t_frf:6.3f} s"
        )


if __name__ == "__main__":
    main()
