"""A specimen process that dies mid-run: the coordinator says why, and the MCAP log it leaves is
finished and readable with the plain mcap reader."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading

import pytest
from _scenarios import short
from mcap.reader import make_reader

from rths.config.scenario import parse_scenario
from rths.core.errors import TransportError
from rths.session.runner import RunOptions, run_scenario
from rths.wire.auth import RunSecret, write_secret_file
from rths.wire.transport import loopback_endpoint


def test_killed_specimen_leaves_a_finished_readable_log(tmp_path):
    scn_file = tmp_path / "s.toml"
    scn_file.write_text(short(60.0))
    scn = parse_scenario(scn_file.read_text(), str(scn_file))
    endpoint = loopback_endpoint()
    out = tmp_path / "crash.mcap"
    secret = write_secret_file(tmp_path / "run.secret", RunSecret.new())
    outcome: dict = {}
    running = threading.Event()

    def progress(done: int, total: int) -> None:
        if done >= 1000:
            running.set()

    def coordinator() -> None:
        try:
            outcome["value"] = run_scenario(
                scn,
                RunOptions(
                    out=out,
                    listen=(endpoint,),
                    external_specimen=True,
                    run_id="crash-test",
                    secret_file=secret,
                    step_timeout=3.0,
                    progress=progress,
                ),
            )
        except TransportError as exc:
            outcome["error"] = exc

    thread = threading.Thread(target=coordinator)
    thread.start()
    specimen = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "rths",
            "specimen",
            str(scn_file),
            "--run-id",
            "crash-test",
            "--connect",
            endpoint,
            "--secret-file",
            str(secret),
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        assert running.wait(120.0), "the run never started"  # 1000 steps done
        os.kill(specimen.pid, signal.SIGKILL)  # a hard crash: no goodbye
    finally:
        specimen.wait(timeout=30)
        thread.join(timeout=60)
    assert not thread.is_alive()
    # the coordinator noticed: either an error naming the specimen or a stop with the reason
    if "error" in outcome:
        message = str(outcome["error"])
    else:
        message = outcome["value"].result.stopped or ""
    assert "specimen" in message, message
    with open(out, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()  # present only if the file was finished
        counts = {
            c.topic: summary.statistics.channel_message_counts.get(c.id, 0)
            for c in summary.channels.values()
        }
        events = [json.loads(m.data) for _, _, m in reader.iter_messages(topics=["rths/events"])]
    assert counts["rths/loop"] > 100
    assert any("specimen" in e["message"] for e in events), events
    assert events[-1]["kind"] in ("end", "error")


@pytest.mark.parametrize("bad_id", ["a/b", "", "x*"])
def test_bad_run_id_is_refused(bad_id, tmp_path):
    scn = parse_scenario(short(0.1))
    with pytest.raises(Exception, match="run id must be"):
        run_scenario(
            scn,
            RunOptions(
                out=tmp_path / "x.mcap", run_id=bad_id, external_specimen=True, ready_timeout=0.5
            ),
        )
