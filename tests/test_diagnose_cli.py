"""``rths diagnose`` on the command line: the JSON contract, figures and one-line errors."""

from __future__ import annotations

import json

import numpy as np
import pytest

from rths.cli import main
from rths.diagnose.data.nominal import nominal_toml
from rths.diagnose.data.records import write_csv
from rths.diagnose.data.synthetic import CLASSES, LabCase, band_limited_command, lab_record

#: 1024 Hz: at 512 Hz the emulated lab's own discretisation takes 36 % off the IMD's apparent
#: damping (9 % at 1024 Hz, 2 % at 2048 Hz, of the 6000 N s/m it holds) -- beyond the
#: +/-15 % within which the baseline re-calibrates a nominal, so the nominal the test writes
#: would no longer describe its own records.
DT = 1.0 / 1024.0


@pytest.fixture(scope="module")
def case_dir(tmp_path_factory):
    """Two short records with a 5 ms extra actuator delay and their nominal file."""
    folder = tmp_path_factory.mktemp("case")
    case = LabCase("actuator_delay", 0.005, 1589.0, 6000.0)
    rng = np.random.default_rng(2)
    for k in (1, 2):
        r = lab_record(case, band_limited_command(rng, 6.0, DT, (0.3, 5.0), 3e-3), DT, seed=k)
        write_csv(folder / f"run_{k}.csv", r.time, r.command, r.measured, r.force)
    (folder / "NOMINAL.toml").write_text(nominal_toml(case.nominal(1500.0, 6000.0, 1.0)))
    return folder


def _args(folder, *extra):
    return [
        "diagnose",
        str(folder / "run_1.csv"),
        str(folder / "run_2.csv"),
        "--nominal",
        str(folder / "NOMINAL.toml"),
        *extra,
    ]


def test_json_keys_follow_the_contract(case_dir, capsys):
    out = case_dir / "d.json"
    assert main(_args(case_dir, "--json", str(out))) == 0
    doc = json.loads(out.read_text())
    # design.md section 7: verdict, where{subsystem, band_hz, phase}, params, gap{channel,
    # before, after}, ranked candidates with held-out scores
    assert {"verdict", "where", "params", "gap", "candidates"} <= set(doc)
    assert doc["verdict"] in CLASSES and doc["verdict"] == "actuator_delay"
    assert set(doc["where"]) == {"subsystem", "band_hz", "phase"}
    assert doc["where"]["subsystem"] in ("specimen", "actuator", "none")
    assert len(doc["where"]["band_hz"]) == 2
    assert set(doc["gap"]) == {"channel", "before", "after"}
    assert set(doc["params"]) == {"delay"}
    # the +/-1-sample alignment (calibration) and the poles' lag trade against a delay: within
    # 1.5 samples of the truth
    assert doc["params"]["delay"] == pytest.approx(0.005, abs=1.5 * DT)
    names = [c["name"] for c in doc["candidates"]]
    # the actuator channel tried both its effects; the specimen channel is at its floor
    assert {"actuator_delay", "rate_limit"} <= set(names) and names[0] == "actuator_delay"
    assert [e["name"] for e in doc["effects"]] == ["actuator_delay"]
    assert doc["channels"]["measured"]["effects"][0]["name"] == "actuator_delay"
    assert doc["channels"]["force"]["verdict"] == "none"
    assert all("held_out_nrmse" in c and "closed" in c for c in doc["candidates"])
    text = capsys.readouterr().out
    assert "verdict: actuator_delay" in text and "held out" in text


def test_plots_and_quiet(case_dir, tmp_path, capsys):
    # the figures, not the selection, are under test: the delay alone is a candidate
    assert (
        main(_args(case_dir, "--plots", str(tmp_path), "--quiet", "--effects", "actuator_delay"))
        == 0
    )
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("verdict: actuator_delay")
    for name in ("residual_time", "residual_spectrum", "ranking", "overlay"):
        assert (tmp_path / f"{name}.png").stat().st_size > 1000


def _one_line_error(capsys, argv, match):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rths diagnose: error:")
    assert match in err[0]


def test_errors_are_one_line_with_exit_code_2(case_dir, tmp_path, capsys):
    _one_line_error(
        capsys,
        ["diagnose", str(case_dir / "run_1.csv"), "--nominal", str(tmp_path / "no.toml")],
        "no such file",
    )
    bad = tmp_path / "bad.toml"
    bad.write_text((case_dir / "NOMINAL.toml").read_text().replace("inertance", "inertia"))
    _one_line_error(
        capsys,
        ["diagnose", str(case_dir / "run_1.csv"), "--nominal", str(bad)],
        "[specimen] inertance: missing",
    )
    rows = np.loadtxt(case_dir / "run_1.csv", delimiter=",", skiprows=1)
    rows[100:, 0] += 0.5 * DT
    gap = tmp_path / "gap.csv"
    write_csv(gap, *rows.T)
    _one_line_error(
        capsys,
        ["diagnose", str(gap), "--nominal", str(case_dir / "NOMINAL.toml")],
        "non-uniform sampling",
    )
    _one_line_error(capsys, _args(case_dir, "--effects", "wobble"), "unknown effect 'wobble'")
    _one_line_error(capsys, _args(case_dir, "--cutoff", "600"), "smoothing cutoff must lie in")


def test_a_bad_cutoff_is_refused_before_any_identification(case_dir, capsys, monkeypatch):
    def no_selection(*args, **kwargs):
        raise AssertionError("a channel was identified before the cutoff was checked")

    monkeypatch.setattr("rths.diagnose.verdict.select", no_selection)
    _one_line_error(capsys, _args(case_dir, "--cutoff", "600"), "smoothing cutoff must lie in")


def test_non_positive_cutoff_is_one_line(tmp_path, capsys):
    from rths.cli import main

    nominal = tmp_path / "n.toml"
    nominal.write_text("[actuator]\nnum = [1.0]\nden = [0.01, 1.0]\n[specimen]\ninertance = 1.0\n")
    csv = tmp_path / "r.csv"
    csv.write_text(
        "time,command,measured,force\n"
        + "".join(f"{k / 1000},{0.0},{0.0},{0.0}\n" for k in range(3000))
    )
    assert main(["diagnose", str(csv), "--nominal", str(nominal), "--cutoff", "0"]) == 2
    err = capsys.readouterr().err
    assert "smoothing cutoff [Hz] must be positive" in err and "Traceback" not in err
