"""Deadline misses of a real-time run, and how periodic they are.

Runs a scenario with ``--clock realtime`` (its duration and ``[loop] max_lag`` replaced, so the
run does not stop on lag), then reads the ``lag`` column of topic ``rths/loop``: a step misses its
deadline when its measurement is not back in time (``lag > 0``).  Printed per run: the miss rate,
the autocorrelation of the miss indicator at the recorder's block length (256 rows: a peak there
says the misses follow the hand-over of blocks to the recorder), the miss rate over the first 16
steps of each block relative to the mean, the phase in the block (``seq % 256``) where misses are
most frequent and how much above the mean, and the machine's load.  ``--log FILE`` only analyses an
existing log.

    python tools/bench_deadlines.py scenarios/cable_imd_mode3.toml --duration 10 --repeat 2
    RTHS_RT_PRIORITY=50 python tools/bench_deadlines.py scenarios/cable_imd_mode3.toml
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from rths.log.reader import read_topic

BLOCK = 256


def analyse(path: Path, block: int = BLOCK) -> dict[str, float]:
    """Miss rate, autocorrelation at ``block`` and the early-phase miss ratio of one log."""
    loop = read_topic(path, "rths/loop")
    miss = (np.asarray(loop["lag"]) > 0).astype(float)
    seq = np.asarray(loop["sequence"])
    rate = float(miss.mean())
    centred = miss - rate
    var = float(centred @ centred)
    acf = float(centred[:-block] @ centred[block:]) / var if var > 0 else 0.0
    early = miss[(seq % block) < 16].mean() / rate if rate > 0 else 0.0
    phase = np.bincount(seq % block, weights=miss, minlength=block) / np.maximum(
        np.bincount(seq % block, minlength=block), 1
    )
    return {
        "steps": float(miss.size),
        "misses": rate,
        "acf": acf,
        "early": float(early),
        "peak_phase": float(np.argmax(phase)),
        "peak_ratio": float(phase.max() / rate) if rate > 0 else 0.0,
    }


def scenario_text(source: Path, duration: float, max_lag: int) -> str:
    """The scenario with ``duration`` and ``[loop] max_lag`` replaced (or added)."""
    text = source.read_text()
    text = re.sub(r"(?m)^duration\s*=.*$", f"duration = {duration}", text)
    text = re.sub(r"(?m)^max_lag\s*=.*\n", "", text)
    return re.sub(r"(?m)^\[loop\]\s*$", f"[loop]\nmax_lag = {max_lag}", text)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scenario", type=Path, nargs="?", help="scenario TOML (with a [loop])")
    parser.add_argument("--duration", type=float, default=10.0, help="simulated time [s]")
    parser.add_argument("--max-lag", type=int, default=200, help="[loop] max_lag [steps]")
    parser.add_argument("--repeat", type=int, default=2, help="runs")
    parser.add_argument("--log", type=Path, help="only analyse this MCAP log")
    parser.add_argument("--keep", type=Path, help="keep the logs in this folder")
    args = parser.parse_args()
    if args.log is not None:
        print(analyse(args.log))
        return
    if args.scenario is None:
        parser.error("give a scenario or --log")
    prio = os.environ.get("RTHS_RT_PRIORITY", "-")
    print(f"{args.scenario}, {args.duration} s realtime, RTHS_RT_PRIORITY={prio}")
    print(
        f"{'run':>4}{'steps':>8}{'misses':>9}{'acf@256':>9}{'early/mean':>11}"
        f"{'peak phase':>11}{'peak/mean':>10}{'load1':>7}"
    )
    with tempfile.TemporaryDirectory() as tmp:
        scn = Path(tmp) / "scenario.toml"
        scn.write_text(scenario_text(args.scenario, args.duration, args.max_lag))
        for k in range(args.repeat):
            out = (args.keep or Path(tmp)) / f"run{k}.mcap"
            cmd = [sys.executable, "-m", "rths", "run", str(scn), "--clock", "realtime"]
            run = subprocess.run([*cmd, "--out", str(out)], stdout=subprocess.DEVNULL)
            r = analyse(out)
            print(
                f"{k:>4}{r['steps']:>8.0f}{100 * r['misses']:>8.1f}%{r['acf']:>9.3f}"
                f"{r['early']:>11.1f}{r['peak_phase']:>11.0f}{r['peak_ratio']:>10.1f}"
                f"{os.getloadavg()[0]:>7.2f}"
                + (f"  (stopped early, exit {run.returncode})" if run.returncode else "")
            )


if __name__ == "__main__":
    main()
