"""Benchmark of ``plants.cable.model.Cable.step`` (and the mass-matrix convergence study).

Usage::

    python tools/bench_cable.py                 # µs per step for N = 100, 400 and 1000 elements
    python tools/bench_cable.py --elements 50 100 200 400 800 --steps 5000 --repeats 9
    python tools/bench_cable.py --mass-study    # damped-eigenvalue error per element mass matrix

The cable is the seed RTHS configuration (200 m, 5e6 N, 80 kg/m, damper at x_d = 0.02, mode-3
distributed load, 0.1 % Rayleigh damping, 4096 Hz); each repetition times ``steps`` calls of
``step(F)`` with a varying force using ``time.perf_counter`` and the median over repetitions is
reported, for the compiled kernel and for the NumPy/SciPy reference path, without a nominal
device ("bare") and with the S0 Type II IMD with its series stiffness ("series": 8480 kg behind
6.4e7 N/m, c = 47 kN s/m, the flywheel condensed into the tridiagonal solve).
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

from plants.cable.model import (
    Cable,
    CableProperties,
    DistributedLoad,
    InterfaceDevice,
    PointDamper,
    fe_matrices,
    physical_damper,
)

PROPS = CableProperties(length=200.0, tension=5.0e6, mass_per_length=80.0)
TYPE_II = InterfaceDevice(
    series_stiffness=6.4e7, series_inertance=8480.0, series_damping=0.75 * math.pi * 2e4
)  # m_e = 0.53, c_d x_d = 0.015 (S0 §5.3) behind the Type II stiffness at prototype scale


def time_per_step(
    elements: int, use_numba: bool, steps: int, repeats: int, device: InterfaceDevice | None
) -> float:
    """Median wall time of one ``Cable.step`` [µs]."""
    cable = Cable(
        PROPS,
        0.02,
        1.0 / 4096,
        elements=elements,
        load=DistributedLoad(100.0, mode=3),
        damper=device,
        use_numba=use_numba,
    )
    forces = [1e3 * math.sin(0.01 * k) for k in range(steps)]
    cable.step(0.0)  # compile / warm up
    samples = []
    for _ in range(repeats):
        cable.reset()
        start = time.perf_counter()
        for f in forces:
            cable.step(f)
        samples.append((time.perf_counter() - start) / steps * 1e6)
    return statistics.median(samples)


def mass_study() -> None:
    """Relative damping-ratio error of the FE model vs the exact frequency equation."""
    from plants.cable.frequency_equation import _state_space_eigenvalues, exact_roots

    unit = CableProperties(1.0, 1.0, 1.0)
    cases = {
        "viscous n=1 kappa=1": (1, 0.0, 1.0 / (math.pi**2 * 0.02)),
        "IMD seed n=3": (3, 0.53, 0.75),
    }
    for name, (n, m_e, c_d) in cases.items():
        exact = exact_roots(n, 0.02, m_e, c_d)
        print(f"{name}: exact zeta = {[round(r.zeta, 6) for r in exact]}")
        for kind in ("consistent", "lumped", "average"):
            row = []
            for elements in (50, 100, 200, 400):
                damper = PointDamper(*physical_damper(unit, m_e, c_d))
                fe = fe_matrices(unit, 0.02, elements, damper=damper, mass_matrix=kind)
                k, m, c = fe.stiffness, fe.mass, fe.damping
                s = _state_space_eigenvalues(k, m, c, 1j * n * math.pi, 2.0)
                betas = sorted((-1j * s[s.imag > 0]).tolist(), key=lambda b: b.real)
                errors = [(b.imag / abs(b)) / r.zeta - 1.0 for b, r in zip(betas, exact)]
                row.append("/".join(f"{e:+.1e}" for e in errors))
            print(f"  {kind:<11} N=50,100,200,400: " + "  ".join(row))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n", 1)[0])
    parser.add_argument("--elements", type=int, nargs="+", default=[100, 400, 1000])
    parser.add_argument("--steps", type=int, default=4096)
    parser.add_argument("--repeats", type=int, default=15)
    parser.add_argument("--mass-study", action="store_true")
    args = parser.parse_args()
    if args.mass_study:
        mass_study()
        return
    print(f"Cable.step, median of {args.repeats} x {args.steps} steps [µs/step]")
    print(f"{'elements':>8} {'numba':>10} {'+series':>10} {'reference':>10} {'+series':>10}")
    for n in args.elements:
        row = []
        for use_numba, repeats in ((True, args.repeats), (False, max(3, args.repeats // 3))):
            for device in (None, TYPE_II):
                row.append(time_per_step(n, use_numba, args.steps, repeats, device))
        print(f"{n:>8} " + " ".join(f"{t:>10.2f}" for t in row))


if __name__ == "__main__":
    main()
