"""``rths damping``: table and JSON output, physical vs normalised input, one-line errors."""

import json
import math
import re

import pytest

from plants.cable.frequency_equation import exact_roots
from plants.cable.model import CableProperties, normalised_stiffness, physical_damper
from rths.cli import main

SEED_ARGS = [
    "damping",
    "--mode",
    "3",
    "--xd",
    "0.02",
    "--me",
    "0.53",
    "--cd",
    "0.75",
    "--elements",
    "200",
]


def run_json(capsys, argv):
    assert main([*argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_json_output_for_the_seed_imd_point(capsys):
    doc = run_json(capsys, SEED_ARGS)
    assert {"mode", "xd", "me", "cd", "roots"} <= doc.keys()
    assert (doc["mode"], doc["xd"], doc["me"], doc["cd"]) == (3, 0.02, 0.53, 0.75)
    exact = [r for r in doc["roots"] if r["method"] == "exact"]
    fe = [r for r in doc["roots"] if r["method"] == "fe"]
    assert len(exact) == len(fe) == 2
    assert [r["zeta"] for r in exact] == pytest.approx(
        [0.0905, 0.0878], rel=1e-3
    )  # values quoted to 3 figures
    assert [r["zeta"] for r in fe] == pytest.approx(
        [0.0905, 0.0878], rel=2e-2
    )  # FE at 200 elements: ~0.3 %
    assert exact[0]["beta"] == pytest.approx([9.46092, 0.85996], abs=1e-5)  # quoted to 6 figures
    for r in doc["roots"]:
        assert r["zeta"] == pytest.approx(
            r["beta"][1] / math.hypot(*r["beta"]), rel=1e-12
        )  # definition
        assert r["freq_ratio"] == pytest.approx(math.hypot(*r["beta"]) / (3 * math.pi), rel=1e-12)


def test_table_output_shows_exact_and_fe_side_by_side(capsys):
    assert (
        main(["damping", "--mode", "1", "--xd", "0.02", "--cd", str(1 / (math.pi**2 * 0.02))]) == 0
    )
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("cable-damper modes near mode 1")
    exact = next(line for line in lines if line.startswith("exact"))
    fe = next(line for line in lines if line.startswith("fe/400"))
    assert float(exact.split()[-2]) / 0.02 == pytest.approx(0.51057, rel=1e-3)  # 6 decimals printed
    assert float(fe.split()[-2]) == pytest.approx(
        float(exact.split()[-2]), rel=1e-3
    )  # FE 400: ~1e-7
    assert lines[-1].startswith("asymptotic small-damper zeta: 0.010000")  # kappa = 1 -> x_d/2


def test_physical_input_is_normalised_with_eq23(capsys):
    cable = CableProperties(length=120.0, tension=3.0e6, mass_per_length=60.0)
    inertance, damping = physical_damper(cable, 0.53, 0.75)
    physical = [
        "damping",
        "--mode",
        "3",
        "--xd",
        "0.02",
        "--length",
        "120",
        "--tension",
        "3e6",
        "--mass-per-length",
        "60",
        "--inertance",
        repr(inertance),
        "--damping",
        repr(damping),
        "--elements",
        "200",
    ]
    a = run_json(capsys, physical)
    b = run_json(capsys, SEED_ARGS)
    assert (a["me"], a["cd"]) == pytest.approx((0.53, 0.75), rel=1e-12)  # round trip of Eq.23
    flat = lambda doc: [x for r in doc["roots"] for x in r["beta"]]
    assert flat(a) == pytest.approx(flat(b), rel=1e-9)  # Eq.23 round-off through Newton / ARPACK


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--xd", "1.2", "--cd", "1"], r"damper position x_d must lie in \(0, 1\); got 1.2"),
        (["--xd", "0.02", "--me", "-1"], "normalised inertance m_e must be non-negative; got -1.0"),
        (["--xd", "0.02", "--cd", "-2"], "normalised damping c_d must be non-negative; got -2.0"),
        (["--xd", "0.02", "--cd", "1", "--length", "3"], "either normalised .* not both"),
        (["--xd", "0.02"], "no damper given"),
        (
            ["--xd", "0.02", "--length", "3", "--damping", "4"],
            "also needs --tension, --mass-per-length",
        ),
        (
            [
                "--xd",
                "0.02",
                "--length",
                "3",
                "--tension",
                "-1",
                "--mass-per-length",
                "1",
                "--damping",
                "4",
            ],
            "cable tension T must be positive; got -1.0",
        ),
        (
            [
                "--xd",
                "0.02",
                "--length",
                "3",
                "--tension",
                "1",
                "--mass-per-length",
                "1",
                "--inertance",
                "-4",
            ],
            "damper inertance must be non-negative; got -4.0",
        ),
        (
            ["--xd", "0.02", "--cd", "1", "--elements", "1"],
            r"number of elements must lie in \[2, 100000\]; got 1",
        ),
        (["--xd", "0.02", "--me", "0.5", "--stiffness", "1e7"], "either normalised .* not both"),
        (["--xd", "0.02", "--ke", "10", "--length", "3"], "either normalised .* not both"),
        (
            ["--xd", "0.02", "--me", "0.5", "--ke", "-1"],
            "normalised series stiffness k_e must be positive; got -1.0",
        ),
        (
            ["--xd", "0.02", "--ke", "10"],
            "a series stiffness needs m_e or c_d > 0 behind it; got k_e=10.0",
        ),
        (
            [
                "--xd",
                "0.02",
                "--length",
                "3",
                "--tension",
                "1",
                "--mass-per-length",
                "1",
                "--inertance",
                "4",
                "--stiffness",
                "-5",
            ],
            "series stiffness must be positive; got -5.0",
        ),
    ],
)
def test_bad_input_is_one_line_and_exit_code_2(capsys, extra, message):
    assert main(["damping", "--mode", "3", *extra]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    err = captured.err.strip()
    assert "\n" not in err and "Traceback" not in err
    assert err.startswith("rths damping: error: ")
    assert re.search(message, err)


def test_bad_mode_is_rejected(capsys):
    assert main(["damping", "--mode", "0", "--xd", "0.02", "--cd", "1"]) == 2
    assert "mode number n must be a positive integer; got 0" in capsys.readouterr().err


SEED_PHYSICAL = [
    "damping", "--mode", "3", "--xd", "0.02", "--length", "200", "--tension", "5e6", "--mass-per-length", "80",
    "--inertance", "8480", "--damping", repr(0.75 * math.pi * math.sqrt(5e6 * 80)), "--stiffness", "6.4e7",
]  # fmt: skip  # brief's seed point: m_e = 0.53, c_d x_d = 0.015, Type II stiffness at prototype scale


def test_physical_series_stiffness_is_normalised_and_solved(capsys):
    doc = run_json(capsys, SEED_PHYSICAL)
    k_e = normalised_stiffness(CableProperties(200.0, 5e6, 80.0), 6.4e7)
    assert (doc["me"], doc["cd"], doc["ke"]) == pytest.approx(
        (0.53, 0.75, k_e), rel=1e-12
    )  # Eq.23 round-off
    assert doc["device_beta"] == pytest.approx(math.pi * math.sqrt(k_e / 0.53), rel=1e-12)
    exact = [r for r in doc["roots"] if r["method"] == "exact"]
    fe = [r for r in doc["roots"] if r["method"] == "fe"]
    expected = exact_roots(3, 0.02, 0.53, 0.75, k_e=k_e)
    assert [complex(*r["beta"]) for r in exact] == pytest.approx(
        [r.beta for r in expected], rel=1e-10
    )  # Newton
    assert [r["zeta"] for r in fe] == pytest.approx(
        [r.zeta for r in expected], rel=2e-2
    )  # brief: 2 % at 400
    normalised = run_json(
        capsys,
        [
            "damping",
            "--mode",
            "3",
            "--xd",
            "0.02",
            "--me",
            "0.53",
            "--cd",
            "0.75",
            "--ke",
            repr(k_e),
        ],
    )
    flat = lambda d: [x for r in d["roots"] for x in r["beta"]]
    assert flat(normalised) == pytest.approx(
        flat(doc), rel=1e-9
    )  # Eq.23 round-off through Newton / ARPACK


def test_table_reports_the_series_stiffness_and_the_device_mode(capsys):
    assert main(SEED_PHYSICAL) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].endswith("series k_e = 259.382 (S0 Eq.12)")
    assert any(
        line.startswith("device's own mode (node held): beta = 69.4996 (~ mode 22.12), outside")
        for line in lines
    )
    argv = [
        "damping",
        "--mode",
        "22",
        "--xd",
        "0.02",
        "--me",
        "0.53",
        "--cd",
        "0.75",
        "--ke",
        "259.382",
        "--elements",
        "200",
    ]
    assert main(argv) == 0
    assert "inside this window" in capsys.readouterr().out
    assert main(["damping", "--mode", "1", "--xd", "0.02", "--cd", "5", "--ke", "3", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert (
        doc["device_beta"] is None and doc["ke"] == 3.0
    )  # no inertance behind the spring: no device mode
    assert main(["damping", "--mode", "1", "--xd", "0.02", "--cd", "5", "--ke", "3"]) == 0
    assert "the device has no oscillating mode of its own" in capsys.readouterr().out
