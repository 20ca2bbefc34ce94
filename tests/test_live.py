"""Live viewing: the Foxglove WebSocket server serves the log's own JSON and schema to a real
WebSocket client speaking the Foxglove protocol; the shipped layout plots channels that exist."""

from __future__ import annotations

import json
import re
import struct
from importlib import resources

import numpy as np
import pytest
from websockets.sync.client import connect

from rths.core.channels import RowBlock
from rths.core.errors import ConfigError
from rths.log.live import LiveServer, parse_where
from rths.log.recorder import block_schema
from rths.log.writer.rowjson import block_messages
from rths.runtime.loop import LOOP_CHANNELS

PROTOCOL = "foxglove.sdk.v1"  # the SDK's name for the Foxglove WebSocket protocol


#: Longest wait [s] for an event that must come (a failure, not a pace).
PATIENCE = 60.0


def _block(n: int, k0: int = 0) -> RowBlock:
    block = RowBlock(LOOP_CHANNELS, n)
    rng = np.random.default_rng(k0)
    block.values[:] = rng.normal(size=block.values.shape)
    block.seq[:] = np.arange(k0, k0 + n)
    block.t_ns[:] = (block.seq + 1) * 244_140
    block.count = n
    return block


def _json_until(ws, op: str) -> dict:
    while True:
        frame = ws.recv(timeout=10)
        if isinstance(frame, str):
            msg = json.loads(frame)
            if msg.get("op") == op:
                return msg


def test_a_websocket_client_receives_the_logs_json_and_schema():
    server = LiveServer.start("127.0.0.1:0", max_rate=1e9)  # no thinning
    try:
        schema = block_schema("rths/loop", RowBlock(LOOP_CHANNELS, 0))
        server.add_topic("rths/loop", schema)
        with connect(f"ws://127.0.0.1:{server.port}", subprotocols=[PROTOCOL]) as ws:
            advertised = _json_until(ws, "advertise")["channels"]
            (channel,) = [c for c in advertised if c["topic"] == "rths/loop"]
            assert channel["encoding"] == "json" and channel["schemaEncoding"] == "jsonschema"
            assert json.loads(channel["schema"]) == schema
            ws.send(
                json.dumps(
                    {"op": "subscribe", "subscriptions": [{"id": 7, "channelId": channel["id"]}]}
                )
            )
            # rows put before the server has registered the subscription go nowhere: wait for it
            assert server.subscribed.wait(PATIENCE), "the subscription never reached the server"
            block = _block(32, k0=100)
            expected = block_messages(block)
            received = []
            while len(received) < len(expected):  # waits on frames, not on time
                server.put_block("rths/loop", block if not received else _block(0))
                frame = ws.recv(timeout=10)
                if isinstance(frame, bytes) and frame[0] == 1:  # MessageData
                    sub, log_time = struct.unpack_from("<IQ", frame, 1)
                    assert sub == 7
                    received.append((log_time, frame[13:]))
        for (log_time, payload), (_k, t, data, _ok) in zip(received, expected):
            assert log_time == t and payload == data  # byte for byte the MCAP log's message
        row = json.loads(received[0][1])
        assert row["seq"] == 100 and set(row) == {"seq", *(c.name for c in LOOP_CHANNELS)}
    finally:
        server.close()


def test_rows_are_thinned_to_the_live_rate():
    server = LiveServer.start("127.0.0.1:0", max_rate=1000.0)  # rows every 244 us -> every 5th
    try:
        server.put_block("rths/loop", _block(200))
        server.close()
        assert server.sent == 40
    finally:
        server.close() if server._thread.is_alive() else None


@pytest.mark.parametrize("where", ["8765", "host:", "host:70000", ":1"])
def test_bad_live_address_is_one_clear_error(where):
    with pytest.raises(ConfigError, match="--live takes HOST:PORT"):
        parse_where(where)


def test_the_shipped_layout_plots_channels_the_log_has():
    text = resources.files("rths.log").joinpath("foxglove_layout.json").read_text()
    layout = json.loads(text)
    names = {c.name for c in LOOP_CHANNELS}
    paths = re.findall(r'\\"rths/loop\\"\.(\w+)', text)
    assert paths and set(paths) <= names
    titles = " ".join(p["title"] for p in layout["configById"].values())
    for panel in (
        "target / command / measured",
        "synchronisation subspace",
        "force-displacement",
        "timing",
    ):
        assert panel in titles


def test_readme_log_contract_is_generated_from_the_declarations():
    from pathlib import Path

    from rths.log.contract import markdown

    readme = (Path(__file__).resolve().parent.parent / "README.md").read_text()
    begin, end = "<!-- log-contract:begin -->\n", "<!-- log-contract:end -->"
    assert readme[readme.index(begin) + len(begin) : readme.index(end)] == markdown()
