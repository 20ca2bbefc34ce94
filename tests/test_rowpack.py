"""The compiled row packer writes the records of the interpreted path, byte for byte.

Oracle: :func:`rths.log.writer.rowjson.block_json` (itself held to the stdlib's JSON parser in
``test_block_writer.py``) with each row headed by a Message record header packed by ``struct``
as the MCAP spec lays it out.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from rths.core.channels import Channel, RowBlock
from rths.log.reader import is_complete, read_topic
from rths.log.recorder import Recorder
from rths.log.writer.rowjson import block_json
from rths.log.writer.rowpack import RowPacker, block_records

PATIENCE = 60.0  # upper bound for the writer's periodic flush; reached only if the code is broken


def _block(names: list[str], start: int, rows: int, rng: np.random.Generator) -> RowBlock:
    block = RowBlock([Channel(n, "m") for n in names], rows + 3)  # a block not quite full
    scale = 10.0 ** rng.integers(-300, 300, (rows, len(names)))
    block.values[:rows] = rng.standard_normal((rows, len(names))) * scale
    block.seq[:rows] = np.arange(start, start + rows)
    block.t_ns[:rows] = (np.arange(rows) + 1) * 488_281 + 2**62
    block.count = rows
    return block


def _reference(block: RowBlock, channel_id: int) -> tuple[bytes, list[int], int]:
    data, nonfinite = block_json(block, {})
    n = block.count
    records = [
        struct.pack("<BQHIQQ", 5, 22 + len(d), channel_id, k & 0xFFFFFFFF, t, t) + d
        for k, t, d in zip(block.seq[:n].tolist(), block.t_ns[:n].tolist(), data)
    ]
    return b"".join(records), np.cumsum([len(r) for r in records]).tolist(), nonfinite


@pytest.mark.parametrize(
    ("names", "start", "rows"),
    [
        (["x"], 0, 1),
        (["t", "target", "actuator.specimen.gap_open", "w"], 7, 256),
        ([f"c{i}" for i in range(40)], 2**32 - 5, 30),  # sequence numbers past 2**32
        (["a", "b"], 10**18, 3),  # the longest step counters
    ],
)
def test_block_records_are_the_interpreted_records(names, start, rows):
    rng = np.random.default_rng(rows)
    block = _block(names, start, rows, rng)
    if rows > 3:
        block.values[2, 0] = np.nan
        block.values[3, -1] = -np.inf
        block.values[4, :4] = [0.0, -0.0, 1e-300, 5e-324]
    records, ends, nonfinite = block_records(block, 300)
    want, want_ends, want_nonfinite = _reference(block, 300)
    assert records == want
    assert ends.tolist() == want_ends
    assert nonfinite == want_nonfinite == (2 if rows > 3 else 0)


def test_row_packer_reuses_its_buffer_and_skips_what_it_cannot_pack():
    rng = np.random.default_rng(1)
    packer = RowPacker()
    big, small = _block(["x", "y"], 0, 100, rng), _block(["x", "y", "z"], 100, 5, rng)
    first = packer.pack(big, 1)
    assert first is not None and bytes(first[0]) == _reference(big, 1)[0]
    second = packer.pack(small, 2)
    assert second is not None and bytes(second[0]) == _reference(small, 2)[0]
    assert packer.pack(_block([], 0, 4, rng), 1) is None  # no channels: the interpreted path
    assert packer.pack(_block(["x"], 0, 0, rng), 1) is None  # no rows
    with pytest.raises(ValueError, match="no channels or no rows"):
        block_records(_block(["x"], 0, 0, rng), 1)


def test_row_packer_refuses_negative_counters_and_times():
    rng = np.random.default_rng(2)
    for field in ("seq", "t_ns"):
        block = _block(["x"], 0, 3, rng)
        getattr(block, field)[1] = -1
        with pytest.raises(ValueError, match="negative"):
            block_records(block, 1)


def test_killed_recorder_with_packed_blocks_leaves_a_readable_log(tmp_path: Path):
    """The in-process writer (compiled packing, zstd level 1): what its periodic flush put on
    disk reads back with every row, although the file was never finished."""
    path, snap = tmp_path / "killed.mcap", tmp_path / "snap.mcap"
    rng = np.random.default_rng(3)
    blocks = [_block(["t", "x", "y"], 50 * i, 50, rng) for i in range(4)]
    rec = Recorder(path, topics={}, flush_interval=0.01).start()
    for block in blocks:
        rec.put_block("rths/loop", block)
    assert rec.wait_flushed(PATIENCE)
    snap.write_bytes(path.read_bytes())  # what is on disk if the process died now
    rec.close()
    assert not is_complete(snap)
    with pytest.warns(Warning, match="unfinished"):
        rows = read_topic(snap, "rths/loop")
    assert rows["sequence"].tolist() == list(range(200))
    want = np.concatenate([b.values[: b.count] for b in blocks])
    assert np.array_equal(np.column_stack([rows[n] for n in ("t", "x", "y")]), want)
    assert np.array_equal(read_topic(path, "rths/loop")["x"], want[:, 1])
