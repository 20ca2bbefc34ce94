"""The machine's own real-time floor: how late does a compiled loop wake up at a fixed rate?

    python tools/wakeup_floor.py [--rate 2048] [--seconds 60] [--priority 50] [--json OUT]

Before blaming Python for a deadline miss, measure what the operating system gives a program
that does nothing else: a 40-line C loop (compiled here with the system's ``cc``; the tool says
``skipped`` and exits 0 when there is none) sleeps with ``clock_nanosleep`` to absolute
deadlines ``k / rate`` on ``CLOCK_MONOTONIC``, timer slack 1 µs, the PM QoS CPU latency request
held at 0 when ``/dev/cpu_dma_latency`` is writable, memory locked when allowed, and -- with
``--priority`` -- in ``SCHED_FIFO`` (needs root or ``ulimit -r``).  It prints how many wake-ups
were later than 0.25 / 1 / 2.4 / 5 / 10 ms, the p50 / p99 / p99.9 / longest lateness [µs], and
the longest run of consecutive steps a late wake-up swallowed at ``--rate``, and the share of
deadlines a program with no work at all would miss (a wake-up ``m`` whole steps late misses
``m``): a floor under any real-time figure of the machine.

That longest lateness is a lower bound for the watchdogs of ``realtime`` runs on the machine
(``[loop] max_lag`` steps and ``[loop] command_timeout`` s): a watchdog shorter than what the
scheduler alone costs stops runs for the machine, not for the test.  Measured on the project's
2-core VM (2026-11-24, quiet): at 2048 Hz for 60 s under ``SCHED_FIFO`` 50, 11 wake-ups more
than 2.4 ms late, the longest 7.2 ms -- why the watchdogs' defaults are 10 and 20 ms.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

C_SOURCE = r"""
#define _GNU_SOURCE
#include <fcntl.h>
#include <sched.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <time.h>
#include <unistd.h>

static int64_t ns(const struct timespec *t) {
    return (int64_t)t->tv_sec * 1000000000LL + t->tv_nsec;
}

int main(int argc, char **argv) {
    double rate = atof(argv[1]);
    long steps = atol(argv[2]);
    int prio = atoi(argv[3]);
    int qos = open("/dev/cpu_dma_latency", O_WRONLY);
    if (qos >= 0) { int32_t zero = 0; if (write(qos, &zero, 4) != 4) { close(qos); qos = -1; } }
    prctl(PR_SET_TIMERSLACK, 1000UL, 0, 0, 0);
    int locked = mlockall(MCL_CURRENT | MCL_FUTURE) == 0;
    int fifo = 0;
    if (prio > 0) { struct sched_param p = {.sched_priority = prio};
                    fifo = sched_setscheduler(0, SCHED_FIFO, &p) == 0; }
    fprintf(stderr, "qos=%d mlock=%d fifo=%d\n", qos >= 0, locked, fifo);
    int64_t period = (int64_t)(1e9 / rate + 0.5);
    struct timespec now, next;
    clock_gettime(CLOCK_MONOTONIC, &now);
    int64_t t0 = ns(&now) + 10000000LL;
    for (long k = 0; k < steps; k++) {
        int64_t due = t0 + k * period;
        next.tv_sec = due / 1000000000LL; next.tv_nsec = due % 1000000000LL;
        while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, NULL)) {}
        clock_gettime(CLOCK_MONOTONIC, &now);
        printf("%lld\n", (long long)(ns(&now) - due));
    }
    return 0;
}
"""

#: Lateness thresholds reported [ms].
THRESHOLDS_MS = (0.25, 1.0, 2.4, 5.0, 10.0)


def compile_probe(folder: Path) -> Path | None:
    """The probe compiled into ``folder``; None when the system has no C compiler."""
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        return None
    source, exe = folder / "wakeup.c", folder / "wakeup"
    source.write_text(C_SOURCE)
    subprocess.run([cc, "-O2", "-o", str(exe), str(source)], check=True, capture_output=True)
    return exe


def summarise(late_ns: np.ndarray, rate: float) -> dict[str, object]:
    """Counts above each threshold, quantiles [µs] and the most steps one wake-up swallowed."""
    late_us = late_ns * 1e-3
    return {
        "wakeups": int(late_ns.size),
        "late_over_ms": {f"{t:g}": int(np.sum(late_us > t * 1e3)) for t in THRESHOLDS_MS},
        "p50_us": float(np.percentile(late_us, 50)),
        "p99_us": float(np.percentile(late_us, 99)),
        "p999_us": float(np.percentile(late_us, 99.9)),
        "max_us": float(late_us.max()),
        "max_steps": int(np.floor(late_ns.max() * 1e-9 * rate)),
        # a wake-up late by m whole steps makes even a program with no work miss m deadlines
        "missed_pct": float(100.0 * np.sum(np.floor(late_ns * 1e-9 * rate)) / late_ns.size),
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rate", type=float, default=2048.0, help="wake-ups per second [Hz]")
    ap.add_argument("--seconds", type=float, default=60.0, help="how long [s]")
    ap.add_argument("--priority", type=int, default=0, help="SCHED_FIFO priority (0: none)")
    ap.add_argument("--json", type=Path, help="write the figures here too")
    args = ap.parse_args()
    if not (0 < args.rate <= 100_000 and 0 < args.seconds <= 3600):
        print(f"error: --rate {args.rate:g} Hz / --seconds {args.seconds:g} out of range",
              file=sys.stderr)  # fmt: skip
        return 2
    with tempfile.TemporaryDirectory() as tmp:
        exe = compile_probe(Path(tmp))
        if exe is None:
            print("skipped: no C compiler (cc) on this machine")
            return 0
        steps = int(args.rate * args.seconds)
        done = subprocess.run(
            [str(exe), repr(args.rate), str(steps), str(args.priority)],
            capture_output=True, text=True, check=True,
        )  # fmt: skip
    late = np.array(done.stdout.split(), dtype=np.int64)
    figures = {"rate_hz": args.rate, "seconds": args.seconds, "settings": done.stderr.strip()}
    figures |= summarise(late, args.rate)
    over = figures["late_over_ms"]
    print(
        f"{args.rate:g} Hz, {args.seconds:g} s ({figures['settings']}): wake-ups late by more "
        f"than "
        + ", ".join(f"{t} ms: {n}" for t, n in over.items())
        + f"; p50 / p99 / p99.9 / max {figures['p50_us']:.0f} / {figures['p99_us']:.0f} / "
        f"{figures['p999_us']:.0f} / {figures['max_us']:.0f} µs (at most "
        f"{figures['max_steps']} steps swallowed; deadlines a program with no work would miss: "
        f"{figures['missed_pct']:.3f} %)"
    )
    if args.json:
        args.json.write_text(json.dumps(figures, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
