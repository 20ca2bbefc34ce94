"""Convert a real MTS actuator logger file to the diagnosis CSV contract (design.md section 7).

    python tools/mts_to_csv.py PATH/TO/0A.txt --out mts_0A.csv

Input: the text logger format of the public MTS sweep (a header whose first line gives its size
and which holds ``Sampling Interval``, then rows ``sample, date/time, CHANNEL0, CHANNEL1,
CHANNEL2[, events]`` in volts).  Channel scaling (from the source repository's preprocessing):
CHANNEL0 x 10 mm/V -> measured displacement, CHANNEL1 x 9806.65 N/V -> force, CHANNEL2 x 10 mm/V
-> command.  Output in SI (m, N, s), row ``i`` at ``time = (i + 1) dt``.

Processing, as the source's preprocessing does but without its 200 Hz low-pass (the diagnosis
estimates and handles the noise itself): the offset of each channel is removed (mean over the
first ``--rest`` seconds, where the actuator is at rest), and the record is trimmed to the
active part -- from ``--margin`` seconds before the first to ``--margin`` after the last sample
where ``|command| > --threshold``.  Nothing is copied into the project: the path is given on the
command line.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from rths.diagnose.data.records import write_csv

DISPLACEMENT_M_PER_V = 10.0e-3
FORCE_N_PER_V = 9806.65
COMMAND_M_PER_V = 10.0e-3


def read_logger(path: Path) -> tuple[float, np.ndarray]:
    """``(dt [s], volts [n, 3])`` from the logger file (CHANNEL0..2)."""
    with open(path, encoding="utf-8", errors="replace") as f:
        first = f.readline()
        size = int(first.split(":")[1])
        header = [first] + [f.readline() for _ in range(size - 1)]
        dt = next(float(h.split(":")[1]) for h in header if h.startswith("Sampling Interval"))
        rows = []
        for line in f:
            parts = line.split(",")
            if len(parts) >= 5:
                rows.append([float(parts[2]), float(parts[3]), float(parts[4])])
    return dt, np.asarray(rows)


def convert(volts: np.ndarray, dt: float, rest: float, threshold: float, margin: float):
    """SI columns (time, command, measured, force), offsets removed, trimmed to the test."""
    measured = volts[:, 0] * DISPLACEMENT_M_PER_V
    force = volts[:, 1] * FORCE_N_PER_V
    command = volts[:, 2] * COMMAND_M_PER_V
    n_rest = max(1, int(round(rest / dt)))
    for x in (measured, force, command):
        x -= np.mean(x[:n_rest])
    active = np.flatnonzero(np.abs(command) > threshold)
    if active.size == 0:
        raise SystemExit(f"no sample with |command| > {threshold} m")
    pad = int(round(margin / dt))
    lo, hi = max(active[0] - pad, 0), min(active[-1] + pad + 1, command.size)
    t = dt * np.arange(1, hi - lo + 1)
    return t, command[lo:hi], measured[lo:hi], force[lo:hi]


def main(argv: list[str] | None = None) -> int:
    """Command line (module docstring)."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n", 1)[0])
    p.add_argument("logger", type=Path, help="MTS logger text file (e.g. 0A.txt)")
    p.add_argument("--out", type=Path, required=True, help="CSV to write")
    p.add_argument("--rest", type=float, default=0.5, help="seconds at rest for offsets (0.5)")
    p.add_argument("--threshold", type=float, default=0.4e-3, help="active |command| [m]")
    p.add_argument("--margin", type=float, default=1.0, help="seconds kept around the test")
    args = p.parse_args(argv)
    dt, volts = read_logger(args.logger)
    t, u, x, f = convert(volts, dt, args.rest, args.threshold, args.margin)
    write_csv(args.out, t, u, x, f)
    print(f"{args.out}: {t.size} samples at {1 / dt:g} Hz ({t[-1]:.1f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
