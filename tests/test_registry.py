"""The registries of kinds: every registered kind builds from a minimal scenario and runs; the
README's table of kinds is what ``rths kinds --markdown`` prints; the README's toy damper is the
whole diff a new damper model needs; option tables are validated key by key."""

from __future__ import annotations

import math
import re
import subprocess
import sys
import types
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np
import pytest

from rths.config import build
from rths.config.kinds import load_kinds, registry
from rths.config.options import describe_options, parse_options
from rths.config.scenario import parse_scenario
from rths.config.toml import parse_toml
from rths.core.channels import RowBlock
from rths.core.errors import ConfigError
from rths.core.registry import FAMILIES, SPECIMENS, Registry
from rths.runtime.loop import InProcessLink, Loop

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"

# A minimal component table per kind that has required keys; every other kind is built from
# its defaults.  A new kind with required keys fails test_every_kind_builds_and_runs until its
# minimal table is added here (with its tests).
MINIMAL = {
    ("substructure", "cable"): "length = 20.0\ntension = 5.0e4\nmass_per_length = 8.0\n"
    "damper_position = 0.05\nelements = 20\n[substructure.load]\namplitude = 20.0\nmode = 1\n",
    ("substructure", "tmdi"): 'mass = "IM"\nflywheel = "IF"\n[substructure.excitation]\n'
    "pga = 0.1\nfrequencies = [2.0]\ncycles = 2\n",
    ("specimen", "imd"): 'preset = "type_ii"\n',
    ("specimen", "imd_internal"): 'preset = "type_ii"\n',
    ("specimen", "imd_simplified"): "inertance = 100.0\ndamping = 50.0\n",
    ("specimen", "hdrb"): 'preset = "s1_primary_uncontrolled"\n',
    ("actuator", "transfer_function"): 'preset = "mts_identified"\n',
    ("actuator", "servo_hydraulic"): 'preset = "heavy_inertial_load"\n',
    ("substructure", "vrths_frame"): 'ground_motion = "chirp"\n',
}
DEFAULTS = {  # the companions of the kind under test
    "substructure": "cable",
    "specimen": "linear",
    "actuator": "transfer_function",
    "compensator": "none",
}


def scenario_text(**kinds: str) -> str:
    chosen = DEFAULTS | kinds
    parts = [
        '[run]\nname = "kind"\nduration = 0.05\nrate = 1024.0\nclock = "fast"\n',
        '[lab]\nbits = 24\nfull_scale = 10.0\n[model]\nkind = "none"\n'
        "[loop]\ncorrection_filter = 0.0\n",
    ]
    for family, kind in chosen.items():
        parts.append(f'[{family}]\nkind = "{kind}"\n' + MINIMAL.get((family, kind), ""))
    return "\n".join(parts)


def all_kinds() -> list[tuple[str, str]]:
    load_kinds()
    return [(family, name) for family, reg in FAMILIES.items() for name in reg.names()]


@pytest.mark.parametrize(("family", "kind"), all_kinds(), ids=lambda x: str(x))
def test_every_kind_builds_and_runs(family, kind):
    """Each registered kind parses from a minimal table, builds, and runs 51 fast steps with
    finite signals (with companions that are known to work: cable, linear, TF, none)."""
    scn = parse_scenario(scenario_text(**{family: kind}), f"<{family}:{kind}>")
    sub, comp, lab = build.substructure(scn), build.compensator(scn), build.lab(scn)
    records: list[dict[str, float]] = []
    result = Loop(
        sub,
        comp,
        InProcessLink(lab),
        scn.scaling,
        scn.run.steps,
        sink=lambda b: records.extend(b.records()),
    ).run()
    assert result.stopped is None and result.steps == scn.run.steps == 51
    built = {
        "substructure": sub,
        "compensator": comp,
        "actuator": lab.actuator,
        "specimen": lab.actuator.specimen,
    }[family]
    assert (
        built.kind == kind or family == "specimen"
    )  # factory kinds (imd, benchmark) build a class
    assert all(math.isfinite(v) for r in records for v in r.values())
    assert sub.steps == comp.steps == lab.actuator.steps == 51  # the bases count
    # declared channels: the row a component writes is its dict, name for name, value for value
    for part, as_dict in ((lab, lab.truth()), (comp, comp.state()), (sub, sub.outputs())):
        row = RowBlock(part.channels(), 1).values[0]
        part.write_channels(row)
        assert [c.name for c in part.channels()] == list(as_dict), type(part).__name__
        assert row.tolist() == [float(v) for v in as_dict.values()], type(part).__name__


def test_every_kind_is_documented_in_the_readme():
    """The README's table is ``rths kinds --markdown`` (regenerate it when a kind changes)."""
    out = subprocess.run(
        [sys.executable, "-m", "rths", "kinds", "--markdown"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    text = README.read_text(encoding="utf-8")
    table = text.split("<!-- kinds:begin -->\n")[1].split("<!-- kinds:end -->")[0]
    assert table == out


def test_run_help_lists_every_kind():
    out = subprocess.run(
        [sys.executable, "-m", "rths", "run", "--help"], capture_output=True, text=True, check=True
    ).stdout
    for family, name in all_kinds():
        assert re.search(rf"\[{family}\] .*\b{name}\b", out), (family, name)


# ------------------------------------------------------------------------------ the toy damper
@pytest.fixture
def toy_damper():
    """The README's example module, executed as ``plants.viscous_damper``; unregistered after."""
    block = README.read_text(encoding="utf-8").split("<!-- toy-damper:begin -->\n```python\n")[1]
    source = block.split("```")[0]
    module = types.ModuleType("plants.viscous_damper")
    sys.modules[module.__name__] = module
    exec(compile(source, "README.md:toy-damper", "exec"), module.__dict__)
    yield module
    SPECIMENS.unregister("viscous")
    del sys.modules[module.__name__]


def test_readme_toy_damper_is_a_whole_damper_model(toy_damper):
    """One module, one decorator: the scenario names it, the lab builds it, and the force the
    actuator sees is exactly c v of the drive (closed form)."""
    text = scenario_text(specimen="viscous").replace(
        '[specimen]\nkind = "viscous"\n', '[specimen]\nkind = "viscous"\ndamping = 2000.0\n'
    )
    scn = parse_scenario(text, "<toy>")
    lab = build.lab(scn)
    act = lab.actuator
    assert isinstance(act.specimen, toy_damper.ViscousDamper) and act.specimen.kind == "viscous"
    for k in range(200):
        kin, force = act.step(1e-3 * math.sin(2 * math.pi * 3.0 * k * scn.run.dt))
        assert force == 2000.0 * kin.velocity
    with pytest.raises(ConfigError, match=r"^<bad>: \[specimen\] dampnig: unknown key"):
        parse_scenario(text.replace("damping = 2000.0", "dampnig = 2000.0"), "<bad>")
    with pytest.raises(ConfigError, match=r"^<bad>: \[specimen\] damping must be non-negative"):
        parse_scenario(text.replace("damping = 2000.0", "damping = -1.0"), "<bad>")


# ------------------------------------------------------------------------------ the registry
def test_registry_rejects_malformed_registrations():
    reg = Registry("widget")

    @dataclass(frozen=True)
    class Opts:
        x: float = 1.0

    with pytest.raises(ValueError, match="widget kind must match"):
        reg.register("Bad-Name", Opts)
    with pytest.raises(ValueError, match="must be a frozen dataclass"):
        reg.register("mutable", dataclass(type("M", (), {"__annotations__": {"x": float}})))
    with pytest.raises(TypeError, match="needs a classmethod from_options"):
        reg.register("plain", Opts)(type("Plain", (), {}))

    @reg.register("thing", Opts)
    class Thing:
        @classmethod
        def from_options(cls, options, **context):
            return (cls, options.x, context)

    assert Thing.kind == "thing" and reg.names() == ("thing",) and "thing" in reg
    assert reg.get("thing").build(Opts(2.0), dt=0.1) == (Thing, 2.0, {"dt": 0.1})
    with pytest.raises(ValueError, match="already registered by"):
        reg.register("thing", Opts)(
            type("Other", (), {"from_options": classmethod(lambda c, o: o)})
        )
    with pytest.raises(ValueError, match="unknown widget kind 'thingy'; choose one of 'thing'"):
        reg.get("thingy")
    with pytest.raises(ValueError, match="takes Opts options; got int"):
        reg.get("thing").build(3)


# ------------------------------------------------------------------------------ option tables
@dataclass(frozen=True)
class Inner:
    """Parameters
    ----------
    gain
        A gain [-].
    """

    gain: float = 1.0


@dataclass(frozen=True)
class Everything:
    """Parameters
    ----------
    rate
        A rate [Hz]. Second sentence not shown.
    """

    rate: float
    count: int = 3
    flag: bool = False
    name: str = "x"
    mode: Literal["a", "b"] = "a"
    values: tuple[float, ...] = (1.0,)
    pair: tuple[float, float] = (0.0, 1.0)
    bounds: tuple[tuple[float, float], ...] = ((0.0, 1.0),)
    size: int | Literal["auto"] = "auto"
    limit: float | None = None
    inner: Inner = field(default_factory=Inner)


def parse(text: str) -> Everything:
    return parse_options(parse_toml(text, "t.toml"), Everything)


def test_options_read_every_supported_type():
    o = parse(
        "rate = 2\ncount = 4\nflag = true\nname = 'y'\nmode = 'b'\nvalues = [1, 2.5]\n"
        "pair = [3, 4]\nbounds = [[0, 2], [1, 3]]\nsize = 7\nlimit = 0.5\n[inner]\ngain = 2\n"
    )
    assert o == Everything(
        2.0, 4, True, "y", "b", (1.0, 2.5), (3.0, 4.0), ((0.0, 2.0), (1.0, 3.0)), 7, 0.5, Inner(2.0)
    )
    assert isinstance(o.rate, float) and parse("rate = 1\nsize = 'auto'").size == "auto"


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("count = 1", r"\[top level\] rate: missing \(required\)"),
        ("rate = 'fast'", r"\[top level\] rate: must be a number; got 'fast'"),
        ("rate = nan", r"\[top level\] rate: must be finite"),
        ("rate = 1\ncount = 1.5", r"\[top level\] count: must be an integer; got 1.5"),
        ("rate = 1\nflag = 1", r"\[top level\] flag: must be true or false"),
        ("rate = 1\nmode = 'c'", r"\[top level\] mode: must be one of 'a' \| 'b'; got 'c'"),
        ("rate = 1\npair = [1]", r"\[top level\] pair: must be a list of 2 items"),
        ("rate = 1\nvalues = []", r"\[top level\] values: must be a non-empty list"),
        ("rate = 1\nsize = 'big'", r"\[top level\] size: must be int \| 'auto'; got 'big'"),
        ("rate = 1\nrat = 2", r"\[top level\] rat: unknown key; expected one of .*'rate'"),
        ("rate = 1\n[inner]\ngian = 2", r"\[inner\] gian: unknown key"),
    ],
)
def test_option_errors_name_file_table_and_key(text, match):
    with pytest.raises(ConfigError, match=r"^t\.toml: " + match):
        parse(text)


def test_option_docs_come_from_the_dataclass():
    docs = {o.key: o for o in describe_options(Everything)}
    assert docs["rate"].default is None and docs["rate"].description == "A rate [Hz]."
    assert docs["count"].default == "3" and docs["limit"].default == "none"
    assert docs["size"].type == "int | 'auto'" and docs["bounds"].type == "[[float, float], ...]"


def test_presets_with_overrides():
    scn = parse_scenario(
        scenario_text(specimen="imd").replace(
            'preset = "type_ii"\n', 'preset = "type_ii"\nfriction = 25.0\n'
        ),
        "<p>",
    )
    options = scn.specimen.options
    assert options.inertance == 1589.0 and options.friction == 25.0
    spec = build.specimen(scn)
    assert type(spec).__name__ == "InternalStiffnessIMD"


def test_kinds_are_shared_between_scenario_and_factory():
    """``controllers.factory`` and the scenario parser read the same registry."""
    from controllers.factory import kinds

    assert kinds() == registry("compensator").names()
    assert np.all([SPECIMENS.get(n).family == "specimen" for n in SPECIMENS.names()])


def test_an_entry_point_module_that_does_not_import_is_one_line(monkeypatch):
    import rths.config.kinds as kinds_module

    class Point:
        name, value = "broken", "no_such_module_xyz"

    monkeypatch.setattr(kinds_module, "_loaded", False)
    monkeypatch.setattr(kinds_module, "entry_points", lambda group: [Point()])
    with pytest.raises(ConfigError, match="entry point 'broken' .* 'no_such_module_xyz'"):
        kinds_module.load_kinds()
