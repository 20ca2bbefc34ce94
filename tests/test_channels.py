"""Declared channels and row blocks: the wire frame round-trips exactly, the recorder writes one
JSON message per row (exact floats, null for non-finite) under a schema generated from the
declarations, readable with the plain mcap reader."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from mcap.reader import make_reader

from rths.core.channels import Channel, RowBlock, json_schema
from rths.core.errors import DataError, ParameterError
from rths.log.recorder import Recorder
from rths.wire.codec import pack_block, pack_frames, unpack_block

CHANNELS = (
    Channel("t", "s", "time"),
    Channel("x", "m", "displacement"),
    Channel("f", "N", "force"),
)


def _block(n: int) -> RowBlock:
    b = RowBlock(CHANNELS, n + 3)
    rng = np.random.default_rng(3)
    b.values[:n] = rng.normal(size=(n, 3)) * np.array([1.0, 1e-3, 1e3])
    b.seq[:n] = np.arange(10, 10 + n)
    b.t_ns[:n] = (b.seq[:n] + 1) * 488_281
    b.count = n
    return b


def test_block_frame_round_trips_bit_for_bit():
    b = _block(17)
    back = unpack_block(pack_block(b))
    assert back.channels == CHANNELS and back.count == 17
    np.testing.assert_array_equal(back.values, b.values[:17])
    np.testing.assert_array_equal(back.seq, b.seq[:17])
    np.testing.assert_array_equal(back.t_ns, b.t_ns[:17])
    for bad in (b"", b"RTHSBLK1" + b"\xff" * 8, pack_block(b)[:-1]):
        with pytest.raises(DataError, match="row block frame is malformed"):
            unpack_block(bad)


@pytest.mark.parametrize("limit", [10**6, 1500, 400, 1])
def test_a_block_split_into_frames_keeps_every_row_in_order_and_each_under_the_limit(limit):
    """The frames of a block that does not fit one batch of zenoh's low-latency transport (which
    drops a larger message silently): each within the limit (a single row may exceed a limit
    smaller than itself), together the block's rows, bit for bit and in order."""
    b = _block(100)
    frames = pack_frames(b, limit)
    parts = [unpack_block(f) for f in frames]
    if limit >= len(pack_block(b)):
        assert frames == [pack_block(b)]  # fits: sent as it was
    elif limit == 1:
        assert [p.count for p in parts] == [1] * 100  # no row fits: one per frame
    else:
        assert len(frames) > 1 and all(len(f) <= limit for f in frames)
    np.testing.assert_array_equal(np.concatenate([p.values for p in parts]), b.values[:100])
    np.testing.assert_array_equal(np.concatenate([p.seq for p in parts]), b.seq[:100])
    np.testing.assert_array_equal(np.concatenate([p.t_ns for p in parts]), b.t_ns[:100])
    assert all(p.channels == CHANNELS for p in parts)


def test_recorder_writes_one_exact_json_message_per_row(tmp_path):
    b = _block(50)
    b.values[7, 1] = math.nan
    with Recorder(tmp_path / "r.mcap", topics={}) as rec:
        rec.put_block("rths/test", b)
    assert rec.summary.topics["rths/test"].written == 50
    assert rec.summary.topics["rths/test"].nonfinite == 1
    with open(tmp_path / "r.mcap", "rb") as f:
        reader = make_reader(f)
        msgs = list(reader.iter_messages(topics=["rths/test"]))
        schema = json.loads(msgs[0][0].data)
    rows = [json.loads(m.data) for _, _, m in msgs]
    assert schema == json_schema("rths.test", CHANNELS, description=schema["description"], seq=True)
    assert schema["properties"]["x"]["description"] == "displacement [m]"
    assert [r["seq"] for r in rows] == list(range(10, 60))
    assert [m.log_time for _, _, m in msgs] == b.t_ns[:50].tolist()
    for i, r in enumerate(rows):
        for j, name in enumerate(("t", "x", "f")):
            want = b.values[i, j]
            assert (r[name] is None) if math.isnan(want) else r[name] == want  # exact


def test_channel_names_are_checked():
    with pytest.raises(ParameterError, match="channel name"):
        Channel("a b")
    with pytest.raises(ParameterError, match="unique"):
        RowBlock((Channel("a"), Channel("a")), 1)
