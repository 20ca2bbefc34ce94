"""`rths replay` republishes a log on the live keys at its recorded pace."""

from __future__ import annotations

import json
import threading

import zenoh
from _scenarios import short

from rths.cli import main
from rths.log.replay import paced
from rths.wire.codec import LogRecord
from rths.wire.transport import RunKeys, ZenohEndpoints, loopback_endpoint, open_session


def test_replay_publishes_every_record_in_order_at_the_recorded_pace(tmp_path):
    scn = tmp_path / "s.toml"
    scn.write_text(short(0.25))
    log = tmp_path / "run.mcap"
    assert (
        main(
            [
                "run",
                str(scn),
                "--clock",
                "fast",
                "--out",
                str(log),
                "--no-progress",
                "--run-id",
                "replayed",
            ]
        )
        == 0
    )
    endpoint = loopback_endpoint()
    received: list[LogRecord] = []
    lock = threading.Lock()
    all_in = threading.Event()

    def on_sample(sample: zenoh.Sample) -> None:
        with lock:
            received.append(LogRecord.decode(sample.payload.to_bytes()))
            if len(received) == 512:
                all_in.set()

    keys = RunKeys("replayed")
    with open_session(ZenohEndpoints(listen=(endpoint,))) as session:
        sub = session.declare_subscriber(keys.loop, zenoh.handlers.Callback(on_sample))
        code = main(
            [
                "replay",
                str(log),
                "--connect",
                endpoint,
                "--speed",
                "1",
                "--wait",
                "1.0",
                "--topic",
                "rths/loop",
            ]
        )
        all_in.wait(10)  # replay returns when sent; the last records may still be on the way
        sub.undeclare()
    assert code == 0
    assert [r.seq for r in received] == list(range(512))
    assert [r.message["seq"] for r in received] == list(range(512))
    assert received[-1].log_time_ns == 250_000_000
    json.dumps(received[0].message)  # the payload is plain JSON


def test_pacing_keeps_the_recorded_spacing_divided_by_speed():
    """On a fake clock: each record is released exactly at (log time - first) / speed."""
    clock = [1_000]
    released: list[int] = []

    def sleep(seconds: float) -> None:
        clock[0] += round(seconds * 1e9)

    records = [("rths/loop", t, {}) for t in (5_000, 5_000, 7_000, 12_000)]
    for _, log_time, _ in paced(records, 2.0, now_ns=lambda: clock[0], sleep=sleep):
        released.append(clock[0])
    assert released == [1_000, 1_000, 2_000, 4_500]


def test_replay_refuses_a_missing_topic(tmp_path, capsys):
    scn = tmp_path / "s.toml"
    scn.write_text(short(0.05))
    log = tmp_path / "run.mcap"
    assert main(["run", str(scn), "--clock", "fast", "--out", str(log), "--no-progress"]) == 0
    assert main(["replay", str(log), "--topic", "rths/nothing"]) == 2
    assert "has no topic 'rths/nothing'" in capsys.readouterr().err
