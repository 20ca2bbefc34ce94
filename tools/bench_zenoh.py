"""Benchmark of the hot path: cross-process lockstep round trip over zenoh, and Recorder throughput.

Usage::

    python tools/bench_zenoh.py [--steps 3000] [--rounds 3] [--messages 200000] [--only NAME ...]

Round trip: the parent (coordinator) listens on a free loopback port and spawns this script as an
echo specimen (``--echo``) that connects; after the readiness handshake the parent sends a
24-byte command and waits for the 40-byte measurement with the same seq, ``--steps`` times after
a warm-up, and reports the median (p50) and 99th percentile (p99) of the round trip [µs],
pooled over ``--rounds`` interleaved rounds.  Mechanisms (``*`` = what rths.wire.transport uses):

* ``rths*``          LockstepClient/LockstepServer: publisher.put(bytes), reliable + express +
  BLOCK; FifoChannel ``recv()`` with the watchdog that implements the timeout
* ``fifo``           raw FifoChannel ``recv()`` on both sides, no timeout machinery (floor)
* ``queue-direct``   direct callback (``indirect=False``) → SimpleQueue.get(timeout)
* ``queue-indirect`` callback on a Python thread (``indirect=True``) → SimpleQueue.get
* ``reply-in-cb``    coordinator as rths; the echo answers inside its zenoh callback
* ``batched``        rths with ``express=False`` publishers (zenoh batching on)
* ``lowlatency``     rths on a ``transport/unicast/lowlatency`` session (QoS off)
* ``query``          request/response with Querier.get / Queryable.reply
* ``sync*``          SyncClient (the synchronous ``realtime`` clock: direct callback into a
  SimpleQueue, timed wait) against LockstepServer, sealed with a run secret (HMAC)
* ``sync-lowlatency`` the same on ``transport/unicast/lowlatency`` sessions (QoS off)
* ``sync-shm``       the same with zenoh's shared-memory transport on and the specimen's
  measurements written into SHM buffers (``zenoh.shm.ShmProvider``)
* ``sync-poll``      SyncClient on a FIFO channel polled every 20 µs (timer slack 1 µs)
* ``sync-cb*``       SyncClient against a :class:`CallbackServer` (the specimen answers inside
  its zenoh callback: what ``rths specimen`` does)
* ``sync-cb-lowlatency`` the same on ``transport/unicast/lowlatency`` sessions (no tx thread)
* ``sync-cb-spin``   SyncClient busy-polling its FIFO channel (``poll=0``) against the callback
* ``recording``      rths while a :class:`Recorder` records one rths/loop message per step
  (its writer thread competes for the GIL; CPython's default switch interval is 5 ms)
* ``recording-si``   the same after ``sys.setswitchinterval(1e-4)`` in the coordinator
* ``recording-process`` the same with the recorder's writer in its own process
  (``Recorder(writer="process")``; ``tools/bench_recorder.py`` measures its hand-over)

Recorder: ``--messages`` rths/loop records put from one thread; reports the put() cost on the
producer's thread [µs] and the end-to-end throughput [messages/s] until the file is finished,
for each compression.  Wall-clock numbers: run on a quiet machine.
"""

from __future__ import annotations

import argparse
import math
import os
import queue
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
import zenoh

from rths.log.recorder import LOOP_TOPIC, Recorder
from rths.runtime.clocks import realtime_thread
from rths.wire.auth import RunSecret
from rths.wire.codec import Command, Measurement
from rths.wire.transport import (
    CallbackServer,
    LockstepClient,
    LockstepServer,
    Presence,
    RunKeys,
    SyncClient,
    ZenohEndpoints,
    declare_hot_publisher,
    session_config,
)

MECHANISMS = (
    "rths",
    "fifo",
    "queue-direct",
    "queue-indirect",
    "reply-in-cb",
    "batched",
    "lowlatency",
    "query",
    "recording",
    "recording-si",
    "recording-process",
    "sync",
    "sync-lowlatency",
    "sync-shm",
    "sync-poll",
    "sync-cb",
    "sync-cb-lowlatency",
    "sync-cb-spin",
)
RTHS_LINKS = ("rths", "batched", "lowlatency", "recording", "recording-si", "recording-process")
SYNC_LINKS = (
    "sync",
    "sync-lowlatency",
    "sync-shm",
    "sync-poll",
    "sync-cb",
    "sync-cb-lowlatency",
    "sync-cb-spin",
)
#: A fixed secret for the benchmark's sealed links (both processes know it).
BENCH_SECRET = RunSecret(b"rths-bench-secret-not-for-runs!!")
WARMUP = 300
STOP = b"stop"


def config(endpoints: ZenohEndpoints, mechanism: str) -> zenoh.Config:
    cfg = session_config(endpoints)
    if mechanism == "sync-shm":
        cfg.insert_json5("transport/shared_memory/enabled", "true")
        cfg.insert_json5("transport/shared_memory/transport_optimization/enabled", "true")
    if mechanism in ("lowlatency", "sync-lowlatency", "sync-cb-lowlatency"):
        cfg.insert_json5("transport/unicast/lowlatency", "true")
        cfg.insert_json5("transport/unicast/qos/enabled", "false")
    return cfg


def publisher(session: zenoh.Session, key: str, mechanism: str) -> zenoh.Publisher:
    if mechanism == "batched":
        return session.declare_publisher(
            key, congestion_control=zenoh.CongestionControl.BLOCK, express=False
        )
    return declare_hot_publisher(session, key)


def echo_measurement(payload: bytes) -> bytes:
    c = Command.unpack(payload)
    return Measurement(c.seq, c.t_ns, c.command, -c.command, time.monotonic_ns()).pack()


# --------------------------------------------------------------------------- specimen side


def run_echo(mechanism: str, endpoint: str, run_id: str) -> None:
    """The echo specimen; returns when the coordinator asks it to stop or goes away."""
    ep, keys = ZenohEndpoints(connect=(endpoint,)), RunKeys(run_id)
    session = zenoh.open(config(ep, mechanism))
    try:
        if mechanism.startswith("sync-cb"):
            holder: list[CallbackServer] = []

            def respond(c: Command) -> None:
                holder[0].reply(Measurement.unpack(echo_measurement(c.pack())))

            holder.append(CallbackServer(session, keys, respond, BENCH_SECRET))
            presence = Presence(session, keys, "specimen", ep.describe())
            presence.wait_for_peer(30.0, [holder[0].publisher])
            presence.stop.wait()
            return
        if mechanism in SYNC_LINKS:
            server = LockstepServer(session, keys, BENCH_SECRET)
            if mechanism == "sync-shm":
                import zenoh.shm as shm

                provider = shm.ShmProvider.default_backend(1 << 20)
                plain = server.publisher

                class _ShmPublisher:  # the sealed frame written into an SHM buffer
                    def put(self, payload: bytes) -> None:
                        buf = provider.alloc(len(payload), shm.GarbageCollect())
                        buf[:] = payload
                        plain.put(buf)

                server.publisher = _ShmPublisher()  # type: ignore[assignment]
                pubs = [plain]
            else:
                pubs = [server.publisher]
            presence = Presence(session, keys, "specimen", ep.describe())
            presence.wait_for_peer(30.0, pubs)
            server.serve(lambda c: Measurement.unpack(echo_measurement(c.pack())), presence.stop)
            return
        if mechanism in RTHS_LINKS:
            server = LockstepServer(session, keys)
            if mechanism == "batched":
                server.publisher.undeclare()
                server.publisher = publisher(session, keys.measurement, mechanism)
            presence = Presence(session, keys, "specimen", ep.describe())
            presence.wait_for_peer(30.0, [server.publisher])
            server.serve(lambda c: Measurement.unpack(echo_measurement(c.pack())), presence.stop)
            return
        pub = publisher(session, keys.measurement, mechanism)
        done = threading.Event()
        if mechanism == "query":

            def answer(query: zenoh.Query) -> None:
                query.reply(keys.measurement, echo_measurement(query.payload.to_bytes()))

            session.declare_queryable(
                keys.measurement, zenoh.handlers.Callback(answer, indirect=False)
            )
            session.declare_subscriber(keys.stop, lambda s: done.set())
            pubs = []
        elif mechanism == "reply-in-cb":
            session.declare_subscriber(
                keys.command,
                zenoh.handlers.Callback(
                    lambda s: pub.put(echo_measurement(s.payload.to_bytes())), indirect=False
                ),
            )
            session.declare_subscriber(keys.stop, lambda s: done.set())
            pubs = [pub]
        elif mechanism.startswith("queue"):
            inbox: queue.SimpleQueue[bytes] = queue.SimpleQueue()
            session.declare_subscriber(
                keys.command,
                zenoh.handlers.Callback(
                    lambda s: inbox.put(s.payload.to_bytes()),
                    indirect=mechanism.endswith("indirect"),
                ),
            )
            pubs = [pub]
        else:  # fifo
            sub = session.declare_subscriber(keys.command, zenoh.handlers.FifoChannel(1024))
            pubs = [pub]
        presence = Presence(session, keys, "specimen", ep.describe())
        presence.wait_for_peer(30.0, pubs)
        if mechanism.startswith("queue"):
            while (payload := inbox.get()) != STOP:
                pub.put(echo_measurement(payload))
        elif mechanism == "fifo":
            while (payload := sub.recv().payload.to_bytes()) != STOP:
                pub.put(echo_measurement(payload))
        else:
            done.wait()
    finally:
        session.close()


# --------------------------------------------------------------------------- coordinator side


def process_cpu_ns(pid: int) -> int:
    """CPU time [ns] (user + system, every thread) process ``pid`` has used so far (Linux)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) * 1_000_000_000 // os.sysconf("SC_CLK_TCK")


#: CPU [µs] both processes spent per measured exchange, per mechanism (every thread, zenoh's
#: included; ``round_trips`` adds one figure per round).
PROCESS_CPU: dict[str, list[float]] = {}


def round_trips(mechanism: str, steps: int) -> tuple[list[float], list[float]]:
    """Round-trip times [µs] of ``steps`` lockstep exchanges against a child echo specimen, and
    the CPU time [µs] each exchange cost the calling thread (``time.thread_time_ns``: what the
    loop thread pays beyond the wait, independent of the machine's load).  The CPU both whole
    processes spent per exchange goes to :data:`PROCESS_CPU`."""
    ep, keys = ZenohEndpoints.loopback(), RunKeys(f"bench-{mechanism}")
    child = subprocess.Popen(
        [sys.executable, __file__, "--echo", mechanism, ep.listen[0], keys.run_id]
    )
    session = zenoh.open(config(ep, mechanism))
    try:
        if mechanism == "query":
            querier = session.declare_querier(keys.measurement, timeout=10.0)
            presence = Presence(session, keys, "coordinator", ep.describe())
            presence.wait_for_peer(30.0)
            while not querier.matching_status.matching:
                time.sleep(0.01)

            def exchange(c: Command) -> Measurement:
                reply = querier.get(payload=c.pack()).recv()
                return Measurement.unpack(reply.ok.payload.to_bytes())

            stop = lambda: session.put(keys.stop, b"{}")
        elif mechanism in ("queue-direct", "queue-indirect", "fifo"):
            pub = declare_hot_publisher(session, keys.command)
            if mechanism == "fifo":
                sub = session.declare_subscriber(keys.measurement, zenoh.handlers.FifoChannel(1024))
                recv = lambda: sub.recv().payload.to_bytes()
            else:
                inbox: queue.SimpleQueue[bytes] = queue.SimpleQueue()
                indirect = mechanism.endswith("indirect")
                session.declare_subscriber(
                    keys.measurement,
                    zenoh.handlers.Callback(
                        lambda s: inbox.put(s.payload.to_bytes()), indirect=indirect
                    ),
                )
                recv = lambda: inbox.get(timeout=10.0)
            presence = Presence(session, keys, "coordinator", ep.describe())
            presence.wait_for_peer(30.0, [pub])

            def exchange(c: Command) -> Measurement:
                pub.put(c.pack())
                return Measurement.unpack(recv())

            stop = lambda: pub.put(STOP)
        elif mechanism in SYNC_LINKS:
            poll = {"sync-poll": 20e-6, "sync-cb-spin": 0.0}.get(mechanism)
            sync = SyncClient(session, keys, BENCH_SECRET, poll=poll)
            realtime_thread()
            presence = Presence(session, keys, "coordinator", ep.describe())
            presence.wait_for_peer(30.0, [sync.publisher])

            def exchange(c: Command) -> Measurement:
                m = sync.exchange(c, time.monotonic_ns() + 10_000_000_000)
                assert m is not None
                return m

            stop = lambda: presence.request_stop("bench done")
        else:
            client = LockstepClient(session, keys, timeout=10.0)
            if mechanism == "batched":
                client.publisher.undeclare()
                client.publisher = publisher(session, keys.command, mechanism)
            presence = Presence(session, keys, "coordinator", ep.describe())
            presence.wait_for_peer(30.0, [client.publisher])
            exchange = client.exchange
            stop = lambda: presence.request_stop("bench done")
        times, cpu = [], []
        clock, cpu_clock = time.perf_counter_ns, time.thread_time_ns
        with tempfile.TemporaryDirectory() as tmp:
            writer = "process" if mechanism == "recording-process" else "thread"
            rec = (
                Recorder(Path(tmp) / "rt.mcap", writer=writer).start()
                if "recording" in mechanism
                else None
            )
            switch_interval = sys.getswitchinterval()
            if mechanism == "recording-si":
                sys.setswitchinterval(1e-4)
            for k in range(WARMUP + steps):
                if k == WARMUP:
                    own0, echo0 = time.process_time_ns(), process_cpu_ns(child.pid)
                t0, c0 = clock(), cpu_clock()
                m = exchange(Command(k, k, 1e-3))
                cpu.append((cpu_clock() - c0) / 1e3)
                times.append((clock() - t0) / 1e3)
                if m.seq != k:
                    raise RuntimeError(f"{mechanism}: got seq {m.seq} for command {k}")
                if rec is not None:
                    rec.put(
                        LOOP_TOPIC,
                        k,
                        k * 250_000,
                        {
                            "t": k * 2.5e-4,
                            "target": 1e-3,
                            "command": 1e-3,
                            "measured": m.displacement,
                            "force": m.force,
                        },
                    )
            own, echo = time.process_time_ns() - own0, process_cpu_ns(child.pid) - echo0
            PROCESS_CPU.setdefault(mechanism, []).append((own + echo) / 1e3 / steps)
            sys.setswitchinterval(switch_interval)
            if rec is not None:
                rec.close()
        stop()
        child.wait(30)
        return times[WARMUP:], cpu[WARMUP:]
    finally:
        session.close()
        if child.poll() is None:
            child.kill()
            child.wait()


# --------------------------------------------------------------------------- recorder


def recorder_throughput(messages: int, compression: str) -> tuple[float, float]:
    """(median put() cost [µs] over batches of 1000, end-to-end messages/s until closed)."""
    rows = [
        {
            "t": k * 2.5e-4,
            "target": math.sin(k * 1e-3),
            "command": math.sin(k * 1e-3 + 0.1),
            "measured": math.sin(k * 1e-3 - 0.1),
            "force": 1e3 * math.cos(k * 1e-3),
        }
        for k in range(1000)
    ]
    batch_costs = []
    with tempfile.TemporaryDirectory() as tmp:
        rec = Recorder(Path(tmp) / "bench.mcap", compression=compression).start()  # type: ignore[arg-type]
        clock = time.perf_counter_ns
        t_start = clock()
        for start in range(0, messages, 1000):
            t0 = clock()
            for k in range(start, min(start + 1000, messages)):
                rec.put(LOOP_TOPIC, k, k * 250_000, rows[k % 1000])
            batch_costs.append((clock() - t0) / 1e3 / 1000)
        summary = rec.close()
        elapsed = (clock() - t_start) / 1e9
    assert summary.complete and summary.topics[LOOP_TOPIC].written == messages
    return statistics.median(batch_costs), messages / elapsed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=3000, help="measured round trips per round")
    parser.add_argument("--rounds", type=int, default=3, help="interleaved rounds per mechanism")
    parser.add_argument("--messages", type=int, default=200_000, help="recorder messages")
    parser.add_argument("--no-recorder", action="store_true", help="skip the recorder table")
    parser.add_argument("--only", nargs="*", choices=MECHANISMS, default=list(MECHANISMS))
    parser.add_argument(
        "--echo", nargs=3, metavar=("MECH", "ENDPOINT", "RUN"), help=argparse.SUPPRESS
    )
    args = parser.parse_args()
    if args.echo:
        run_echo(*args.echo)
        return
    pooled: dict[str, list[float]] = {m: [] for m in args.only}
    pooled_cpu: dict[str, list[float]] = {m: [] for m in args.only}
    for _ in range(args.rounds):
        for mechanism in args.only:
            times, cpu = round_trips(mechanism, args.steps)
            pooled[mechanism] += times
            pooled_cpu[mechanism] += cpu
    print(
        f"cross-process lockstep round trip, {args.rounds} x {args.steps} steps, "
        "24 B out / 40 B back"
    )
    print(
        f"(load average {os.getloadavg()[0]:.2f}; CPU: the caller thread's CPU time per exchange; "
        "both CPU: both processes' whole CPU per exchange [µs], every thread, median of rounds)"
    )
    print(
        f"{'mechanism':<19}{'p50 [us]':>10}{'p90 [us]':>10}{'p99 [us]':>10}{'max [us]':>10}"
        f"{'CPU p50':>10}{'CPU mean':>10}{'both CPU':>10}"
    )
    for mechanism, times in pooled.items():
        p50, p90, p99 = np.percentile(times, [50, 90, 99])
        star = "*" if mechanism in ("rths", "sync-cb") else ""
        cpu = pooled_cpu[mechanism]
        print(
            f"{mechanism + star:<19}{p50:>10.1f}{p90:>10.1f}{p99:>10.1f}{max(times):>10.0f}"
            f"{statistics.median(cpu):>10.1f}{statistics.fmean(cpu):>10.1f}"
            f"{statistics.median(PROCESS_CPU[mechanism]):>10.1f}"
        )
    if args.no_recorder:
        return
    print(f"\nRecorder, {args.messages} rths/loop messages")
    print(f"{'compression':<12}{'put() [us]':>12}{'throughput [msg/s]':>20}")
    for compression in ("zstd", "lz4", "none"):
        put_us, rate = recorder_throughput(args.messages, compression)
        print(f"{compression:<12}{put_us:>12.2f}{rate:>20,.0f}")


if __name__ == "__main__":
    main()
