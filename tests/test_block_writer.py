"""The batched message path writes the file ``mcap``'s per-message path writes, byte for byte.

Oracle: :class:`mcap.writer.Writer` itself, one ``add_message`` per message (the reference path,
code we did not write), and ``mcap``'s reader. Chunk sizes are small so that blocks cross chunk
boundaries, several at a time; blocks of 0 and 1 rows, several channels, records written between
blocks (schemas, channels, metadata) and NaN/infinity rows are in the mix.
"""

from __future__ import annotations

import io
import json
import queue
import struct
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

from rths.core.channels import Channel, RowBlock
from rths.log.writer import mcap_writer
from rths.log.writer.block_writer import BlockWriter
from rths.log.writer.mcap_writer import STOP, WriterThread
from rths.log.writer.rowjson import block_json, block_messages


def _batches(seed: int) -> list[tuple[int, list[int], list[int], list[int], list[bytes]]]:
    """Blocks on channels 1..3: sizes 0, 1 and up to 300 messages of 0..400 bytes each."""
    rng = np.random.default_rng(seed)
    out, seq, t = [], [0, 0, 0, 0], 10
    for size in [0, 1, 37, 300, 1, 0, 123, 2, 250]:
        ch = int(rng.integers(1, 4))
        lengths = rng.integers(0, 400, size)
        data = [bytes(rng.integers(0, 256, n, dtype=np.uint8)) for n in lengths]
        seqs = list(range(seq[ch], seq[ch] + size))
        logs = (t + np.cumsum(rng.integers(-5, 1000, size))).tolist()  # not always increasing
        pubs = [x + 7 for x in logs]
        out.append((ch, seqs, logs, pubs, data))
        seq[ch] += size
        t += 500_000
    return out


def _records(ch: int, seqs: list[int], logs: list[int], pubs: list[int], data: list[bytes]):
    """The messages as serialised Message records (as ``rowpack`` hands them over) and ends."""
    heads = [
        struct.pack("<BQHIQQ", 5, 22 + len(d), ch, k, t, p)
        for k, t, p, d in zip(seqs, logs, pubs, data)
    ]
    records = [h + d for h, d in zip(heads, data)]
    return b"".join(records), np.cumsum([len(r) for r in records], dtype=np.int64)


def _write(
    batched: bool,
    chunk_size: int,
    compression: CompressionType,
    seed: int,
    records: bool = False,
    zstd_level: int | None = None,
) -> bytes:
    out = io.BytesIO()
    if batched:
        writer: Writer = BlockWriter(
            out, chunk_size=chunk_size, compression=compression, zstd_level=zstd_level
        )
        expected = zstd_level if compression == CompressionType.ZSTD else None
        assert writer.zstd_level == expected
    else:
        writer = Writer(out, chunk_size=chunk_size, compression=compression)
    writer.start(profile="", library="test")
    schema = writer.register_schema("s", "jsonschema", b"{}")
    for topic in ("a", "b", "c"):
        writer.register_channel(topic, "json", schema)
    for i, (ch, seqs, logs, pubs, data) in enumerate(_batches(seed)):
        if batched:
            assert isinstance(writer, BlockWriter) and writer.batched
            if records:
                packed, ends = _records(ch, seqs, logs, pubs, data)
                writer.add_records(ch, np.array(logs, dtype=np.int64), memoryview(packed), ends)
            else:
                writer.add_messages(ch, seqs, logs, pubs, data)
        else:
            for k, t, p, d in zip(seqs, logs, pubs, data):
                writer.add_message(ch, t, d, p, k)
        if i == 4:  # records between blocks: a metadata record, a schema and a channel
            writer.add_metadata("between", {"k": "v"})
            writer.register_channel("d", "json", writer.register_schema("s2", "", b""))
            writer.add_message(4, 5, b"lone", 5, 0)
        if i == 6:
            writer.flush()  # a chunk finished early, as the writer thread's periodic flush does
    writer.finish()
    return out.getvalue()


@pytest.mark.parametrize(
    ("chunk_size", "compression"),
    [
        (1, CompressionType.NONE),  # one message per chunk
        (700, CompressionType.ZSTD),  # a few messages per chunk
        (4096, CompressionType.LZ4),
        (10_000, CompressionType.ZSTD),  # blocks span several chunks and share them
        (1 << 20, CompressionType.ZSTD),  # everything in one chunk
    ],
)
def test_block_writer_writes_the_bytes_of_add_message(chunk_size, compression):
    for seed in (1, 2):
        reference = _write(False, chunk_size, compression, seed)
        assert _write(True, chunk_size, compression, seed) == reference
        assert _write(True, chunk_size, compression, seed, records=True) == reference
        # the chunk-finishing code that takes a zstd level is mcap's, level 3 being mcap's own
        assert _write(True, chunk_size, compression, seed, True, zstd_level=3) == reference


def test_block_writer_zstd_level_changes_only_the_compressed_bytes():
    """Level 1: other chunk bytes, the same records, indexes and summary (mcap's reader)."""

    def read(data: bytes):
        reader = make_reader(io.BytesIO(data))
        messages = [
            (c.id, m.sequence, m.log_time, m.publish_time, m.data)
            for _, c, m in reader.iter_messages(log_time_order=False)
        ]
        summary = reader.get_summary()
        chunks = [
            (i.chunk_start_offset > 0, i.message_start_time, i.message_end_time, i.compression)
            for i in summary.chunk_indexes
        ]
        return (
            messages,
            summary.statistics,
            chunks,
            [i.uncompressed_size for i in summary.chunk_indexes],
        )

    reference = _write(False, 10_000, CompressionType.ZSTD, 1)
    level1 = _write(True, 10_000, CompressionType.ZSTD, 1, records=True, zstd_level=1)
    assert level1 != reference
    assert read(level1) == read(reference)


def test_block_writer_file_reads_back_with_mcap():
    data = _write(True, 2000, CompressionType.ZSTD, 3)
    batches = _batches(3)
    reader = make_reader(io.BytesIO(data))
    got = [
        (c.id, m.sequence, m.log_time, m.publish_time, m.data)
        for _, c, m in reader.iter_messages(log_time_order=False)
    ]
    want = [
        (ch, k, t, p, d)
        for ch, seqs, logs, pubs, ds in batches
        for k, t, p, d in zip(seqs, logs, pubs, ds)
    ]
    want.insert(sum(len(b[4]) for b in batches[:5]), (4, 0, 5, 5, b"lone"))
    assert got == want
    stats = reader.get_summary().statistics
    assert stats.message_count == len(want)
    for ch in (1, 2, 3, 4):
        assert stats.channel_message_counts.get(ch, 0) == sum(1 for w in want if w[0] == ch)
    times = [w[2] for w in want]
    assert (stats.message_start_time, stats.message_end_time) == (min(times), max(times))
    assert stats.chunk_count > 5


def test_block_writer_rejects_what_add_message_would():
    writer = BlockWriter(io.BytesIO())
    writer.start()
    writer.register_channel("a", "json", 0)
    with pytest.raises(ValueError, match="out of range"):
        writer.add_messages(1, [2**32], [0], [0], [b"x"])
    with pytest.raises(ValueError, match="out of range"):
        writer.add_messages(1, [0], [-1], [0], [b"x"])
    with pytest.raises(ValueError, match="2 messages"):
        writer.add_messages(1, [0], [0], [0], [b"x", b"y"])


def _block(names: list[str], start: int, rows: int, rng: np.random.Generator) -> RowBlock:
    block = RowBlock([Channel(n, "m") for n in names], max(rows, 1))
    block.values[:rows] = rng.standard_normal((rows, len(names))) * 10.0 ** rng.integers(-9, 4)
    block.seq[:rows] = np.arange(start, start + rows)
    block.t_ns[:rows] = (block.seq[:rows] + 1) * 488_281
    block.count = rows
    return block


def test_block_json_parses_to_the_rows():
    """Oracle: the stdlib's JSON parser and ``repr`` (shortest round trip) against the block."""
    rng = np.random.default_rng(4)
    block = _block(["x", "y.z", "w"], 5, 40, rng)
    block.values[3, 1] = np.nan
    block.values[7] = [np.inf, -np.inf, 1e300]
    data, nonfinite = block_json(block, {})
    want = [
        {k: (None if isinstance(v, float) and not np.isfinite(v) else v) for k, v in r.items()}
        for r in block.records()
    ]
    assert [json.loads(d) for d in data] == want
    assert nonfinite == 2 == sum(not ok for *_, ok in block_messages(block, {}))
    assert data[3] == b'{"seq":8,"x":%s,"y.z":null,"w":%s}' % tuple(
        repr(float(v)).encode() for v in block.values[3, [0, 2]]
    )
    assert block_json(_block(["x"], 0, 0, rng)) == ([], 0)


def _log(
    path: Path, items: list[tuple], reference: bool, compiled: bool = False
) -> tuple[bytes, int]:
    """Write ``items`` with the writer thread; ``reference``: mcap's Writer, one row at a time;
    ``compiled``: rows packed by :mod:`rths.log.writer.rowpack`.

    Returns the file and how many blocks took the batched path.
    """
    inbox: queue.SimpleQueue = queue.SimpleQueue()
    config = {
        "reserve": 1 << 20,
        "metadata": {"rths.test": {"a": "b"}},
        "compression": "zstd",
        "chunk_size": 5000,
        "flush_interval": 1e9,  # chunks end by size only: both files cut them at the same rows
        "compiled": compiled,
    }
    thread = WriterThread.open(path, inbox, config)
    if reference:
        thread._writer = Writer(thread._stream, chunk_size=5000, compression=CompressionType.ZSTD)
        thread._block = thread._block_rows  # type: ignore[method-assign]
    batches = []
    if not reference:
        name = "add_records" if compiled else "add_messages"
        add = getattr(thread._writer, name)
        setattr(thread._writer, name, lambda *a: batches.append(a) or add(*a))
    for item in items:
        inbox.put(item)
    inbox.put(STOP)
    thread.run()
    assert thread.error is None
    return path.read_bytes(), len(batches)


@pytest.mark.parametrize("compiled", [False, True])
def test_writer_thread_file_is_the_per_row_file(tmp_path, compiled, monkeypatch):
    monkeypatch.setattr(mcap_writer, "ZSTD_LEVEL", 3)  # mcap's level, as the reference writes
    rng = np.random.default_rng(5)
    loop, spec = ["t", "target", "command", "force"], ["t", "displacement", "force"]
    nan_block = _block(loop, 301, 50, rng)
    nan_block.values[10, 2] = np.nan
    nan_block.values[11, 0] = np.inf
    items: list[tuple] = [("s", "rths/events", b"{}"), ("s", "rths/loop", b"{}")]
    items += [("s", "rths/specimen", b"{}"), ("e", 0, {"kind": "start", "message": "go"})]
    items += [
        ("b", "rths/loop", _block(loop, 0, 1, rng)),
        ("b", "rths/specimen", _block(spec, 0, 0, rng)),  # empty
        ("b", "rths/specimen", _block(spec, 0, 200, rng)),
        ("b", "rths/loop", _block(loop, 1, 300, rng)),
        ("b", "rths/loop", nan_block),
        ("b", "rths/loop", _block(loop, 360, 20, rng)),  # a gap: the per-row path, an event
        ("b", "rths/loop", _block(loop, 370, 5, rng)),  # reordered
        ("b", "rths/specimen", _block(spec, 200, 1, rng)),
        ("e", 10**9, {"kind": "stop", "message": "done"}),
    ]
    batched, blocks = _log(tmp_path / "batched.mcap", items, reference=False, compiled=compiled)
    assert blocks == 5  # the others: empty, after a gap, reordered
    assert batched == _log(tmp_path / "reference.mcap", items, reference=True)[0]
    reader = make_reader(io.BytesIO(batched))
    counts = {}
    for _, channel, _ in reader.iter_messages():
        counts[channel.topic] = counts.get(channel.topic, 0) + 1
    # start, stop, one gap (351..359 missing), five rows reordered (370..374 after 379)
    assert counts == {"rths/events": 8, "rths/loop": 376, "rths/specimen": 201}
