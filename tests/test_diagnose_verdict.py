"""End-to-end diagnosis on one small case of each source: own plants, the independent
generator (tools/truthgen), real friction-damper records.

Own plants: records of the project's emulated lab (rths.diagnose.data.synthetic: MTS-identified
TF, IMD specimen, 16-bit converters) with a mis-calibrated nominal (inertance -6 %, damping
+25 %, actuator gain +3 %) that the baseline must absorb.  These prove self-consistency only;
the independent generator (written without the diagnosis code: its own integrator, DAQ, effect
forms) and the real records are the validation.  Short records keep this file fast; the full
figures come from tools/score_diagnosis.py.
"""

from __future__ import annotations

import math
import os
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from rths.core.errors import ParameterError
from rths.diagnose import Options, diagnose, load_nominal, load_record
from rths.diagnose.data.synthetic import LabCase, band_limited_command, lab_record
from rths.diagnose.effects import EFFECTS

DT = 1.0 / 1024.0
M, C = 1589.0, 2 * 0.15 * 1589.0 * 2 * math.pi * 20.0  # zeta 0.15 at 20 Hz (S0 Eq.18 range)
TOOLS = Path(__file__).resolve().parents[1] / "tools"


def _records(case: LabCase, n: int = 2, duration: float = 6.0, seed: int = 5) -> list:
    rng = np.random.default_rng(seed)
    return [
        lab_record(
            case,
            band_limited_command(rng, duration, DT, (0.3, 6.0), 3e-3),
            DT,
            seed=k,
            name=f"run_{k}.csv",
        )
        for k in range(n)
    ]


def _nominal(case: LabCase):
    # a lab-identified nominal: within the +/-20 % the baseline re-calibrates (the emulated
    # lab's IMD shows ~9 % less damping at 1024 Hz than it holds)
    return case.nominal(0.94 * case.inertance, 1.08 * case.damping, 1.03)


def test_own_lab_friction_is_named_with_its_level_and_the_gap_shrinks():
    case = LabCase("coulomb_friction", 200.0, M, C)
    d = diagnose(_records(case), _nominal(case))
    assert d.verdict == "coulomb_friction" and d.subsystem == "specimen"
    assert [e for e, _, _ in d.effects] == ["coulomb_friction"]
    # the measured drive's noise, differentiated twice, dominates this channel's floor: 5 %
    assert d.params["friction"] == pytest.approx(200.0, rel=0.05)
    assert d.shrink > 0.8 and d.after < d.before
    assert d.identification == ["run_0.csv"] and d.held_out == ["run_1.csv"]


def test_an_effect_outside_the_candidates_is_unexplained():
    """An asymmetric spring (a force ``k2 x^2``, 30 % of the force's spread, softer on one
    side: even harmonics) is no candidate effect: every candidate is odd in the motion.  No
    model closes half of the gap -- neither in time nor, for the force channel, in its
    held-out spectrum (:mod:`rths.diagnose.search.spectral`) -- so the verdict is
    ``unexplained``, in the specimen's force channel, with its band."""
    case = LabCase("none", 0.0, M, C)
    records = []
    for r in _records(case):
        quad = r.measured**2 - np.mean(r.measured**2)
        records.append(replace(r, force=r.force + 0.3 * np.std(r.force) / np.std(quad) * quad))
    d = diagnose(records, _nominal(case))
    assert d.verdict == "unexplained" and d.subsystem == "specimen" and not d.effects
    assert d.gap_channel == "force" and d.channels["force"].evidence == "replay"
    assert d.shrink < 0.5 and d.band_hz[1] > d.band_hz[0] > 0.0


def test_own_lab_noise_and_miscalibration_only_is_none():
    case = LabCase("none", 0.0, M, C)
    d = diagnose(_records(case), _nominal(case))
    assert d.verdict == "none" and d.subsystem == "none" and d.params == {} and not d.effects
    assert d.shrink == 0.0 and d.before == d.after
    spec = d.channels["force"].baseline.baseline  # the baseline absorbed the mis-calibration
    assert spec["inertance"] == pytest.approx(M, rel=0.01)


def test_independent_generator_case_is_named_with_its_parameter(tmp_path):
    sys.path.insert(0, str(TOOLS.parent))
    from tools.truthgen.generate import build_case

    # one internal-stiffness case of the independent generator, 1000 Hz, records capped at 3 s
    ss = np.random.SeedSequence(20240611)
    label = build_case(ss, ("internal_stiffness",), [1000.0], 3.0, tmp_path / "case")
    files = sorted((tmp_path / "case").glob("rec_*.csv"))
    d = diagnose([load_record(f) for f in files], load_nominal(tmp_path / "case" / "NOMINAL.toml"))
    truth = label["effects"][0]["params"]["stiffness"]
    assert d.verdict == "internal_stiffness"
    # a series stiffness is identified from the resonance it adds: 10 % (the target)
    assert d.params["stiffness"] == pytest.approx(truth, rel=0.1)


def test_real_friction_damper_names_friction_and_backlash(tmp_path):
    sys.path.insert(0, str(TOOLS))
    from friction_damper_data import find_data_dir
    from friction_damper_data import load_record as load_fd
    from friction_damper_to_csv import columns, write_csv

    folder = find_data_dir(os.environ.get("RTHS_DATA"))
    if folder is None:
        pytest.skip("RTHS_DATA with friction-damper/ not available")
    # 30 lb band tension, 0.5 in: identify on 8 s (16 cycles) at 2 Hz, hold out 12 s (6 cycles)
    # at 0.5 Hz (the same tension, another frequency)
    for name, seconds in (("2Hz30lbtension0.5amplitude", 8), ("0.5Hz30lbtension0.5amplitude", 12)):
        table = columns(load_fd(folder, name))[0]
        write_csv(tmp_path / f"{name}.csv", table[1024 : 1024 * (seconds + 1)])
    nominal = tmp_path / "NOMINAL.toml"
    nominal.write_text(
        "[actuator]\nnum = [1.0]\nden = [1.0]\ndelay = 0.0\n"
        "[specimen]\ninertance = 0.0\ndamping = 0.0\nstiffness = 0.0\nfriction = 5000.0\n"
    )
    records = [
        load_record(tmp_path / f"{n}.csv")
        for n in ("2Hz30lbtension0.5amplitude", "0.5Hz30lbtension0.5amplitude")
    ]
    d = diagnose(records, load_nominal(nominal))
    named = {e: p for e, _, p in d.effects}
    assert {"coulomb_friction", "backlash"} <= set(named)
    # loop reading (tools/friction_damper_loops.py): friction 10.2 kN at 30 lb, tangent
    # clearance 3.5-4.1 mm (5 % band width 1.1-2.7 mm): a model, not a ruler, within ~25 %
    assert 7.5e3 < named["coulomb_friction"]["friction"] < 12.5e3
    assert 1.0e-3 < named["backlash"]["gap"] < 5.0e-3


def test_options_are_checked():
    with pytest.raises(ParameterError, match="unknown effect 'wobble'"):
        Options(effects=("wobble",))
    with pytest.raises(ParameterError, match="drive must be one of 'auto', 'measured'"):
        Options(drive="replay")
    with pytest.raises(ParameterError, match="smoothing cutoff must lie in"):
        diagnose(_records(LabCase("none")), _nominal(LabCase("none")), Options(cutoff=600.0))


def test_series_element_hints_are_the_compliance_fit_in_chain_coordinates():
    from types import SimpleNamespace

    from rths.diagnose.verdict import element_hints

    assert element_hints(None) == {}
    m, k, c = 1000.0, 4.0e6, 2.0e3  # sqrt(k/m) = 63.2 rad/s (10.07 Hz), zeta = c/(2 sqrt(k m))
    fit = SimpleNamespace(
        effects=("backlash",),
        params={"backlash": {"gap": 2e-4, "stiffness": k, "contact_damping": c}},
        baseline={"inertance": m},
    )
    other = SimpleNamespace(effects=("backlash",), params=fit.params, baseline={"inertance": -1.0})
    result = SimpleNamespace(
        candidates=[
            SimpleNamespace(fit=other, physical=True),
            SimpleNamespace(fit=fit, physical=True),
        ]
    )
    hint = element_hints(result)["backlash"]  # the unphysical inertance is skipped
    assert hint["frequency"] == pytest.approx(math.sqrt(k / m) / (2 * math.pi), rel=1e-12)
    assert hint["zeta"] == pytest.approx(c / (2 * math.sqrt(k * m)), rel=1e-12)
    assert hint["gap"] == 2e-4


def _view(significant: bool, effects: tuple[str, ...], verdict: str):
    from types import SimpleNamespace

    return SimpleNamespace(
        decomposition=SimpleNamespace(significant=significant), effects=effects, verdict=verdict
    )


def test_gap_channels_counts_a_secondary_view_only_when_an_effect_closes_its_gap():
    from rths.diagnose.verdict import gap_channels

    views = ("measured", "force")
    at_floor = {"measured": _view(False, (), "none"), "force": _view(False, (), "none")}
    # the counted views at their floor; the force-driven displacement keeps a significant
    # gap that no candidate touches: that view's model form, not an effect -> none
    channels = {**at_floor, "displacement": _view(True, (), "unexplained")}
    assert gap_channels(channels, views) == []  # type: ignore[arg-type]
    # ... but a series element that only that view shows is reported (never a false none)
    element = _view(True, ("internal_stiffness",), "internal_stiffness")
    channels = {**at_floor, "displacement": element}
    assert gap_channels(channels, views) == [element]  # type: ignore[arg-type]
    # a counted view's significant gap wins over the others; its model form does not count
    delay = _view(True, ("actuator_delay",), "actuator_delay")
    channels = {"measured": delay, "force": _view(True, (), "none"), "displacement": element}
    assert gap_channels(channels, views) == [delay]  # type: ignore[arg-type]


def test_a_displacement_view_with_no_live_held_out_force_is_left_out():
    """The force-driven ``displacement`` view scores only samples where the force is live;
    a held-out record whose force is the conditioner's noise alone (an independent
    generator's case: 80-120 N of specimen force against 43 N of noise) leaves it nothing to
    hold out.  The view is left out and the diagnosis completes (it raised a ValueError
    from an empty spectrum)."""
    from rths.diagnose.channels.build import displacement_channel

    case = LabCase("none", 0.0, M, C)
    records = _records(case)
    rng = np.random.default_rng(1)
    noise = 1e-3 * float(np.std(records[0].force)) * rng.standard_normal(records[1].force.size)
    records[1] = replace(records[1], force=noise)
    view = displacement_channel(records, _nominal(case))
    assert not any(np.any(s.held) for s in view.segments)
    d = diagnose(records, _nominal(case))
    assert "displacement" not in d.channels and {"measured", "force"} <= set(d.channels)
    assert d.verdict in (*EFFECTS, "none", "unexplained")


def test_model_form_is_a_significant_none_left_to_the_baseline_not_to_coverage():
    """``model_form`` (JSON and table): the channel's verdict is ``none`` although its gap is
    significant -- unless the records' coverage, not the model, explained it."""
    from types import SimpleNamespace

    from rths.diagnose.search.results import ChannelResult

    def result(significant: bool, verdict: str, evidence: str) -> ChannelResult:
        dec = SimpleNamespace(significant=significant)
        return ChannelResult(None, None, 0.0, dec, [], (), None, 0.0, verdict, 0.0, evidence)  # type: ignore[arg-type]

    assert result(True, "none", "replay").model_form
    assert not result(True, "none", "coverage").model_form
    assert not result(False, "none", "replay").model_form  # at the floor
    assert not result(True, "unexplained", "replay").model_form
