"""What recording row blocks costs the coordinator process: writer thread vs writer process.

Usage::

    python tools/bench_recorder.py [--blocks 40] [--rate 8] [--channels 45] [--rounds 2]
    python tools/bench_recorder.py --writer-only [--blocks 80] [--channels 21] [--rounds 5]

``--writer-only`` measures the writer's own CPU per row instead (no threads, no pacing): the
writer thread's code writing ``--blocks`` blocks to memory, by the compiled path (rows packed into
records by :mod:`rths.log.writer.rowpack`, what the fast clock's writer thread runs), the batched
path (:meth:`rths.log.writer.block_writer.BlockWriter.add_messages`, what the writer process
runs) and the reference path (``mcap``'s ``add_message`` per row at ``mcap``'s zstd level 3, what
ran first; the same records), interleaved over ``--rounds``, with the parts: JSON formatting of
the rows, zstd compression of the chunks at the writer's level and at 3.  The seed scenario's two
topics have 21 channels each (~640 B per row).

The loop hands the recorder one :class:`rths.core.channels.RowBlock` of 256 rows every 256 steps
(8 blocks/s at 2048 Hz).  This benchmark does the same at ``--rate`` blocks/s with the seed's
~45 channels, for ``Recorder(writer="thread")`` (encoding, ``mcap`` and zstd in the coordinator)
and ``Recorder(writer="process")`` (a sender thread pickles the block to a pipe; the rest runs in
the writer process), interleaved over ``--rounds``.  Per block it reports

* ``put`` -- CPU of ``put_block`` on the caller's thread [µs];
* ``coord CPU`` -- CPU of the whole coordinator process (all its threads but the probe's) from
  the first block to the finished file, divided by the blocks [µs]: what competes with the loop for
  the CPU and the GIL (it includes the caller's own pacing sleeps and closing the recorder);
* ``writer CPU`` -- CPU of the writer process per block [µs] (``RUSAGE_CHILDREN``; 0 for the
  thread);
* ``probe p99/max`` -- lateness [µs] of a thread in the coordinator that sleeps 0.5 ms at a time
  (as the loop does between steps): a writer that holds the GIL delays its wake-ups;
* ``late`` -- share of the probe's wake-ups more than 250 µs late [%] (half a 2048 Hz step);
* ``start`` -- wall time [ms] until the writer process has opened the file.

``--fifo 50`` runs the benchmark as ``RTHS_RT_PRIORITY=50`` runs the coordinator: in
``SCHED_FIFO``, which the writer thread inherits and the writer process resets; the probe is then
delayed by the writer (the GIL, the CPU) and hardly by other people's jobs.

CPU times do not depend much on the machine's load; the probe's lateness does (load is printed).
"""

from __future__ import annotations

import argparse
import io
import os
import queue
import resource
import statistics
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
import zstandard
from mcap.writer import CompressionType, Writer

from rths.core.channels import Channel, RowBlock
from rths.log.recorder import Recorder
from rths.log.writer.mcap_writer import ZSTD_LEVEL, WriterThread
from rths.log.writer.rowjson import block_json

ROWS = 256
PROBE_SLEEP = 0.5e-3  # s
LATE = 250.0  # µs: a probe wake-up this late would cost a 2048 Hz step half its period


def _blocks(n: int, channels: int) -> list[RowBlock]:
    chans = [Channel(f"ch{i}", "m") for i in range(channels)]
    rng = np.random.default_rng(1)
    out = []
    for b in range(n):
        block = RowBlock(chans, ROWS)
        block.values[:] = rng.standard_normal((ROWS, channels)) * 1e-3
        block.seq[:] = np.arange(b * ROWS, (b + 1) * ROWS)
        block.t_ns[:] = (block.seq + 1) * 488_281
        block.count = ROWS
        out.append(block)
    return out


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def handover(writer: str, blocks: list[RowBlock], rate: float) -> dict[str, float]:
    """One round: the figures of the module docstring for ``writer``."""
    late: list[float] = []
    probe_cpu: list[float] = []
    done = threading.Event()

    def probe() -> None:
        c0 = time.thread_time()
        while not done.is_set():
            t0 = time.perf_counter()
            time.sleep(PROBE_SLEEP)
            late.append((time.perf_counter() - t0 - PROBE_SLEEP) * 1e6)
        probe_cpu.append(time.thread_time() - c0)

    with tempfile.TemporaryDirectory() as tmp:
        rec = Recorder(Path(tmp) / "bench.mcap", topics={}, writer=writer)  # type: ignore[arg-type]
        rec.start()
        start = rec.writer_started_in or 0.0
        prober = threading.Thread(target=probe, daemon=True)
        prober.start()
        puts = []
        cpu0, child0 = time.process_time(), _children_cpu()
        t_next = time.perf_counter()
        for block in blocks:
            t_next += 1.0 / rate
            time.sleep(max(0.0, t_next - time.perf_counter()))
            c0 = time.thread_time()
            rec.put_block("rths/loop", block)
            puts.append(time.thread_time() - c0)
        summary = rec.close()
        done.set()
        prober.join()
        coord = time.process_time() - cpu0 - probe_cpu[0]  # the probe's own CPU is not the writer's
        child = _children_cpu() - child0
    assert summary.complete and summary.topics["rths/loop"].written == ROWS * len(blocks)
    n = len(blocks)
    return {
        "put": statistics.median(puts) * 1e6,
        "coord": coord / n * 1e6,
        "child": child / n * 1e6,
        "p99": float(np.percentile(late, 99)),
        "over": 100.0 * float(np.mean(np.asarray(late) > LATE)),
        "max": max(late),
        "start": start * 1e3,
    }


def writer_cost(blocks: list[RowBlock], path: str) -> tuple[float, int]:
    """CPU [s] of the writer thread's code writing ``blocks`` to memory by ``path``
    (``compiled``, ``batched`` or ``reference``), and the file's size."""
    out = io.BytesIO()
    thread = WriterThread(
        out,  # type: ignore[arg-type]
        queue.SimpleQueue(),
        {},
        "zstd",
        1 << 20,
        1.0,
        compiled=path == "compiled",
    )
    if path == "reference":  # mcap's add_message per row
        thread._writer = Writer(out, chunk_size=1 << 20, compression=CompressionType.ZSTD)
        thread._block = thread._block_rows  # type: ignore[method-assign]
    thread._writer.start()
    thread._register("rths/loop", b"{}")
    c0 = time.thread_time()
    for block in blocks:
        thread._block("rths/loop", block)
    thread._writer.finish()
    return time.thread_time() - c0, out.tell()


def writer_only(blocks: list[RowBlock], rounds: int) -> None:
    """Print the writer's CPU per row by each path, and its parts (``--writer-only``)."""
    rows = sum(b.count for b in blocks)
    paths, size = ("compiled", "batched", "reference"), 0
    runs: dict[str, list[float]] = {name: [] for name in (*paths, "json", "zstd", "zstd 3")}
    writer_cost(blocks[:1], "compiled")  # the kernel loaded (or compiled) once
    for _ in range(rounds):
        for name in paths:
            cpu, written = writer_cost(blocks, name)
            runs[name].append(cpu / rows * 1e6)
            size = written if name == "compiled" else size
        c0 = time.thread_time()
        data = b"".join(m for b in blocks for m in block_json(b, {})[0])
        runs["json"].append((time.thread_time() - c0) / rows * 1e6)
        for name, level in (("zstd", ZSTD_LEVEL), ("zstd 3", 3)):
            compressor = zstandard.ZstdCompressor(level=level)
            c0 = time.thread_time()
            for i in range(0, len(data), 1 << 20):
                compressor.compress(data[i : i + (1 << 20)])
            runs[name].append((time.thread_time() - c0) / rows * 1e6)
    print(
        f"writer CPU per row [us], {len(blocks)} blocks of {ROWS} x {blocks[0].values.shape[1]}, "
        f"{size / rows:.0f} B per row in the file, {rounds} rounds, median (worst) "
        f"(load average {os.getloadavg()[0]:.2f})"
    )
    for name, values in runs.items():
        print(f"{name:<10}{statistics.median(values):>8.2f} ({max(values):.2f})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--blocks", type=int, default=40, help="blocks per round")
    parser.add_argument("--rate", type=float, default=8.0, help="blocks per second")
    parser.add_argument("--channels", type=int, default=45, help="channels per row")
    parser.add_argument("--rounds", type=int, default=2, help="interleaved rounds")
    parser.add_argument(
        "--fifo", type=int, default=0, help="run this process in SCHED_FIFO at this priority"
    )
    parser.add_argument(
        "--writer-only", action="store_true", help="the writer's CPU per row (module docstring)"
    )
    args = parser.parse_args()
    if args.writer_only:
        writer_only(_blocks(args.blocks, args.channels), args.rounds)
        return
    if args.fifo:  # as RTHS_RT_PRIORITY does: threads inherit it, the writer process resets it
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(args.fifo))
    blocks = _blocks(args.blocks, args.channels)
    results: dict[str, list[dict[str, float]]] = {"thread": [], "process": []}
    for _ in range(args.rounds):
        for writer, runs in results.items():
            runs.append(handover(writer, blocks, args.rate))
    print(
        f"{args.blocks} blocks of {ROWS} x {args.channels} at {args.rate} blocks/s, "
        f"{args.rounds} rounds (load average {os.getloadavg()[0]:.2f}, "
        f"{'SCHED_FIFO ' + str(args.fifo) if args.fifo else 'default priority'}); "
        "medians over rounds"
    )
    print(
        f"{'writer':<9}{'put [us]':>10}{'coord CPU [us]':>16}{'writer CPU [us]':>17}"
        f"{'probe p99 [us]':>16}{'probe max [us]':>16}{'late [%]':>10}{'start [ms]':>12}"
    )
    for writer, runs in results.items():
        med = {k: statistics.median(r[k] for r in runs) for k in runs[0]}
        print(
            f"{writer:<9}{med['put']:>10.1f}{med['coord']:>16.0f}{med['child']:>17.0f}"
            f"{med['p99']:>16.0f}{med['max']:>16.0f}{med['over']:>10.2f}{med['start']:>12.0f}"
        )


if __name__ == "__main__":
    main()
