"""The actuator channel of the diagnosis: cross-validation folds, the orifice-law column, the
rate limit's "limit held" check, the model-form resolution, and one end-to-end delay case of a
servo-valve with the square-root flow law (``tools/servogen.py``, written without the
diagnosis code)."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from plants.lines import rate_limited
from rths.diagnose import load_nominal, load_record
from rths.diagnose.channels.channel import Channel, Segment, actuator_channel
from rths.diagnose.data.nominal import ActuatorNominal, NominalModel, SpecimenNominal
from rths.diagnose.effects import ActuatorModel
from rths.diagnose.search.identify import blocked
from rths.diagnose.search.selection import select

TOOLS = Path(__file__).resolve().parents[1] / "tools"
DT = 1.0 / 1000.0
W = 2 * math.pi * 10.0  # first-order nominal actuator, 10 Hz


def _channel(observed: list[np.ndarray], command: list[np.ndarray], flow=None) -> Channel:
    nominal = NominalModel(ActuatorNominal((W,), (1.0, W), 0.0), SpecimenNominal(0.0))
    segs = []
    for i, (y, u) in enumerate(zip(observed, command, strict=True)):
        n = y.size
        ident = np.zeros(n, bool)
        ident[50 : n - 50] = True
        signals = {
            "command": u,
            "dforce": np.zeros(n),
            "load_flow": np.zeros(n) if flow is None else flow,
        }
        segs.append(Segment(f"r{i}", i, DT, y, signals, ident, np.zeros(n, bool)))
    noise = {"measured": 1e-7, "force": 1.0, "command": 0.0}
    return Channel("measured", "actuator", segs, nominal, noise)


def test_block_folds_partition_every_record_and_exchange_roles():
    n = 1200
    ch = _channel([np.zeros(n), np.zeros(n)], [np.zeros(n), np.zeros(n)])
    a, b = blocked(ch, 0), blocked(ch, 1)
    for s, sa, sb in zip(ch.segments, a.segments, b.segments, strict=True):
        scored = s.ident | s.held
        assert np.array_equal(sa.ident | sa.held, scored)
        assert not np.any(sa.ident & sa.held)
        assert np.array_equal(sa.ident, sb.held) and np.array_equal(sa.held, sb.ident)
        assert np.any(sa.ident) and np.any(sa.held)  # every record in both roles


def test_orifice_column_is_the_loop_sensitivity_over_s():
    # T = w/(s+w): S(s)/s = 1/(s+w); a constant |v| F = q settles at q/w (exact ZOH model)
    n = 2000
    q = 3.0
    ch = _channel([np.zeros(n)], [np.zeros(n)], flow=np.full(n, q))
    col = ActuatorModel()._flow_column(ch, ch.segments[0])[:, 0]
    t = np.arange(n) * DT
    # ZOH-exact first-order step response from rest (the input applied from t_0 first seen
    # at t_1: the DAQ convention)
    expected = q / W * (1.0 - np.exp(-W * t))
    assert col[0] == 0.0
    assert col == pytest.approx(expected, rel=1e-9, abs=1e-12)


def _sine_channel(limit: float | None, sag: float = 1.0) -> tuple[Channel, ActuatorModel]:
    t = np.arange(4000) * DT
    u = 0.02 * np.sin(2 * math.pi * 1.5 * t)
    m = ActuatorModel(("rate_limit",))
    ch = _channel([np.zeros(t.size)], [u])
    y = m._linear(ch, ch.segments[0], {"shift": 0.0})
    ch.segments[0].observed = y if limit is None else rate_limited(y, sag * limit, DT)
    return ch, m


def test_rate_limit_is_held_where_the_motion_is_limited():
    # peak linear speed 0.02 * 2 pi 1.5 / |1 + j 0.15| = 0.187 m/s; limit 0.1 m/s clips
    ch, m = _sine_channel(0.1)
    assert m.physical(ch, {"rate_limit": {"velocity_limit": 0.1}})
    # a plateau sagging 5 % below the fitted limit (a valve's flow at load pressure) holds
    ch, m = _sine_channel(0.1, sag=0.95)
    assert m.physical(ch, {"rate_limit": {"velocity_limit": 0.1}})


def test_rate_limit_that_is_never_reached_is_rejected():
    # a linear attenuation (a limiter fitted to mimic it): the measured speed peaks at
    # 0.45 * 0.187 = 0.084 m/s, below the 0.1 m/s claimed
    ch, m = _sine_channel(None)
    ch.segments[0].observed = 0.45 * ch.segments[0].observed
    assert not m.physical(ch, {"rate_limit": {"velocity_limit": 0.1}})
    # and where the limiter is active the motion sags far below a claimed limit
    ch, m = _sine_channel(0.1, sag=0.7)
    assert not m.physical(ch, {"rate_limit": {"velocity_limit": 0.1}})


def test_resolution_is_a_one_sample_shift_of_a_sine():
    # mean square of A sin(w t) - A sin(w (t - dt)) is A^2 (1 - cos(w dt)) over whole periods
    # (1200 samples scored: 3 periods of 2.5 Hz at 1 kHz; the rest is rounding)
    a, f = 0.01, 2.5
    t = np.arange(1300) * DT
    p = a * np.sin(2 * math.pi * f * t)
    ch = _channel([p], [p])
    got = ActuatorModel().resolution(ch, [p])
    assert got == pytest.approx(a * a * (1.0 - math.cos(2 * math.pi * f * DT)), rel=1e-9)


def test_square_root_flow_law_with_extra_delay_names_it(tmp_path):
    sys.path.insert(0, str(TOOLS))
    from servogen import build_case

    # 1000 Hz, 3 s records keep the test short
    label = build_case(np.random.default_rng(4), "actuator_delay", tmp_path, 3.0, 1000.0)
    records = [load_record(f) for f in sorted(tmp_path.glob("rec_*.csv"))]
    nominal = load_nominal(tmp_path / "NOMINAL.toml")
    r = select(actuator_channel(records, nominal, 30.0), ("actuator_delay", "rate_limit"))
    truth = label["effects"][0]["params"]["delay"]
    assert r.verdict == "actuator_delay"
    # a delay trades against the +/-10 % pole calibration, worth 10 % of the nominal's
    # low-frequency group delay a1/a0 - b1/b0 (~1.6 ms for a 10 Hz loop), plus one sample
    # (the nominal delay's own calibration error is up to 0.4 sample)
    num, den = nominal.actuator.num, nominal.actuator.den
    lag = den[-2] / den[-1] - (num[-2] / num[-1] if len(num) > 1 else 0.0)
    found = r.final.params["actuator_delay"]["delay"]
    assert abs(found - truth) <= 0.1 * lag + 1.0 / label["rate"]
