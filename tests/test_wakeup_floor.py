"""tools/wakeup_floor.py: the C probe compiles and runs, and its summary counts what it is given."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))

from wakeup_floor import compile_probe, summarise


def test_the_summary_counts_late_wakeups_and_swallowed_steps():
    """Lateness 0.1, 0.5, 3 and 12 ms at 2048 Hz: one above 10 ms, two above 2.4 ms, three
    above 0.25 ms; 12 ms swallows floor(0.012 * 2048) = 24 steps."""
    late = np.array([100_000, 500_000, 3_000_000, 12_000_000], dtype=np.int64)
    got = summarise(late, 2048.0)
    assert got["late_over_ms"] == {"0.25": 3, "1": 2, "2.4": 2, "5": 1, "10": 1}
    assert got["max_us"] == 12_000.0 and got["max_steps"] == 24 and got["wakeups"] == 4
    # whole steps late: 0, 1 (0.5 ms = 1.02 steps), 6 (3 ms = 6.1), 24 -> 31 of 4 deadlines
    assert got["missed_pct"] == 100.0 * 31 / 4


@pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None, reason="no cc")
def test_the_probe_wakes_once_per_step_never_early(tmp_path):
    """The compiled probe prints one lateness per step, none negative (clock_nanosleep with
    TIMER_ABSTIME never returns before its deadline)."""
    exe = compile_probe(tmp_path)
    assert exe is not None
    out = subprocess.run([str(exe), "1000.0", "50", "0"], capture_output=True, text=True)
    late = np.array(out.stdout.split(), dtype=np.int64)
    assert out.returncode == 0 and late.size == 50 and late.min() >= 0


def test_the_tool_refuses_a_bad_rate_in_one_line():
    tool = Path(__file__).resolve().parents[1] / "tools" / "wakeup_floor.py"
    done = subprocess.run(
        [sys.executable, str(tool), "--rate", "0"], capture_output=True, text=True
    )
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1
