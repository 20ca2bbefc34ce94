"""The independent Hertz / Hunt-Crossley generator (tools/hertzgen.py): its contact physics."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import optimize

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))
import hertzgen


def test_hertz_contact_settles_where_the_body_spring_balances_it():
    """A drive held 300 um past a 200 um clearance against a 2 Hz body spring: the damped body
    settles where ``k y = k_c (x - y - g/2)^(3/2)`` (root found independently)."""
    m, k = 100.0, 100.0 * (2 * math.pi * 2.0) ** 2
    spec = {"mass": m, "damping": 2 * 0.7 * math.sqrt(k * m), "stiffness": k}
    elem = {"kind": "backlash", "gap": 200e-6, "k": 1e9, "n": 1.5, "alpha": 20.0}
    x0, h = 400e-6, 1e-4
    force = hertzgen._body(np.full(40000, x0), h, spec, elem)  # 4 s: settled

    def balance(y):
        return k * y - elem["k"] * max(x0 - y - 100e-6, 0.0) ** 1.5

    y = optimize.brentq(balance, 0.0, x0)
    assert force[-1] == pytest.approx(k * y, rel=1e-6)


def test_a_backlash_case_is_written_with_its_labels(tmp_path):
    label = hertzgen.build_case(np.random.SeedSequence(3), "backlash", tmp_path / "c", 3.0)
    (effect,) = label["effects"]
    assert effect["effect"] == "backlash"
    assert 200e-6 <= effect["params"]["gap"] <= 460e-6
    files = sorted(p.name for p in (tmp_path / "c").iterdir())
    assert files == ["NOMINAL.toml", "rec_1.csv", "rec_2.csv", "rec_3.csv"]
    head = (tmp_path / "c" / "rec_1.csv").read_text().splitlines()[0]
    assert head == "time,command,measured,force"
    json.dumps(label)  # serialisable
