"""Where a lockstep step goes: the round trip split at the specimen's stamp, and CPU per thread.

Runs the seed scenario (or ``--scenario``) on the ``lockstep`` clock with the coordinator's
lockstep link wrapped so that every exchange records four clocks: the command leaving
(``time.monotonic_ns`` before the send), the specimen's stamp on its measurement
(``Measurement.sample_ns``: the same system-wide monotonic clock, taken right after the lab's
step), the measurement arriving on the loop thread, and the loop thread's CPU time spent in the
send and in the receive.  The round trip splits into

* ``out + specimen``: command over zenoh, the specimen's wake-up, guard and lab step;
* ``back``: measurement over zenoh and the loop thread's wake-up;

and the loop thread's CPU time into the send (pack, HMAC seal, zenoh put) and the receive
(waiting costs no CPU: what is counted is the wake-up, the HMAC check and the decode).  It also
prints the CPU time per step of every coordinator thread during the loop (zenoh's ``tx``/``rx``
threads, the recorder, the log bridge, ...) and of the specimen process (whole life).  On a 2-core
machine the sum of both processes' CPU per step bounds the lockstep rate from below.

    python tools/lockstep_anatomy.py                      # 2048 Hz, 8 s
    python tools/lockstep_anatomy.py --rate 4096 --duration 10
    RTHS_ZENOH_LOWLATENCY=1 python tools/lockstep_anatomy.py   # zenoh's low-latency transport

The wrapper replaces ``rths.session.zenoh_run._LockstepLink.exchange`` for this process only (a
measuring tool, not product code); the tool says so and stops if that class is gone.
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_loop import SEED, scenario

from rths.runtime import loop as loop_module
from rths.runtime.loop import LinkSample
from rths.session import zenoh_run
from rths.session.runner import RunOptions, run_scenario
from rths.wire.codec import Command


def thread_cpu() -> dict[int, tuple[str, float]]:
    """CPU time [s] of every thread of this process, by native id, with its name."""
    names = {t.native_id: t.name for t in threading.enumerate()}
    tick = os.sysconf("SC_CLK_TCK")
    out = {}
    for tid in os.listdir("/proc/self/task"):
        try:
            stat = Path(f"/proc/self/task/{tid}/stat").read_text().rsplit(")", 1)[1].split()
            comm = Path(f"/proc/self/task/{tid}/comm").read_text().strip()
        except OSError:  # the thread ended meanwhile
            continue
        name = names.get(int(tid), f"zenoh/native {comm}")
        out[int(tid)] = (name, (int(stat[11]) + int(stat[12])) / tick)
    return out


def pct(x: np.ndarray) -> str:
    p50, p90, p99 = np.percentile(x, [50, 90, 99])
    return f"p50 {p50:6.0f}  p90 {p90:6.0f}  p99 {p99:6.0f}  mean {x.mean():6.0f}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", type=Path, default=SEED)
    ap.add_argument("--rate", type=float, default=2048.0)
    ap.add_argument("--duration", type=float, default=8.0)
    args = ap.parse_args()
    link_class = getattr(zenoh_run, "_LockstepLink", None)
    if link_class is None:
        print("rths.session.zenoh_run._LockstepLink is gone: update this tool")
        return
    records: list[tuple[int, int, int, int, int]] = []

    def exchange(self, seq: int, t_ns: int, command: float) -> LinkSample:  # type: ignore[no-untyped-def]
        cpu0, sent = time.thread_time_ns(), time.monotonic_ns()
        self.client.send(Command(seq, t_ns, command))
        cpu1 = time.thread_time_ns()
        m = self.client.receive(seq, self.timeout)
        arrived, cpu2 = time.monotonic_ns(), time.thread_time_ns()
        records.append((sent, m.sample_ns, arrived, cpu1 - cpu0, cpu2 - cpu1))
        return LinkSample(m.displacement, m.force, 0, m.seq)

    link_class.exchange = exchange
    original_run = loop_module.Loop.run
    box: dict[str, object] = {}

    def run(self, progress=None):  # type: ignore[no-untyped-def]
        before = thread_cpu()
        result = original_run(self, progress)
        after = thread_cpu()
        box["threads"] = sorted(
            ((after[t][0], after[t][1] - before.get(t, ("", 0.0))[1]) for t in after),
            key=lambda x: -x[1],
        )
        box["result"] = result
        return result

    loop_module.Loop.run = run  # type: ignore[method-assign]
    scn = scenario(args.scenario, args.rate, args.duration)
    load = os.getloadavg()[0]
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        run_scenario(scn, RunOptions(clock="lockstep", out=Path(tmp) / "anatomy.mcap"))
        wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    specimen = after.ru_utime + after.ru_stime - children.ru_utime - children.ru_stime
    result = box["result"]
    n = result.steps  # type: ignore[attr-defined]
    a = np.array(records[200:], dtype=np.int64)
    print(
        f"lockstep {args.rate:g} Hz, {n} steps ({args.scenario.name}): "
        f"{n / args.rate / wall:.2f} sim s per wall s (whole run); loop "
        f"{n / args.rate / (result.timing.busy_mean * n):.2f}; "  # type: ignore[attr-defined]
        f"load average {load:.2f} before, {os.getloadavg()[0]:.2f} after; "
        f"zenoh low-latency: {os.environ.get('RTHS_ZENOH_LOWLATENCY', '0') == '1'}"
    )
    print(f"  round trip       [µs]  {pct((a[:, 2] - a[:, 0]) / 1e3)}")
    print(f"  out + specimen   [µs]  {pct((a[:, 1] - a[:, 0]) / 1e3)}")
    print(f"  back             [µs]  {pct((a[:, 2] - a[:, 1]) / 1e3)}")
    print(
        f"  loop thread CPU  [µs/step]  send {a[:, 3].mean() / 1e3:.1f}, receive "
        f"{a[:, 4].mean() / 1e3:.1f}, whole step {1e6 * result.cpu_mean:.1f}"  # type: ignore[attr-defined]
    )
    print("  coordinator threads during the loop [µs CPU/step]:")
    for name, cpu in box["threads"][:10]:  # type: ignore[index]
        if cpu > 0:
            print(f"    {name[:60]:<60} {cpu / n * 1e6:8.1f}")
    print(
        f"  specimen process (whole life, start-up included) {specimen / n * 1e6:.1f} µs CPU/step"
    )


if __name__ == "__main__":
    main()
