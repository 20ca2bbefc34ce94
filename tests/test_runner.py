"""End to end: `rths run` on the fast clock and in lockstep over zenoh between two processes;
the MCAP log read back with the plain `mcap` reader (no project code); check/report/CLI errors."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from _scenarios import short
from mcap.reader import make_reader

from rths.cli import main
from rths.config.scenario import parse_scenario
from rths.session.runner import RunOptions, run_scenario


def _plain_loop(path: Path) -> tuple[list[dict], dict[str, dict[str, str]], dict[str, int]]:
    """rths/loop messages, metadata and message counts, read with the mcap package only."""
    with open(path, "rb") as f:
        reader = make_reader(f)
        rows = [json.loads(m.data) for _, _, m in reader.iter_messages(topics=["rths/loop"])]
    with open(path, "rb") as f:
        reader = make_reader(f)
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
        summary = reader.get_summary()
        counts = {
            c.topic: summary.statistics.channel_message_counts.get(c.id, 0)
            for c in summary.channels.values()
        }
    return rows, meta, counts


@pytest.fixture(scope="module")
def fast_log(tmp_path_factory):
    path = tmp_path_factory.mktemp("fast") / "run.mcap"
    scn_path = path.with_suffix(".toml")
    scn_path.write_text(short(1.5))
    code = main(["run", str(scn_path), "--clock", "fast", "--out", str(path), "--no-progress"])
    assert code == 0
    return path


def test_fast_run_log_is_readable_without_project_code(fast_log):
    rows, meta, counts = _plain_loop(fast_log)
    n = 3072  # 1.5 s at 2048 Hz
    assert counts["rths/loop"] == n and counts["rths/specimen"] == n
    assert [r["seq"] for r in rows] == list(range(n))
    for field in ("t", "target", "command", "measured", "force"):
        assert all(isinstance(r[field], float) for r in rows), field
    assert rows[-1]["t"] == pytest.approx(1.5)
    assert meta["scaling"]["displacement"] == "0.1" and meta["scaling"]["force"] == "53.3"
    assert meta["units"]["target"] == "m" and meta["units"]["force"] == "N"
    assert "[specimen]" in meta["scenario"]["text"]
    assert meta["rths.recording"]["complete"] == "true"
    # the summary's J2 is the RMS tracking error of the rows themselves
    target = np.array([r["target"] for r in rows])
    measured = np.array([r["measured"] for r in rows])
    j2 = np.sqrt(np.mean((measured - target) ** 2) / np.mean(target**2))
    assert float(meta["rths.summary"]["j2"]) == pytest.approx(j2, rel=1e-12)


@pytest.mark.parametrize("lowlatency", [False, True], ids=["default", "lowlatency"])
def test_lockstep_over_zenoh_reproduces_the_fast_clock_exactly(
    fast_log, tmp_path, monkeypatch, lowlatency
):
    """Lockstep is deterministic: the specimen process runs the same lab, seeded the same, one
    step per command; the loop records must equal the in-process run's bit for bit -- also on
    zenoh's low-latency transport (``RTHS_ZENOH_LOWLATENCY=1``, inherited by the specimen),
    where every message must fit one batch (the link warm-up frame did not, once)."""
    if lowlatency:
        monkeypatch.setenv("RTHS_ZENOH_LOWLATENCY", "1")
    scn_path = tmp_path / "s.toml"
    scn_path.write_text(short(1.5))
    out = tmp_path / "lock.mcap"
    code = main(["run", str(scn_path), "--out", str(out), "--no-progress"])
    assert code == 0
    lock, meta, counts = _plain_loop(out)
    fast, _, _ = _plain_loop(fast_log)
    assert counts["rths/loop"] == counts["rths/specimen"] == len(fast)
    assert meta["run"]["clock"] == "lockstep"
    for name in ("target", "command", "measured", "force", "correction"):
        np.testing.assert_array_equal([r[name] for r in lock], [r[name] for r in fast], name)


def test_check_passes_and_fails_on_the_bound(fast_log, capsys):
    # the tracking error is at the LVDT noise floor (~4 um RMS) while the target grows from
    # rest (~0.1 mm RMS here), so a 10 % bound passes and a 1e-4 % bound fails
    assert main(["check", str(fast_log), "--max-rmse", "10", "--from", "0.75"]) == 0
    assert "PASS" in capsys.readouterr().out
    assert main(["check", str(fast_log), "--max-rmse", "0.0001", "--from", "0.75"]) == 1
    assert "FAIL" in capsys.readouterr().out


def test_report_writes_metrics_and_figures(fast_log, tmp_path):
    out = tmp_path / "report"
    assert main(["report", str(fast_log), "--out", str(out), "--cycles", "0.5"]) == 0
    for name in ("metrics.json", "time_history.png", "sync_subspace.png", "rths_vs_mock.png"):
        assert (out / name).stat().st_size > 1000, name
    doc = json.loads((out / "metrics.json").read_text())
    assert set(doc["mock"]) == {"model", "simplified"}
    assert doc["tracking"]["sync_rmse"] == pytest.approx(float(doc["summary"]["sync_rmse"]))


@pytest.mark.parametrize(
    "argv, match",
    [
        (["run", "no/such.toml"], "rths run: error: no/such.toml: no such file"),
        (["check", "no/such.mcap", "--max-rmse", "1"], "rths check: error:"),
        (["report", "no/such.mcap"], "rths report: error:"),
    ],
)
def test_bad_input_is_one_line_and_exit_code_2(argv, match, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(match) and err.count("\n") == 1 and "Traceback" not in err


def test_bad_scenario_value_is_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text(short(0.5).replace("rate = 2048.0", "rate = -5.0"))
    assert main(["run", str(bad), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "[run] rate: must be positive; got -5.0" in err and err.count("\n") == 1


def test_run_scenario_returns_the_outcome(tmp_path):
    scn = parse_scenario(short(0.25))
    outcome = run_scenario(scn, RunOptions(clock="fast", out=tmp_path / "r.mcap"))
    assert outcome.result.steps == 512 and outcome.recording.complete
    assert "J2" in outcome.line() and "gaps 0" in outcome.line()


def test_clipped_force_is_counted_and_reported(tmp_path):
    """A load cell too small for the specimen saturates the ADC: the run says so (one-line
    summary, an event, the summary metadata) instead of silently logging a clipped force."""
    scn = parse_scenario(short(1.0).replace("force_per_volt = 220.0", "force_per_volt = 2.0"))
    outcome = run_scenario(scn, RunOptions(clock="fast", out=tmp_path / "sat.mcap"))
    assert outcome.saturated["force"] > 100 and outcome.saturated["displacement"] == 0
    assert "SATURATED force" in outcome.line()
    with open(tmp_path / "sat.mcap", "rb") as f:
        reader = make_reader(f)
        events = [json.loads(m.data) for _, _, m in reader.iter_messages(topics=["rths/events"])]
    assert any(e["kind"] == "saturation" for e in events)


def test_seed_reaches_the_specimen_process_and_the_log(tmp_path):
    """--seed changes the lab's noise on every clock, lockstep reproduces fast with the same
    seed, and the log records the seed actually used."""
    scn = parse_scenario(short(0.25))
    fast7 = run_scenario(scn, RunOptions(clock="fast", out=tmp_path / "f7.mcap", seed=7))
    lock7 = run_scenario(scn, RunOptions(out=tmp_path / "l7.mcap", seed=7))
    fast0 = run_scenario(scn, RunOptions(clock="fast", out=tmp_path / "f0.mcap"))
    rows = {k: _plain_loop(tmp_path / f"{k}.mcap") for k in ("f7", "l7", "f0")}
    measured = {k: [r["measured"] for r in v[0]] for k, v in rows.items()}
    assert measured["f7"] == measured["l7"] != measured["f0"]
    assert rows["l7"][1]["run"]["seed"] == "7" and rows["f0"][1]["run"]["seed"] == "2019"
    assert fast7.result.steps == lock7.result.steps == fast0.result.steps


def test_check_fails_a_run_that_stopped_early_or_was_cut_off(tmp_path, capsys):
    scn_path = tmp_path / "s.toml"
    scn_path.write_text(short(1.0, **{r"^stroke = 0.05": "stroke = 1e-4"}))
    log = tmp_path / "stopped.mcap"
    assert main(["run", str(scn_path), "--clock", "fast", "--out", str(log), "--no-progress"]) == 3
    capsys.readouterr()
    assert main(["check", str(log), "--max-rmse", "1000"]) == 1
    assert "run stopped early" in capsys.readouterr().out
    cut = tmp_path / "cut.mcap"
    whole = _fast_log_bytes(tmp_path)
    cut.write_bytes(whole[: int(0.6 * len(whole))])  # a crash mid-run: loop chunks, no footer
    assert main(["check", str(cut), "--max-rmse", "1000"]) == 1
    assert "log not finished" in capsys.readouterr().out


def _fast_log_bytes(tmp_path) -> bytes:
    scn_path = tmp_path / "whole.toml"
    scn_path.write_text(short(1.0))
    log = tmp_path / "whole.mcap"
    assert main(["run", str(scn_path), "--clock", "fast", "--out", str(log), "--no-progress"]) == 0
    return log.read_bytes()


@pytest.mark.parametrize(
    "argv, match",
    [
        (["--out", "/proc/no/such/dir/x.mcap"], "rths run: error:"),
        (["--run-id", "../escape"], "run id must be"),
        (["--seed", "-5"], "seed must be an integer >= 0"),
    ],
)
def test_bad_run_options_are_one_line(argv, match, tmp_path, capsys):
    scn_path = tmp_path / "s.toml"
    scn_path.write_text(short(0.1))
    assert main(["run", str(scn_path), "--clock", "fast", "--no-progress", *argv]) == 2
    err = capsys.readouterr().err
    assert match in err and err.count("\n") == 1 and "Traceback" not in err
