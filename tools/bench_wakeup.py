"""What a wake-up costs on this machine, with and without the PM QoS CPU latency request.

    python tools/bench_wakeup.py [--steps 3000]

Two round trips between two processes, each measured with the request off and then held
(:class:`rths.runtime.cpu_latency.CpuLatency`, what a ``realtime`` run holds):

* ``pipe``   -- 24 bytes out and 40 back over two OS pipes (two wake-ups: the floor);
* ``zenoh``  -- a zenoh peer-to-peer put / subscriber-callback echo between two Python processes
  on loopback, express publishers (zenoh's own threads add wake-ups of their own).

Prints p50 / p90 / p99 [µs] and whether the request was held (it needs write access to
``/dev/cpu_dma_latency``).  Wall-clock figures: run on a quiet machine and say its load.
"""

from __future__ import annotations

import argparse
import json
import os
import queue
import subprocess
import sys
import time
from typing import Any

import numpy as np

from rths.runtime.cpu_latency import CpuLatency
from rths.wire.transport import free_loopback_port


def pipe_round_trips(steps: int) -> list[float]:
    """Round trips [µs] over two pipes to a forked echo process."""
    r1, w1 = os.pipe()
    r2, w2 = os.pipe()
    pid = os.fork()
    if pid == 0:  # the echo: no Python threads exist yet in this script's parent at this point
        for _ in range(steps + 100):
            os.read(r1, 24)
            os.write(w2, b"m" * 40)
        os._exit(0)
    times = []
    for k in range(steps + 100):
        t0 = time.perf_counter_ns()
        os.write(w1, b"c" * 24)
        os.read(r2, 40)
        if k >= 100:
            times.append((time.perf_counter_ns() - t0) / 1e3)
    os.waitpid(pid, 0)
    for fd in (r1, w1, r2, w2):
        os.close(fd)
    return times


def _config(port: int, listen: bool) -> Any:  # a zenoh.Config
    import zenoh

    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("scouting/gossip/enabled", "false")
    key = "listen/endpoints" if listen else "connect/endpoints"
    config.insert_json5(key, json.dumps([f"tcp/127.0.0.1:{port}"]))
    return config


def zenoh_echo(port: int, steps: int) -> None:
    """The echo process: answer every ``ping`` with a ``pong`` from the subscriber callback."""
    import zenoh

    with zenoh.open(_config(port, listen=False)) as session:
        pub = session.declare_publisher("bench/pong", express=True)
        done = queue.SimpleQueue[None]()
        count = [0]

        def on_ping(sample: zenoh.Sample) -> None:
            pub.put(sample.payload.to_bytes()[:40].ljust(40, b"m"))
            count[0] += 1
            if count[0] == steps:
                done.put(None)

        session.declare_subscriber("bench/ping", on_ping)
        done.get(timeout=120)


def zenoh_round_trips(steps: int) -> list[float]:
    """Round trips [µs] to a zenoh echo process (the first 200 are warm-up, not kept)."""
    import zenoh

    port = free_loopback_port()
    total = steps + 200
    with zenoh.open(_config(port, listen=True)) as session:
        answers: queue.SimpleQueue[bytes] = queue.SimpleQueue()
        session.declare_subscriber("bench/pong", lambda s: answers.put(s.payload.to_bytes()))
        pub = session.declare_publisher("bench/ping", express=True)
        echo = subprocess.Popen(
            [sys.executable, __file__, "--echo", str(port), str(total)], stdin=subprocess.DEVNULL
        )
        try:
            while not pub.matching_status.matching:  # the echo's subscriber is declared
                time.sleep(0.01)
            times = []
            for k in range(total):
                t0 = time.perf_counter_ns()
                pub.put(b"c" * 24)
                answers.get(timeout=10)
                if k >= 200:
                    times.append((time.perf_counter_ns() - t0) / 1e3)
        finally:
            echo.wait(timeout=30)
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=3000, help="round trips per measurement")
    parser.add_argument("--echo", nargs=2, type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.echo:
        zenoh_echo(*args.echo)
        return
    print(f"load average {os.getloadavg()[0]:.2f}; round trips [µs], {args.steps} each")
    print(f"{'path':<8}{'CPU latency request':<34}{'p50':>8}{'p90':>8}{'p99':>8}")
    for name, measure in (("pipe", pipe_round_trips), ("zenoh", zenoh_round_trips)):
        for held in (False, True):
            latency = CpuLatency(0)
            if held:
                with latency:
                    times = measure(args.steps)
            else:
                times = measure(args.steps)
            label = latency.describe() if held else "off"
            p50, p90, p99 = np.percentile(times, [50, 90, 99])
            print(f"{name:<8}{label:<34}{p50:>8.1f}{p90:>8.1f}{p99:>8.1f}")


if __name__ == "__main__":
    main()
