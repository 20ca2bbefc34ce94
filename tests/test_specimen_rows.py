"""The specimen's log rows riding on its measurements (the realtime clock): the reply codec
(rths.wire.codec.pack_reply / unpack_reply), the coordinator's gathering into blocks
(rths.session.specimen_rows) and the synchronous client handing every reply's rows over, on
time, late or drained after the loop -- over a real zenoh pair, sealed.

Every wait over zenoh is a timeout (an upper bound reached only when something is broken).
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from rths.core.channels import Channel, RowBlock
from rths.core.errors import DataError
from rths.session.specimen_rows import BLOCK_ROWS, SpecimenRows
from rths.wire.auth import RunSecret
from rths.wire.codec import Command, Measurement, pack_reply, unpack_reply
from rths.wire.links import LockstepServer
from rths.wire.sync_link import SyncClient
from rths.wire.transport import RunKeys, ZenohEndpoints, open_session, wait_matched

PATIENCE = 10.0
CHANNELS = (Channel("x", "m", "displacement"), Channel("f", "N", "force"), Channel("v", "m/s", ""))


def _rows(first: int, n: int) -> RowBlock:
    b = RowBlock(CHANNELS, 8)
    rng = np.random.default_rng(first)
    b.values[:n] = rng.normal(size=(n, 3)) * [1e-3, 1e4, 0.1]
    b.seq[:n] = np.arange(first, first + n)
    b.t_ns[:n] = (b.seq[:n] + 1) * 976_562
    b.count = n
    return b


def test_a_reply_carries_its_rows_bit_for_bit_and_a_plain_measurement_none() -> None:
    m = Measurement(7, 8_000_000, 1.25e-3, -3.5e2, 123)
    assert unpack_reply(pack_reply(m)) == (m, None)
    assert pack_reply(m, _rows(0, 0)) == m.pack()  # no rows: the 40-byte measurement
    rows = _rows(5, 3)
    data = pack_reply(m, rows)
    assert len(data) == 40 + 4 + 3 * (16 + 8 * 3)
    back, (seq, t_ns, values) = unpack_reply(data)
    assert back == m
    np.testing.assert_array_equal(seq, rows.seq[:3])
    np.testing.assert_array_equal(t_ns, rows.t_ns[:3])
    np.testing.assert_array_equal(values, rows.values[:3])
    for bad in (data[:-1], data[:42], data + b"\0"):
        with pytest.raises(DataError):
            unpack_reply(bad)


def test_rows_are_gathered_into_full_blocks_in_order_and_the_rest_on_flush() -> None:
    got: list[tuple[str, RowBlock]] = []
    gather = SpecimenRows(CHANNELS, "rths/specimen", lambda t, b: got.append((t, b)))
    sent = [_rows(k, 1 if k % 7 else 5) for k in range(0, 600, 5)]  # mostly one row per reply
    for b in sent:
        gather.add((b.seq[: b.count], b.t_ns[: b.count], b.values[: b.count]))
    n = sum(b.count for b in sent)
    assert [b.count for _, b in got] == [BLOCK_ROWS] * (n // BLOCK_ROWS)
    gather.flush()
    assert {t for t, _ in got} == {"rths/specimen"} and gather.rows == n
    values = np.concatenate([b.values[: b.count] for _, b in got])
    seq = np.concatenate([b.seq[: b.count] for _, b in got])
    np.testing.assert_array_equal(values, np.concatenate([b.values[: b.count] for b in sent]))
    np.testing.assert_array_equal(seq, np.concatenate([b.seq[: b.count] for b in sent]))
    with pytest.raises(DataError, match="rows of 2 channels; the lab has 3"):
        gather.add((np.zeros(1, np.int64), np.zeros(1, np.int64), np.zeros((1, 2))))


def test_the_sync_client_hands_over_the_rows_of_every_reply_on_time_late_or_drained() -> None:
    secret, keys, ep = RunSecret.new(), RunKeys("riding"), ZenohEndpoints.loopback()
    with open_session(ep) as co, open_session(ep.peer()) as sp:
        with SyncClient(co, keys, secret) as client, LockstepServer(sp, keys, secret) as server:
            assert wait_matched(client.publisher, PATIENCE)
            assert wait_matched(server.publisher, PATIENCE)
            got: list[int] = []
            client.on_rows = lambda rows: got.extend(rows[0].tolist())
            client.send(Command(0, 1, 0.0))
            assert server.receive(PATIENCE) == Command(0, 1, 0.0)
            server.reply(Measurement(0, 1, 0.1, 0.2, 3), _rows(0, 1))
            # step 1: measurement 0 is read first (late: its row still handed over); nobody
            # answers 1 before the deadline (this thread is the specimen): a miss
            soon = time.monotonic_ns() + 50_000_000
            assert client.exchange(Command(1, 2, 0.0), soon) is None
            assert got == [0] and client.late == 1
            # the answer to 1 carries the rows of steps 1 and 2; drained after the loop
            assert server.receive(PATIENCE) == Command(1, 2, 0.0)
            server.reply(Measurement(1, 2, 0.1, 0.2, 3), _rows(1, 2))
            assert client.drain(time.monotonic_ns() + 1_000_000_000) == 1  # waits out its 1 s
    assert got == [0, 1, 2] and client.late == 2  # every row, once, in order
