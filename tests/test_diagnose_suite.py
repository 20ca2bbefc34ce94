"""rths.diagnose.suite: a case folder as one campaign task (tools/score_diagnosis.py)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from rths.campaign import Campaign, Cluster, ResultTable, Run, execute
from rths.core.errors import DataError
from rths.diagnose.data.records import write_csv
from rths.diagnose.suite import case_files, case_key, diagnose_case

NOMINAL = """[actuator]
num = [1.0]
den = [0.001, 1.0]
delay = 0.0
[specimen]
inertance = 10.0
damping = 100.0
"""


def _case(folder, records=(1, 2, 10), n=64):
    folder.mkdir()
    (folder / "NOMINAL.toml").write_text(NOMINAL)
    t = np.arange(n) / 1000.0
    for i in records:
        write_csv(folder / f"rec_{i}.csv", t, np.sin(t), np.sin(t), 10.0 * np.cos(t))
    return folder


def test_records_are_taken_in_numeric_order(tmp_path):
    case = _case(tmp_path / "c")
    assert [p.name for p in case_files(case)] == ["rec_1.csv", "rec_2.csv", "rec_10.csv"]


def test_a_folder_without_records_or_nominal_is_refused_by_name(tmp_path):
    (tmp_path / "empty").mkdir()
    with pytest.raises(DataError, match="no rec_"):
        case_files(tmp_path / "empty")
    case = _case(tmp_path / "c")
    (case / "NOMINAL.toml").unlink()
    with pytest.raises(DataError, match="no NOMINAL.toml"):
        case_files(case)


def test_the_key_follows_the_content_and_the_split(tmp_path):
    case = _case(tmp_path / "c")
    key = case_key(case, None)
    assert key.startswith("c-") and key == case_key(case, None)
    assert case_key(case, ("rec_2.csv",)) != key
    (case / "NOMINAL.toml").write_text(NOMINAL.replace("100.0", "101.0"))
    assert case_key(case, None) != key


def test_a_case_the_diagnosis_refuses_is_a_row_and_the_campaign_goes_on(tmp_path):
    """64 samples are shorter than a record may be: the task's row says why (one line), the
    campaign table holds one row per case, and a rerun skips both (resume)."""
    cases = [_case(tmp_path / name) for name in ("a", "b")]
    runs = [Run(case_key(c, None), {"case": c.name}, (str(c), None)) for c in cases]
    table = ResultTable(tmp_path / "suite.csv", flush_interval=0.0)
    stats = execute(
        Campaign("suite", runs, diagnose_case), table, Cluster(workers=1, processes=False),
        progress=False,
    )  # fmt: skip
    assert stats.ran == 2 and stats.failed == 0
    rows = table.rows([r.key for r in runs])
    assert [r["verdict"] for r in rows] == ["error", "error"]
    doc = json.loads(str(rows[0]["diagnosis"]))
    assert doc["verdict"] == "error" and "\n" not in doc["error"] and doc["error"]
    again = execute(
        Campaign("suite", runs, diagnose_case), ResultTable(tmp_path / "suite.csv"),
        Cluster(workers=1, processes=False), progress=False,
    )  # fmt: skip
    assert again.skipped == 2 and again.ran == 0
