"""The friction-damper loop reading recovers known slip force, clearance and stiffness.

Synthetic loops come from a tiny exact generator: a sine-driven displacement ``x`` acts through
a dead zone (total clearance ``gap``, optionally a weak spring ``k_gap`` inside it) on a contact
spring ``k`` in series with a Coulomb slider (limits ``+f_pos`` / ``-f_neg``), plus an offset and
white noise on the force.  The real-data check runs only when ``RTHS_DATA`` points at the folder
that holds ``friction-damper/``.
"""

from __future__ import annotations

import gzip
import json
import os
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))
import friction_damper_data as fdd
import friction_damper_loops as fdl
import friction_damper_reading as fdr
import friction_damper_to_csv as fdc

FS = 1024.0


def loops(
    *,
    f_pos: float = 10e3,
    f_neg: float = 12e3,
    gap: float = 3e-3,
    k: float = 4e6,
    k_gap: float = 0.0,
    offset: float = -100.0,
    noise: float = 80.0,
    amp: float = 20e-3,
    freq: float = 0.5,
    cycles: float = 4.0,
    x: np.ndarray | None = None,
    seed: int = 1,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(t [s], x [m], F [N])`` of the dead-zone + elasto-plastic device (module text).

    The slider position ``z`` moves only when the contact force would exceed the limit; the
    force is then the limit exactly.  ``x`` overrides the sine drive.
    """
    if x is None:
        t = np.arange(int(cycles * FS / freq) + 1) / FS
        x = amp * np.sin(2 * np.pi * freq * t)
    else:
        t = np.arange(x.size) / FS
    h, z, f = gap / 2, 0.0, np.empty(x.size)
    for i, xi in enumerate(x):
        u = xi - z
        trial = k_gap * np.clip(u, -h, h) + k * (max(u - h, 0.0) + min(u + h, 0.0))
        if trial > f_pos:
            z, trial = xi - h - (f_pos - k_gap * h) / k, f_pos
        elif trial < -f_neg:
            z, trial = xi + h + (f_neg - k_gap * h) / k, -f_neg
        f[i] = trial
    rng = np.random.default_rng(seed)
    return t, x + rng.normal(0, 1e-6, x.size), f + offset + rng.normal(0, noise, x.size)


def record(
    t: np.ndarray,
    x: np.ndarray,
    f: np.ndarray,
    name: str = "0.5Hz30lbtension1amplitude",
) -> fdd.Record:
    """A :class:`Record` of the synthetic arrays (actuator channels: ``2 (act2 - act1) = F``)."""
    kind, fr, ten, amp = fdd.parse_name(name)
    v = np.gradient(x, t)
    return fdd.Record(
        name, kind, fr, ten, amp, t, x, f, v, np.maximum(-f, 0) / 2, np.maximum(f, 0) / 2
    )


def test_sine_loops_recover_friction_clearance_and_stiffness():
    t, x, f = loops()
    r = fdr.read_record(record(t, x, f))
    s = fdr.summarize(r)
    assert s["slip_pos"]["median"] == pytest.approx(10e3 - 100, rel=0.01)
    assert s["slip_neg"]["median"] == pytest.approx(-12e3 - 100, rel=0.01)
    assert s["friction"]["median"] == pytest.approx(11e3, rel=0.01)
    assert s["centre"]["median"] == pytest.approx(-1e3 - 100, abs=150)
    assert r.f0 == pytest.approx(-100, abs=30)
    assert s["clearance_tangent"]["median"] == pytest.approx(3e-3, rel=0.03)
    # a sharp dead zone: the near-zero band reaches b / k into each contact flank
    assert s["clearance"]["median"] == pytest.approx(3e-3 + 2 * r.band / 4e6, rel=0.05)
    assert s["k_load"]["median"] == pytest.approx(4e6, rel=0.05)
    assert s["k_unload"]["median"] == pytest.approx(4e6, rel=0.05)
    assert abs(s["k_gap"]["median"]) < 0.02 * 4e6
    assert s["breakaway"]["median"] == pytest.approx(1.0, abs=0.05)
    assert s["slip_pos"]["n"] >= 3 and s["slip_neg"]["n"] >= 3 and s["clearance"]["n"] >= 6
    assert r.band == pytest.approx(0.05 * 11e3, rel=0.05)  # 5 % of the slip level


def test_soft_gap_spring_and_other_values():
    t, x, f = loops(
        f_pos=5e3,
        f_neg=5e3,
        gap=5e-3,
        k=2e6,
        k_gap=0.1e6,
        offset=50.0,
        amp=15e-3,
        freq=1.0,
        cycles=5,
    )
    s = fdr.summarize(fdr.read_record(record(t, x, f)))
    assert s["friction"]["median"] == pytest.approx(5e3, rel=0.01)
    assert s["k_gap"]["median"] == pytest.approx(0.1e6, rel=0.15)
    assert s["k_load"]["median"] == pytest.approx(2e6, rel=0.05)
    # the flank lines cross F0 at the contact points minus k_gap/k of the half gap
    assert s["clearance_tangent"]["median"] == pytest.approx(5e-3 * (1 - 0.05), rel=0.03)


def test_small_motion_inside_stick_is_not_slip():
    # +-2.5 mm: through the 3 mm gap, then 1 mm of contact = 4 kN < 10 kN: never slips
    t, x, f = loops(amp=2.5e-3)
    r = fdr.read_record(record(t, x, f))
    assert not any(h.slips for h in r.half_cycles)
    s = fdr.summarize(r)
    assert s["k_load"]["median"] == pytest.approx(4e6, rel=0.05)
    assert s["clearance_tangent"]["median"] == pytest.approx(3e-3, rel=0.05)


def test_nonstationary_drive_is_read_reversal_by_reversal():
    n = int(12 * FS)
    tt = np.arange(n) / FS
    env = np.exp(-0.5 * ((tt - 4) / 2.0) ** 2)
    drive = 18e-3 * env * np.sin(2 * np.pi * 0.9 * tt) + 4e-3 * env * np.sin(2 * np.pi * 2.3 * tt)
    t, x, f = loops(x=drive, seed=3)
    s = fdr.summarize(fdr.read_record(record(t, x, f, name="eq_Synthetic")))
    assert s["friction"]["n"] >= 2
    assert s["friction"]["median"] == pytest.approx(11e3, rel=0.02)
    assert s["k_load"]["median"] == pytest.approx(4e6, rel=0.05)
    assert s["clearance_tangent"]["median"] == pytest.approx(3e-3, rel=0.05)


def test_reversals_ignore_wiggles_below_the_hysteresis():
    x = np.concatenate(
        [
            np.linspace(0, 1, 50),
            np.linspace(1, 0.95, 5),
            np.linspace(0.95, 2, 50),
            np.linspace(2, -1, 80),
        ]
    )
    assert list(fdr.reversals(x, 0.1)) == [0, 104]
    assert list(fdr.reversals(x, 0.01)) == [0, 49, 54, 104]


def test_noise_sigma_of_white_noise():
    e = np.random.default_rng(0).normal(0, 3.0, 20000)
    assert fdr.noise_sigma(e + np.linspace(0, 50, e.size)) == pytest.approx(3.0, rel=0.05)


def test_restoring_sign_and_nominal_fits():
    t, x, f = loops()
    assert fdc.restoring_sign(record(t, x, f)) == 1
    assert fdc.restoring_sign(record(t, x, -f)) == -1
    v = fdr.velocity(x, 1 / FS)
    rec = record(t, x, 2500.0 * v)
    assert fdl.fit_nominal([rec], "viscous")[0] == pytest.approx(2500.0, rel=1e-6)
    rec = record(t, x, 700.0 * np.sign(v))
    assert fdl.fit_nominal([rec], "coulomb") == pytest.approx((700.0, 0.0), abs=1e-6)


def _write_json(folder: Path, name: str, t, x, f) -> None:
    """A record file in the published layout (inches, kip, lb)."""
    rows = np.column_stack(
        [
            t,
            x / fdd.IN_M,
            f / fdd.KIP_N,
            np.gradient(x, t) / fdd.IN_M,
            np.maximum(-f, 0) / 2 / fdd.LB_N,
            np.maximum(f, 0) / 2 / fdd.LB_N,
        ]
    )
    with gzip.open(folder / f"{name}.json.gz", "wt", encoding="utf-8") as fh:
        json.dump({"data": rows.tolist(), "dt": 1 / FS, "sampling freq": FS}, fh)


def test_command_lines_on_a_synthetic_folder(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("RTHS_DATA", raising=False)
    assert fdl.main([]) == 0 and fdc.main(["--out", str(tmp_path / "o")]) == 0
    assert capsys.readouterr().out.count("skipped: friction-damper data not found") == 2
    assert not (tmp_path / "o").exists()
    folder = tmp_path / "friction-damper"
    folder.mkdir()
    t, x, f = loops(cycles=3)
    _write_json(folder, "0.5Hz30lbtension1amplitude", t, x, f)
    _write_json(folder, "eq_Test", t, x, f)
    assert fdl.main(["--data", str(tmp_path), "--json", str(tmp_path / "r.json")]) == 0
    out = json.loads((tmp_path / "r.json").read_text())["records"]
    assert out[0]["plot_units"]["friction"]["median"] == pytest.approx(11.0, rel=0.01)  # kN
    assert out[1]["kind"] == "eq"
    monkeypatch.setenv("RTHS_DATA", str(tmp_path))
    assert fdc.main(["--out", str(tmp_path / "csv")]) == 0
    lines = (tmp_path / "csv" / "eq_Test.csv").read_text().splitlines()
    assert lines[0] == "time,command,measured,force" and len(lines) == t.size + 1
    row = [float(v) for v in lines[200].split(",")]
    assert row[1] == row[2] == pytest.approx(x[199], abs=1e-9)
    assert row[3] == pytest.approx(f[199], rel=1e-6, abs=1e-3)
    man = json.loads((tmp_path / "csv" / "manifest.json").read_text())["records"]
    assert man["0.5Hz30lbtension1amplitude"]["tension_lb"] == 30.0
    assert man["eq_Test"]["kind"] == "eq" and man["eq_Test"]["force_sign"] == 1
    capsys.readouterr()
    assert fdl.main(["--nominal", "coulomb", "--tension", "30"]) == 0
    assert "friction = " in capsys.readouterr().out
    for bad in (["--nominal", "coulomb"], ["--records", "nope"], ["--tension", "30"]):
        with pytest.raises(SystemExit) as e:
            fdl.main(bad)
        assert e.value.code == 2
        assert len(capsys.readouterr().err.strip().splitlines()) == 1


_DATA = fdd.find_data_dir(os.environ.get("RTHS_DATA")) if os.environ.get("RTHS_DATA") else None


@pytest.mark.skipif(_DATA is None, reason="RTHS_DATA does not point at the friction-damper data")
def test_real_record_reading_is_plausible():
    assert _DATA is not None
    rec = fdd.load_record(_DATA, "0.25Hz30lbtension1amplitude")
    r = fdr.read_record(rec)
    s = fdr.summarize(r)
    assert 8e3 < s["friction"]["median"] < 12e3  # ~10 kN at 30 lb (README)
    assert 3e-3 < s["clearance_tangent"]["median"] < 5e-3
    assert 2e6 < s["k_load"]["median"] < 6e6
    assert abs(r.f0) < 300.0
    assert fdc.restoring_sign(rec) == 1
    assert r.checks["force_per_act_diff"] == pytest.approx(2.0, rel=0.05)
