"""tools/score_diagnosis.py: the scoring rules on hand-made labels and diagnoses."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))
from score_diagnosis import main, residual_shrink, score_case, summarize


def _label(*effects: tuple[str, dict]) -> dict:
    return {"effects": [{"effect": e, "channel": "specimen", "params": p} for e, p in effects]}


def _result(verdict: str, *effects: tuple[str, dict], seconds: float = 1.0) -> dict:
    return {
        "verdict": verdict,
        "effects": [{"name": e, "params": p} for e, p in effects],
        "shrink": 0.9,
        "seconds": seconds,
    }


def test_combined_case_is_scored_both_ways_and_parameters_relative():
    label = _label(("coulomb_friction", {"friction": 100.0}), ("backlash", {"gap": 1e-3}))
    # the verdict is the second labelled effect: top-1 'any' but not 'strict'; full set right
    s = score_case(
        label,
        _result("backlash", ("backlash", {"gap": 1.2e-3}), ("coulomb_friction", {"friction": 95})),
    )
    assert s["top1_any"] and not s["top1_strict"] and s["full_set"] and s["combined"]
    assert s["errors"] == pytest.approx({"backlash": 0.2, "coulomb_friction": 0.05})
    missing = score_case(label, _result("backlash", ("backlash", {"gap": 1e-3})))
    assert missing["top1_any"] and not missing["full_set"]


def test_none_and_unexplained_rates():
    none = score_case(_label(("none", {})), _result("none"))
    assert none["top1_strict"] and none["full_set"] and not none["false_none"]
    false_none = score_case(_label(("rate_limit", {"velocity_limit": 0.1})), _result("none"))
    unexplained = score_case(_label(("none", {})), _result("unexplained"))
    assert false_none["false_none"] and unexplained["false_unexplained"]
    summary = summarize({"a": none, "b": false_none, "c": unexplained})
    assert summary["top1_strict"] == pytest.approx(1 / 3)
    assert summary["false_none"] == 1.0  # of the one case with an effect
    assert summary["false_unexplained"] == pytest.approx(1 / 3)
    assert summary["confusion"] == {
        "none -> none": 1,
        "none -> unexplained": 1,
        "rate_limit -> none": 1,
    }


def test_residual_shrink_credits_no_floor():
    """``(J_0 - J_S)/(J_0 - N_0)`` from NRMSEs: baseline 0.5, after 0.3, floor 0.1 give
    (0.25 - 0.09)/(0.25 - 0.01) = 2/3; no effect named, or a channel at its floor: None."""
    channel = {"baseline_nrmse": 0.5, "after_nrmse": 0.3, "floor_nrmse": 0.1}
    result = {
        **_result("backlash", ("backlash", {"gap": 1e-3})),
        "gap": {"channel": "force"},
        "channels": {"force": channel},
    }
    assert residual_shrink(result) == pytest.approx(2 / 3, rel=1e-12)
    assert residual_shrink({**result, "effects": []}) is None
    at_floor = {**channel, "floor_nrmse": 0.5}
    assert residual_shrink({**result, "channels": {"force": at_floor}}) is None
    assert residual_shrink(_result("none")) is None


def test_real_data_commands_skip_cleanly_without_data(monkeypatch, capsys):
    monkeypatch.delenv("RTHS_DATA", raising=False)
    assert main(["friction-damper", "--data", "/nonexistent"]) == 0
    assert capsys.readouterr().out.startswith("skipped")


def test_a_table_of_an_unknown_format_is_one_line_and_exit_2(tmp_path, capsys):
    (tmp_path / "labels.json").write_text("{}")
    with pytest.raises(SystemExit) as e:
        main(["suite", str(tmp_path), "--table", str(tmp_path / "t.table")])
    assert e.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--table must end in .parquet or .csv" in err[0]


def test_an_unreadable_mts_record_is_one_line_and_exit_2(tmp_path, capsys):
    (tmp_path / "friction-damper").mkdir()
    (tmp_path / "friction-damper" / "r.json.gz").write_bytes(b"")
    (tmp_path / "mts-actuator").mkdir()
    (tmp_path / "mts-actuator" / "0A.txt").write_text("not a logger file\n")
    assert main(["mts", "--data", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "0A.txt failed" in err[0], err
