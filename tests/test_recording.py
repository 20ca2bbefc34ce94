"""Oracles for rths.log.recorder and rths.log.reader.

The log is read back with the *plain* ``mcap`` reader (no project code) to hold the log contract
of design.md §4; :mod:`rths.log.reader` is then checked against the same file.  Floats survive JSON
exactly (Python writes the shortest repr that round-trips), so equality checks are exact.
"""

from __future__ import annotations

import json
import math
import struct
import threading
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

from rths import __version__
from rths.core.errors import DataError, ParameterError
from rths.log.reader import is_complete, list_topics, read_metadata, read_topic
from rths.log.recorder import (
    EVENTS_TOPIC,
    LOOP_SCHEMA,
    LOOP_TOPIC,
    Recorder,
    RecordingFailed,
    object_schema,
)
from rths.wire.transport import (
    LogBridge,
    LogPublisher,
    RunKeys,
    ZenohEndpoints,
    open_session,
    wait_matched,
)

PATIENCE = 10.0  # upper bound for asynchronous deliveries; reached only if the code is broken
DT_NS = 250_000  # 4 kHz loop step [ns]


def loop_row(k: int) -> dict[str, float]:
    """A deterministic loop record of step k (values with long binary expansions on purpose)."""
    t = (k + 1) * DT_NS * 1e-9
    return {
        "t": t,
        "target": 1e-3 * math.sin(2 * math.pi * 2.0 * t),
        "command": 1.1e-3 * math.sin(2 * math.pi * 2.0 * t + 0.1),
        "measured": 0.9e-3 * math.sin(2 * math.pi * 2.0 * t - 0.1),
        "force": 1234.5 * math.cos(2 * math.pi * 2.0 * t),
    }


def record(path: Path, n: int, skip: tuple[int, ...] = (), **kwargs) -> Recorder:
    metadata = {"scenario": {"text": "[cable]\nT = 1.0e6\n"}, "units": {"force": "N"}}
    with Recorder(path, metadata=metadata, **kwargs) as rec:
        for k in range(n):
            if k not in skip:
                rec.put(LOOP_TOPIC, k, (k + 1) * DT_NS, loop_row(k))
    return rec


def plain_read(path: Path) -> tuple[dict, list, list]:
    """(summary-derived facts, messages as (topic, schema, channel, message), metadata)."""
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        messages = [(c.topic, s, c, m) for s, c, m in reader.iter_messages(log_time_order=False)]
    with open(path, "rb") as f:
        metadata = list(make_reader(f).iter_metadata())
    return {"summary": summary}, messages, metadata


def test_plain_mcap_reader_sees_every_field_count_order_and_metadata(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    n = 2000
    rec = record(path, n)
    assert rec.summary.complete and rec.summary.topics[LOOP_TOPIC].written == n
    facts, messages, metadata = plain_read(path)
    summary = facts["summary"]
    assert summary is not None  # footer + summary written
    loop = [(s, c, m) for topic, s, c, m in messages if topic == LOOP_TOPIC]
    assert len(loop) == n == summary.statistics.channel_message_counts[loop[0][1].id]
    for k, (schema, channel, message) in enumerate(loop):
        assert message.sequence == k  # file order is production order
        assert message.log_time == message.publish_time == (k + 1) * DT_NS
        assert json.loads(message.data) == loop_row(k)  # exact round trip of every field
    schema, channel, _ = loop[0]
    assert channel.message_encoding == "json" and schema.encoding == "jsonschema"
    assert json.loads(schema.data) == LOOP_SCHEMA
    props = json.loads(schema.data)["properties"]
    assert "[s]" in props["t"]["description"] and "[N]" in props["force"]["description"]
    assert all("[m]" in props[f]["description"] for f in ("target", "command", "measured"))
    by_name = {m.name: m.metadata for m in metadata}
    assert by_name["scenario"] == {"text": "[cable]\nT = 1.0e6\n"}
    assert by_name["units"] == {"force": "N"}
    assert by_name["rths"] == {"version": __version__}
    assert by_name["rths.recording"]["complete"] == "true"
    assert by_name["rths.recording"]["rths/loop.written"] == str(n)
    assert summary.statistics.chunk_count >= 1 and summary.chunk_indexes[0].compression == "zstd"


def test_gaps_and_reordering_are_counted_and_logged(tmp_path: Path) -> None:
    path = tmp_path / "gap.mcap"
    with Recorder(path) as rec:
        for k in (0, 1, 2, 5, 6, 4, 7):  # 3 and 4 skipped when 5 comes; 4 then arrives late
            rec.put(LOOP_TOPIC, k, k * DT_NS, loop_row(k))
    stats = rec.summary.topics[LOOP_TOPIC]
    assert (stats.written, stats.missing, stats.reordered) == (7, 2, 1)
    assert (stats.first_seq, stats.last_seq) == (0, 7) and not rec.summary.complete
    _, messages, metadata = plain_read(path)
    events = [json.loads(m.data) for topic, _, _, m in messages if topic == EVENTS_TOPIC]
    assert [e["kind"] for e in events] == ["gap", "reordered"]
    assert events[0]["message"] == "rths/loop: expected seq 3, got 5" and events[0]["missing"] == 2
    meta = {m.name: m.metadata for m in metadata}["rths.recording"]
    assert meta["complete"] == "false" and meta["rths/loop.missing"] == "2"
    # A stream that does not start at 0 has lost its beginning: that is a gap too.
    with Recorder(tmp_path / "late.mcap") as rec:
        rec.put(LOOP_TOPIC, 3, 0, loop_row(3))
    assert rec.summary.topics[LOOP_TOPIC].missing == 3


def test_producer_never_waits_for_the_writer(tmp_path: Path, monkeypatch) -> None:
    """The writer thread is stuck inside its first write (think: chunk compression, slow disk);
    5000 puts still return, all queued.  Events order everything: the test waits until the
    writer is inside the stuck write, and releases it only after the producer is done."""
    entered, gate = threading.Event(), threading.Event()
    original = Writer.add_message

    def stuck(self, *args, **kwargs):
        entered.set()
        gate.wait()
        return original(self, *args, **kwargs)

    monkeypatch.setattr(Writer, "add_message", stuck)
    rec = Recorder(tmp_path / "stuck.mcap").start()
    rec.put(LOOP_TOPIC, 0, 0, loop_row(0))
    assert entered.wait(PATIENCE)  # the writer holds message 0 and is stuck

    def produce() -> None:
        for k in range(1, 5000):
            rec.put(LOOP_TOPIC, k, k * DT_NS, loop_row(k))

    producer = threading.Thread(target=produce)
    producer.start()
    producer.join(PATIENCE)  # deadlock guard only: put never waits, so this returns at once
    assert not producer.is_alive() and not gate.is_set()
    assert LOOP_TOPIC not in rec._writer.stats() or rec._writer.stats()[LOOP_TOPIC].written == 0
    gate.set()
    summary = rec.close()
    assert summary.topics[LOOP_TOPIC].written == 5000 and summary.complete
    assert summary.max_backlog >= 4000  # the queue absorbed the backlog


def test_file_is_finished_when_the_body_raises(tmp_path: Path) -> None:
    path = tmp_path / "crash.mcap"
    with pytest.raises(ZeroDivisionError):
        with Recorder(path) as rec:
            for k in range(100):
                rec.put(LOOP_TOPIC, k, k * DT_NS, loop_row(k))
            1 / 0
    facts, messages, _ = plain_read(path)
    assert facts["summary"] is not None and is_complete(path)
    assert sum(topic == LOOP_TOPIC for topic, *_ in messages) == 100
    events = [json.loads(m.data) for topic, _, _, m in messages if topic == EVENTS_TOPIC]
    assert events == [
        {"kind": "error", "message": "run ended by ZeroDivisionError('division by zero')"}
    ]
    assert read_topic(path, EVENTS_TOPIC)["log_time_ns"][0] == 99 * DT_NS  # last time seen


def test_writer_failure_stops_nothing_and_ends_the_log_readably(
    tmp_path: Path, monkeypatch
) -> None:
    """A failing write is reported once through on_fault (from the writer thread); the producer
    keeps putting without an error (the loop must not die in its sink), what follows is counted
    as lost, metadata queued afterwards (the run's summary) still lands in the finished file, and
    close() raises the run-time fault."""

    def broken(self, *args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(Writer, "add_message", broken)
    faults: list[str] = []
    told = threading.Event()
    rec = Recorder(
        tmp_path / "full.mcap", on_fault=lambda m: (faults.append(m), told.set())
    ).start()
    rec.put(LOOP_TOPIC, 0, 0, loop_row(0))
    assert told.wait(PATIENCE)
    rec.put(LOOP_TOPIC, 1, DT_NS, loop_row(1))  # accepted, not written (nor was message 0)
    rec.add_metadata("rths.summary", {"stopped": "recording failed"})
    with pytest.raises(
        RecordingFailed, match=r"recording to .*full.mcap' failed: OSError.*2 messages not written"
    ):
        rec.close()
    assert len(faults) == 1 and "No space left" in faults[0] and rec.fault == faults[0]
    assert is_complete(tmp_path / "full.mcap")
    meta = read_metadata(tmp_path / "full.mcap")
    assert meta["rths.summary"] == {"stopped": "recording failed"}
    assert meta["rths.recording"]["complete"] == "false" and meta["rths.recording"]["lost"] == "2"
    # While the body is already raising, the writer's failure is attached as a note instead.
    with pytest.raises(KeyError) as info:
        with Recorder(tmp_path / "full2.mcap") as rec:
            rec.put(LOOP_TOPIC, 0, 0, loop_row(0))
            raise KeyError("body")
    assert any("No space left" in note for note in info.value.__notes__)


def test_nonfinite_numpy_and_other_topics(tmp_path: Path) -> None:
    path = tmp_path / "misc.mcap"
    timing = object_schema("rths.timing", {"jitter": "start-time error [s]"}, description="x")
    with Recorder(path, topics={LOOP_TOPIC: LOOP_SCHEMA, "rths/timing": timing}) as rec:
        rec.add_topic("rths/timing", timing)  # same schema again: no-op
        row = loop_row(0) | {"force": float("nan"), "measured": np.float32(0.5)}
        rec.put(LOOP_TOPIC, 0, 0, row)
        rec.put(LOOP_TOPIC, 1, DT_NS, loop_row(1) | {"extra": np.arange(3)}, publish_time_ns=7)
        rec.put("rths/timing", 0, 0, {"jitter": np.float64(1e-6)})
        rec.add_topic("rths/late", {"type": "object"})  # registered mid-run
        rec.put("rths/late", 0, 0, {"flag": True})
        rec.event(DT_NS, "overrun", "step 1 late", lateness=1e-5)
    assert rec.summary.topics[LOOP_TOPIC].nonfinite == 1
    loop = read_topic(path, LOOP_TOPIC)
    assert math.isnan(loop["force"][0]) and loop["measured"][0] == 0.5  # float32 0.5 is exact
    assert list(loop["extra"][1]) == [0, 1, 2] and loop["extra"][0] is None
    assert list(loop["publish_time_ns"]) == [0, 7] and list(loop["sequence"]) == [0, 1]
    assert read_topic(path, "rths/timing")["jitter"][0] == 1e-6
    assert read_topic(path, "rths/late")["flag"].dtype == bool
    assert read_topic(path, EVENTS_TOPIC)["lateness"][0] == 1e-5
    assert list_topics(path) == {EVENTS_TOPIC: 1, LOOP_TOPIC: 2, "rths/timing": 1, "rths/late": 1}


def test_recorder_validation(tmp_path: Path) -> None:
    with pytest.raises(ParameterError, match=r"compression must be .*got 'gzip'"):
        Recorder(tmp_path / "a.mcap", compression="gzip")  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match=r"chunk_size must be a positive integer; got 0"):
        Recorder(tmp_path / "a.mcap", chunk_size=0)
    with pytest.raises(ParameterError, match=r"flush_interval must be positive; got -1"):
        Recorder(tmp_path / "a.mcap", flush_interval=-1)
    with pytest.raises(
        ParameterError, match=r"metadata\['run'\] keys and values must be strings; got 'dt': 0.001"
    ):
        Recorder(tmp_path / "a.mcap", metadata={"run": {"dt": 0.001}})  # type: ignore[dict-item]
    with pytest.raises(ParameterError, match=r"metadata must map record names .*got 'run': 'x'"):
        Recorder(tmp_path / "a.mcap", metadata={"run": "x"})  # type: ignore[dict-item]
    with pytest.raises(DataError, match=r"cannot create MCAP log '.*no/such/dir/a.mcap'"):
        Recorder(tmp_path / "no" / "such" / "dir" / "a.mcap").start()
    rec = Recorder(tmp_path / "a.mcap")
    with pytest.raises(DataError, match=r"recorder for '.*a.mcap' is not started"):
        rec.put(LOOP_TOPIC, 0, 0, {})
    with pytest.raises(DataError, match=r"was never started"):
        rec.close()
    with pytest.raises(ParameterError, match=r"topic must be a non-empty string; got ''"):
        rec.add_topic("", {})
    with pytest.raises(ParameterError, match=r"schema of topic 'x' is not JSON"):
        rec.add_topic("x", {"a": object()})
    with pytest.raises(
        ParameterError, match=r"topic 'rths/loop' is already registered with another"
    ):
        rec.add_topic(LOOP_TOPIC, {"type": "object"})
    with rec:
        with pytest.raises(DataError, match=r"already started"):
            rec.start()
        with pytest.raises(
            ParameterError, match=r"topic 'nope' is not registered .*known: \['rths/loop'\]"
        ):
            rec.put("nope", 0, 0, {})
        with pytest.raises(
            ParameterError, match=r"'rths/events' is not registered for put\(\) \(events go"
        ):
            rec.put(EVENTS_TOPIC, 0, 0, {})
        with pytest.raises(ParameterError, match=r"seq and times must be integers; got seq=1.0"):
            rec.put(LOOP_TOPIC, 1.0, 0, {})  # type: ignore[arg-type]
        with pytest.raises(ParameterError, match=r"must be >= 0; got seq=0, log_time_ns=-5"):
            rec.put(LOOP_TOPIC, 0, -5, {})
        rec.put(LOOP_TOPIC, np.int64(0), np.int64(0), loop_row(0))  # numpy integers are fine
    assert rec.close() is rec.summary  # idempotent
    with pytest.raises(DataError, match=r"is closed"):
        rec.event(0, "late", "after close")
    with pytest.raises(ParameterError, match=r"needs at least one field"):
        object_schema("empty", {})
    with pytest.raises(
        ParameterError, match=r"required fields of schema 's' are not fields: \['y'\]"
    ):
        object_schema("s", {"x": "[m]"}, required=["y"])


# --------------------------------------------------------------------------- mcap_io


def test_mcap_io_reads_what_was_written(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    record(path, 500, skip=(250,))
    loop = read_topic(path, LOOP_TOPIC)
    ks = [k for k in range(500) if k != 250]
    assert list(loop["sequence"]) == ks and loop["t"].dtype == np.float64
    for name in ("t", "target", "command", "measured", "force"):
        assert np.array_equal(loop[name], [loop_row(k)[name] for k in ks])
    assert np.array_equal(loop["log_time_ns"], [(k + 1) * DT_NS for k in ks])
    meta = read_metadata(path)
    assert (
        meta["scenario"]["text"].startswith("[cable]")
        and meta["rths.recording"]["rths/loop.missing"] == "1"
    )
    assert list_topics(path) == {EVENTS_TOPIC: 1, LOOP_TOPIC: 499} and is_complete(path)


def test_mcap_io_errors(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    record(path, 3)
    with pytest.raises(
        DataError,
        match=r"topic 'rths/nope' not found in .*; topics: \['rths/events', 'rths/loop'\]",
    ):
        read_topic(path, "rths/nope")
    with pytest.raises(DataError, match=r"cannot open MCAP log '.*missing.mcap'"):
        read_topic(tmp_path / "missing.mcap", LOOP_TOPIC)
    (tmp_path / "x.csv").write_text("time,command,measured,force\n0,0,0,0\n")
    with pytest.raises(DataError, match=r"'.*x.csv' is not an MCAP log \(InvalidMagic\)"):
        list_topics(tmp_path / "x.csv")
    for name, data in (("notjson", b"{oops"), ("array", b"[1, 2]")):
        with open(tmp_path / f"{name}.mcap", "wb") as f:  # a foreign log, plain mcap writer
            writer = Writer(f)
            writer.start()
            schema = writer.register_schema("s", "jsonschema", b"{}")
            channel = writer.register_channel("rths/loop", "json", schema)
            writer.add_message(channel, 0, data, 0)
            writer.finish()
    with pytest.raises(DataError, match=r"message on 'rths/loop' in '.*notjson.mcap' is not JSON"):
        read_topic(tmp_path / "notjson.mcap", LOOP_TOPIC)
    with pytest.raises(
        DataError, match=r"'rths/loop' in '.*array.mcap' is not a JSON object: \[1, 2\]"
    ):
        read_topic(tmp_path / "array.mcap", LOOP_TOPIC)
    (tmp_path / "empty.mcap").write_bytes(b"")
    with pytest.raises(DataError, match=r"'.*empty.mcap' is empty or not an MCAP log"):
        read_metadata(tmp_path / "empty.mcap")


def test_truncated_log_reads_a_clean_prefix(tmp_path: Path) -> None:
    path = tmp_path / "full.mcap"
    n = 1000
    record(path, n, chunk_size=2048)  # ~15 messages per chunk: many cut points inside chunks
    data = path.read_bytes()
    cut = tmp_path / "cut.mcap"
    counts = []
    for fraction in np.linspace(0.05, 0.999, 23):
        cut.write_bytes(data[: int(fraction * len(data))])
        assert not is_complete(cut)
        try:
            loop = read_topic(cut, LOOP_TOPIC)
        except DataError as exc:  # cut before the first chunk: no channel yet
            assert "not found" in str(exc) and fraction < 0.1
            continue
        m = loop["sequence"].size
        assert np.array_equal(loop["sequence"], np.arange(m))  # a prefix, nothing garbled
        assert np.array_equal(loop["force"], [loop_row(k)["force"] for k in range(m)])
        counts.append(m)
    assert counts == sorted(counts) and 0 < counts[0] and counts[-1] == n


def test_crashed_writer_leaves_a_readable_log(tmp_path: Path) -> None:
    """A writer that never finishes (killed process) has still flushed whole chunks to disk."""
    path = tmp_path / "killed.mcap"
    snap = tmp_path / "snap.mcap"
    rec = Recorder(path, chunk_size=1 << 20, flush_interval=0.01).start()
    for k in range(300):
        rec.put(LOOP_TOPIC, k, k * DT_NS, loop_row(k))
    assert rec.wait_flushed(PATIENCE)  # the periodic flush, although the chunk is not full
    snap.write_bytes(path.read_bytes())  # what is on disk if the process died now
    seen = read_topic(snap, LOOP_TOPIC)["sequence"].size
    rec.close()
    assert seen == 300 and not is_complete(snap)  # all messages, although the chunk was not full


# --------------------------------------------------------------------------- zenoh bridge


def test_log_bridge_records_another_sessions_stream(tmp_path: Path) -> None:
    ep = ZenohEndpoints.loopback()
    keys = RunKeys("bridge")
    path = tmp_path / "bridge.mcap"
    with open_session(ep) as co, open_session(ep.peer()) as sp:
        rec = Recorder(path).start()
        with LogBridge(co, keys, rec) as bridge, LogPublisher(sp, keys, "specimen") as pub:
            assert wait_matched(pub._publisher, PATIENCE)
            for k in range(100):
                if k == 40:
                    pub.seq += 1  # a record lost on the way: must show up as a gap
                pub.put(k * DT_NS, {"x_i": k * 1e-4, "force_spring": -k * 2.0})
            sp.put(keys.log("specimen"), b"not json")
            assert bridge.wait_for(lambda b: b.received >= 101, PATIENCE)
            rec.close()
            pub.put(0, {"x_i": 0.0})  # after the recorder closed: refused, and counted
            assert bridge.wait_for(lambda b: b.dropped >= 1, PATIENCE)
            assert bridge.dropped == 1
    stats = rec.summary.topics["rths/specimen"]
    assert (stats.written, stats.missing, stats.rejected) == (100, 1, 1)
    spec = read_topic(path, "rths/specimen")
    assert np.array_equal(spec["x_i"], np.arange(100) * 1e-4)
    assert list(spec["sequence"][39:42]) == [39, 41, 42]
    kinds = list(read_topic(path, EVENTS_TOPIC)["kind"])
    assert sorted(kinds) == ["gap", "rejected"]


def test_metadata_added_at_the_end_is_readable_by_the_plain_reader(tmp_path: Path) -> None:
    path = tmp_path / "summary.mcap"
    with Recorder(path, metadata={"scenario": {"text": "x = 1"}}) as rec:
        rec.put(
            LOOP_TOPIC,
            0,
            0,
            {"t": 0.0, "target": 0.0, "command": 0.0, "measured": 0.0, "force": 0.0},
        )
        rec.add_metadata("rths.summary", {"j2": "0.0012"})
        with pytest.raises(ParameterError, match="keys and values must be strings"):
            rec.add_metadata("bad", {"j2": 0.1})  # type: ignore[dict-item]
    with open(path, "rb") as f:
        records = {m.name: m.metadata for m in make_reader(f).iter_metadata()}
    assert records["rths.summary"] == {"j2": "0.0012"}
    assert records["scenario"] == {"text": "x = 1"}
    with pytest.raises(DataError, match="closed"):
        rec.add_metadata("late", {"a": "b"})


def test_records_from_another_process_are_written_as_received_unless_non_finite(tmp_path):
    from rths.wire.codec import LogRecord

    path = tmp_path / "records.mcap"
    with Recorder(path) as rec:
        rec.put_record("rths/side", LogRecord(0, 10, {"a": 1.25, "b": "x"}).encode())
        rec.put_record("rths/side", LogRecord(1, 20, {"a": float("nan")}).encode())
        rec.put_record("rths/side", struct.pack("<QQ", 2, 30) + b"not json")
    with open(path, "rb") as f:
        messages = [m.data for _, _, m in make_reader(f).iter_messages(topics=["rths/side"])]
    assert messages == [b'{"a":1.25,"b":"x"}', b'{"a":null}']  # raw bytes; NaN cleaned
    stats = rec.summary.topics["rths/side"]
    assert (stats.written, stats.nonfinite, stats.rejected) == (2, 1, 1)


def test_block_messages_are_the_rows_as_json_exactly():
    """Each message parsed by the standard library's json equals its row: every float
    round-trips exactly (shortest form), non-finite values become null, seq and order kept."""
    import json as stdlib_json

    from rths.core.channels import Channel, RowBlock
    from rths.log.writer.rowjson import block_messages

    names = ("a", "b.c", "d_e")
    block = RowBlock([Channel(n) for n in names], 8)
    rng = np.random.default_rng(3)
    block.values[:7] = rng.standard_normal((7, 3)) * 10.0 ** rng.integers(-300, 300, (7, 3))
    block.values[1] = (-0.0, 1e-5, 5e-324)
    block.values[2, 1] = np.nan
    block.values[3, 2] = -np.inf
    block.seq[:7] = np.arange(100, 107)
    block.t_ns[:7] = np.arange(7) * 244_141
    block.count = 7
    messages = block_messages(block)
    assert [m[0] for m in messages] == list(range(100, 107))
    assert [m[1] for m in messages] == [t * 244_141 for t in range(7)]
    assert [m[3] for m in messages] == [True, True, False, False, True, True, True]
    for (k, _t, data, _ok), row in zip(messages, block.values[:7].tolist()):
        expected = {"seq": k} | {n: (v if np.isfinite(v) else None) for n, v in zip(names, row)}
        parsed = stdlib_json.loads(data)
        assert list(parsed) == ["seq", *names]
        assert parsed == expected
    empty = RowBlock([], 2)
    empty.count = 1
    assert block_messages(empty)[0][2] == b'{"seq":0}'
