"""Scenario files: the shipped ones parse; every bad key, type or value is one ConfigError that
names the file, the table and the key; builders name the table a plant rejected."""

from __future__ import annotations

from pathlib import Path

import pytest
from _scenarios import SEED, seed_text

from rths.config import build
from rths.config.scenario import load_scenario, parse_scenario
from rths.core.errors import ConfigError

SCENARIOS = sorted(
    p
    for p in (Path(__file__).resolve().parent.parent / "scenarios").glob("*.toml")
    if "[substructure]" in p.read_text()  # RTHS scenarios (rths sweep files have their own schema)
)


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: p.name)
def test_shipped_scenarios_parse(path):
    scn = load_scenario(path)
    assert scn.run.steps >= 1 and scn.run.dt > 0


def test_seed_scenario_realises_the_seed_normalised_inertance():
    """S0 §5.3: realised m_e = 0.529 (S0 Eq.23; for a string m_e = m̄_e/(mL))."""
    scn = load_scenario(SEED)
    s = scn.substructure.options
    m_bar = scn.scaling.impedance * scn.model.inertance
    assert m_bar / (s.mass_per_length * s.length) == pytest.approx(0.529, abs=0.001)
    assert s.damper_position == 0.02 and s.load.mode == 3


@pytest.mark.parametrize(
    "pattern, replacement, match",
    [
        (r"^rate = 2048.0.*$", 'rate = "fast"', r"\[run\] rate: must be a number"),
        (r'^clock = "lockstep".*$', 'clock = "sometimes"', r"\[run\] clock: must be one of"),
        (r"^duration = 20.0.*$", "duration = -1.0", r"\[run\] duration: must be positive"),
        (r"^tension = 5.0e6.*$", "tension = 5.0e6\ntensoin = 1.0", r"tensoin: unknown key"),
        (
            r"^damper_position = 0.02.*$",
            "damper_position = 1.5",
            r"\[substructure\] damper_position must lie in \[1e-06, 0.999999\]; got 1.5",
        ),
        (
            r'^elements = "auto".*$',
            "elements = 1",
            r'\[substructure\] elements must be an integer >= 2 or "auto"; got 1',
        ),
        (r"^mode = 3.*$", "mode = 0", r"\[substructure.load\] mode must be >= 1; got 0"),
        (r'^kind = "imd".*$', 'kind = "sponge"', r"\[specimen\] kind: must be one of"),
        (
            r'^preset = "mts_identified".*$',
            "num = [1.0]",
            r"\[actuator\] num/den: give both num and den, or a preset",
        ),
        (
            r'^preset = "type_ii".*$',
            'preset = "type_iii"',
            r"\[specimen\] preset: must be one of 'eimd_full', 'eimd_small', 'type_i', 'type_ii'",
        ),
        (
            r'^preset = "mts_identified".*$',
            'preset = "moog"',
            r"\[actuator\] preset: must be one of 'mts_identified'; got 'moog'",
        ),
        (
            r'^kind = "ff_lqg".*$',
            'kind = "magic"',
            r"\[compensator\] kind: must be one of .*'ff_lqg'",
        ),
        (
            r'^preset = "type_ii".*$',
            'preset = "type_ii"\nmass = 3.0',
            r"\[specimen\] mass: unknown key; expected one of .*'inertance'",
        ),
        (
            r"^damping_ratio = 0.038.*$",
            "damping_ratio = 0.038\ndamping = 1.0",
            r"\[model\] damping_ratio: give damping or damping_ratio",
        ),
        (
            r"^correction_filter = 60.0.*$",
            "correction_filter = 5000.0",
            r"\[loop\] correction_filter: must lie below the Nyquist frequency 1024 Hz",
        ),
        (r"^\[loop\]", "[lop]", r"\[top level\] lop: unknown key"),
    ],
)
def test_bad_values_name_file_table_and_key(pattern, replacement, match):
    with pytest.raises(ConfigError, match=r"^bad\.toml: .*" + match):
        parse_scenario(seed_text(**{pattern: replacement}), "bad.toml")


def test_missing_section_and_missing_file(tmp_path):
    with pytest.raises(ConfigError, match=r"\[top level\] specimen: missing \(required\)"):
        parse_scenario(
            "[run]\nname='x'\nduration=1.0\nrate=100.0\n[substructure]\nkind='cable'\n"
            "length=1.0\ntension=1.0\nmass_per_length=1.0\ndamper_position=0.5\n",
            "x.toml",
        )
    with pytest.raises(ConfigError, match="no such file"):
        load_scenario(tmp_path / "none.toml")


@pytest.mark.parametrize(
    "pattern, replacement, match",
    [
        (
            r"^mode = 3 .*$",
            "mode = 3\nfrequency = 5000.0",
            r"\[substructure\] load frequency 5000 Hz \(mode 3\) must lie below the Nyquist",
        ),
    ],
)
def test_builders_name_the_table_a_plant_rejected(pattern, replacement, match):
    """What a plant can check only once built (here: against the loop rate) names the table."""
    scn = parse_scenario(seed_text(**{pattern: replacement}), "bad.toml")
    with pytest.raises(ConfigError, match=r"^bad\.toml: " + match):
        build.substructure(scn)


def test_an_unstable_actuator_is_refused_with_the_scenario():
    with pytest.raises(ConfigError, match=r"^bad\.toml: \[actuator\] .*unstable: poles .*2\+0j"):
        parse_scenario(
            seed_text(**{r'^preset = "mts_identified".*$': "num = [1.0]\nden = [1.0, -2.0]"}),
            "bad.toml",
        )


def test_auto_mesh_resolves_the_internal_stiffness():
    """elements = "auto": the damper node radiates at the device's local frequency, element
    size below 4 T / k_s (prototype series stiffness = impedance factor x 1.2e7 N/m)."""
    scn = load_scenario(SEED)
    cable = build.substructure(scn)
    h = cable.positions[cable.damper_index] - cable.positions[cable.damper_index - 1]
    assert h < 4 * scn.substructure.options.tension / (scn.scaling.impedance * 1.2e7)


@pytest.mark.parametrize(
    ("rate", "steps"), [(256.0, 5), (1000.0, 10), (1024.0, 11), (2048.0, 21), (4096.0, 41)]
)
def test_the_default_watchdogs_are_ten_and_twenty_milliseconds(rate, steps):
    """Without ``[loop] max_lag`` the measurement watchdog allows 10 ms of steps rounded up
    (``ceil(0.010 * rate)``), never fewer than 5; the specimen's command watchdog defaults to
    20 ms.  A given ``max_lag`` is taken as is."""
    scn = parse_scenario(seed_text(**{r"^rate = 2048.0.*$": f"rate = {rate!r}"}), "s.toml")
    assert scn.loop.max_lag == steps
    if steps > 5:  # the fewest steps that span 10 ms
        assert steps * scn.run.dt >= 0.010 > (steps - 1) * scn.run.dt
    assert scn.loop.command_timeout == 0.020
    given = seed_text(**{r"^\[loop\]": "[loop]\nmax_lag = 3\ncommand_timeout = 0.05"})
    loop = parse_scenario(given, "s.toml").loop
    assert (loop.max_lag, loop.command_timeout) == (3, 0.05)
