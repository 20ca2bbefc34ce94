"""Records and NOMINAL.toml of the diagnosis: reading, round trips and every validation branch."""

from __future__ import annotations

import math

import numpy as np
import pytest

from plants.actuator import MTS_IDENTIFIED
from rths.core.errors import ConfigError, DataError, ParameterError
from rths.diagnose.data.nominal import (
    ActuatorNominal,
    NominalModel,
    SpecimenNominal,
    load_nominal,
    nominal_toml,
    parse_nominal,
)
from rths.diagnose.data.records import MIN_DURATION, load_record, read_csv, write_csv

DT = 1.0 / 256.0


def _columns(n: int = 1024) -> tuple[np.ndarray, ...]:
    t = DT * np.arange(1, n + 1)
    u = 1e-3 * np.sin(2 * math.pi * 2.0 * t)
    return t, u, 0.98 * u, 1500.0 * u


def test_csv_round_trip_is_lossless(tmp_path):
    t, u, x, f = _columns()
    write_csv(tmp_path / "r.csv", t, u, x, f)
    r = load_record(tmp_path / "r.csv")
    # %.17g round-trips float64 exactly
    assert np.array_equal(r.measured, x) and np.array_equal(r.force, f)
    assert r.dt == pytest.approx(DT, rel=1e-12)  # median of exact steps
    assert (r.name, r.n, r.target) == ("r.csv", 1024, None)


def test_csv_columns_in_any_order_extra_ignored(tmp_path):
    t, u, x, f = _columns()
    rows = np.column_stack([f, x, t, u, t * 0])
    np.savetxt(
        tmp_path / "r.csv", rows, delimiter=",", header="force,measured,time,command,x", comments=""
    )
    r = read_csv(tmp_path / "r.csv")
    assert np.allclose(r.command, u, atol=1e-15)  # %.18e default format, float64 exact


def _write(path, text):
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("", "empty file"),
        ("time,command,force\n0,1,2\n", "missing column 'measured'"),
        ("time,command,measured,force\n0.1,0,0,0\n0.2,0,abc,0\n", "line 3: column 'measured' is"),
        ("time,command,measured,force\n0.1,0,0\n", "line 2: missing column 'force'"),
        (
            "time,command,measured,force\n0.1,0,0,0\n0.2,0,0,nan\n0.3,0,0,0\n",
            "column 'force' must be finite; got nan at sample 1",
        ),
        ("time,command,measured,force\n0.1,0,0,0\n0.2,0,0,0\n", "at least 3 samples; got 2"),
        ("time,command,measured,force\n0.3,0,0,0\n0.2,0,0,0\n0.1,0,0,0\n", "must increase"),
    ],
)
def test_csv_errors_name_file_column_and_value(tmp_path, text, match):
    p = _write(tmp_path / "bad.csv", text)
    with pytest.raises(DataError, match=match):
        read_csv(p)


def test_non_uniform_sampling_is_rejected_with_the_sample(tmp_path):
    t, u, x, f = _columns()
    t = t.copy()
    t[600:] += DT  # a dropped sample: one step of 2 dt
    write_csv(tmp_path / "gap.csv", t, u, x, f)
    with pytest.raises(DataError, match=r"gap.csv: non-uniform sampling: .* samples 599 and 600"):
        read_csv(tmp_path / "gap.csv")


def test_short_record_and_missing_file(tmp_path):
    t, u, x, f = _columns(int(MIN_DURATION / DT) - 1)
    write_csv(tmp_path / "short.csv", t, u, x, f)
    with pytest.raises(DataError, match="record too short for a diagnosis"):
        read_csv(tmp_path / "short.csv")
    with pytest.raises(DataError, match="cannot open data file"):
        load_record(tmp_path / "none.csv")
    with pytest.raises(DataError, match="cannot open CSV record"):
        read_csv(tmp_path / "none.csv")


def test_write_csv_rejects_bad_columns(tmp_path):
    t, u, x, f = _columns()
    with pytest.raises(DataError, match="non-finite values"):
        write_csv(tmp_path / "x.csv", t, u, x * np.nan, f)
    with pytest.raises(DataError, match="four equal 1-D columns"):
        write_csv(tmp_path / "x.csv", np.ones((3, 2)), u[:3], x[:3], f[:3])


def test_mcap_log_is_read_from_rths_loop(tmp_path):
    from rths.log.recorder import LOOP_TOPIC, Recorder

    t, u, x, f = _columns()
    path = tmp_path / "run.mcap"
    with Recorder(path, metadata={"scenario": {"text": "not used here"}}) as rec:
        for k in range(t.size):
            rec.put(
                LOOP_TOPIC,
                k,
                int(round(t[k] * 1e9)),
                {"t": t[k], "target": u[k], "command": u[k], "measured": x[k], "force": f[k]},
            )
    r = load_record(path)
    # DAQ convention: row k = the command applied from t_k and the measurements at t_k, i.e. the
    # previous log row's (the loop logs a command with the state at the end of its hold)
    assert np.array_equal(r.command, u) and r.time[0] == pytest.approx(t[0] - DT)
    assert np.allclose(r.force[1:], f[:-1]) and r.force[0] == 0.0  # JSON keeps float64 repr
    assert np.allclose(r.measured[1:], x[:-1]) and np.allclose(r.target[1:], u[:-1])
    assert r.scenario_text == "not used here"
    assert r.dt == pytest.approx(DT)


NOMINAL = """
[actuator]
num = [4.6667e6]
den = [1.0, 478.08, 1.2307e5, 4.6009e6]
delay = 0.002
[specimen]
inertance = 1589.0
damping = 5970.0
"""


def test_nominal_defaults_and_round_trip(tmp_path):
    n = parse_nominal(NOMINAL, "n.toml")
    assert n.specimen == SpecimenNominal(1589.0, 5970.0, 0.0, 0.0)
    assert n.actuator.delay == 0.002 and n.actuator.dc_gain == pytest.approx(4.6667 / 4.6009)
    model = NominalModel(
        ActuatorNominal(MTS_IDENTIFIED.num, MTS_IDENTIFIED.den, 0.01),
        SpecimenNominal(10.0, 2.0, -3.0, 4.0),
    )
    (tmp_path / "m.toml").write_text(nominal_toml(model, "a comment\nover two lines"))
    back = load_nominal(tmp_path / "m.toml")
    assert (back.actuator, back.specimen) == (model.actuator, model.specimen)  # repr() exact


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (lambda s: s.replace("[specimen]", "[specimens]"), r"\[top level\] specimen: missing"),
        (lambda s: s + "extra = 1\n", r"\[specimen\] extra: unknown key"),
        (
            lambda s: s.replace("inertance = 1589.0", "inertance = -1.0"),
            r"\[specimen\] inertance: must be non-negative; got -1.0",
        ),
        (lambda s: s.replace("delay = 0.002", "delay = -0.1"), r"delay: must be non-negative"),
        (
            lambda s: s.replace("num = [4.6667e6]", "num = [1, 2, 3, 4, 5]"),
            r"num: transfer function must be proper",
        ),
        (lambda s: s.replace("478.08", "-478.08"), r"den: transfer function must be stable"),
        (lambda s: s.replace("den = [1.0,", "den = [0.0,"), r"den: leading coefficient"),
        (lambda s: s.replace("num = [4.6667e6]", "num = [0.0]"), r"num: must not be all zero"),
        (lambda s: s.replace("num = [4.6667e6]", "num = 'x'"), r"num: must be a list"),
        (lambda s: s.replace("damping = 5970.0", "damping = true"), r"damping: must be a number"),
        (lambda s: s + "[other]\n", r"\[top level\] other: unknown key"),
        (lambda s: s.replace("[actuator]", "[actuator"), r"invalid TOML"),
    ],
)
def test_nominal_errors_name_file_key_and_value(edit, match):
    with pytest.raises(ConfigError, match=match):
        parse_nominal(edit(NOMINAL), "n.toml")


def test_nominal_file_errors(tmp_path):
    with pytest.raises(ConfigError, match="no such file"):
        load_nominal(tmp_path / "missing.toml")
    bad = NominalModel(ActuatorNominal((1.0,), (1.0,), 0.0), SpecimenNominal(-1.0))
    with pytest.raises(ParameterError, match="nominal inertance must be non-negative"):
        nominal_toml(bad)


def test_structure_channel_explains_why_it_is_missing(tmp_path):
    from rths.diagnose.data.records import Record
    from rths.diagnose.structure import structure_gap

    t, u, x, f = _columns()
    csv = Record("a.csv", DT, t, u, x, f)
    bad = Record("b.mcap", DT, t, u, x, f, target=u, scenario_text="[run]\nname = 3\n")
    gap = structure_gap([csv, bad])
    assert gap.records == {}
    assert "no target/scenario" in gap.notes["a.csv"]
    assert gap.notes["b.mcap"].startswith("numerical run unavailable: ")  # bad scenario text
    assert gap.to_dict() == {"nrmse": {}, "notes": gap.notes}
