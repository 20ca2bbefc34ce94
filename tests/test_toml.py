"""Strict TOML access: every bad value or unknown key names the file, the table and the key."""

import pytest

from rths.config.toml import load_toml, parse_toml
from rths.core.errors import ConfigError

DOC = """
[run]
rate = 2048
clock = "lockstep"
flag = true
name = "x"
gains = [1.0, 2]
[run.sub]
a = 1
"""


def test_typed_getters_and_defaults():
    run = parse_toml(DOC, "s.toml").table("run")
    assert run.number("rate", positive=True) == 2048.0
    assert run.choice("clock", ("lockstep", "fast")) == "lockstep"
    assert run.boolean("flag") is True
    assert run.string("name") == "x"
    assert run.numbers("gains") == [1.0, 2.0]
    assert run.number("duration", 10.0) == 10.0
    assert run.integer("seed", None) is None
    assert run.table("sub").integer("a", minimum=0) == 1
    run.finish()


@pytest.mark.parametrize(
    "getter, match",
    [
        (lambda t: t.number("clock"), r"s.toml: \[run\] clock: must be a number; got 'lockstep'"),
        (lambda t: t.number("rate", hi=1000), r"rate: must be <= 1000; got 2048"),
        (lambda t: t.number("rate", lo=0, hi=1000), r"rate: must lie in \[0, 1000\]"),
        (lambda t: t.choice("clock", ("fast",)), r"clock: must be one of 'fast'; got 'lockstep'"),
        (lambda t: t.integer("rate", minimum=4096), r"rate: must be >= 4096"),
        (lambda t: t.integer("flag"), r"flag: must be an integer"),
        (lambda t: t.boolean("name"), r"name: must be true or false"),
        (lambda t: t.string("rate"), r"rate: must be a string"),
        (lambda t: t.numbers("name"), r"name: must be a list"),
        (lambda t: t.table("name"), r"name: must be a table"),
        (lambda t: t.number("missing"), r"missing: missing \(required\)"),
    ],
)
def test_errors_name_file_table_key_and_value(getter, match):
    run = parse_toml(DOC, "s.toml").table("run")
    with pytest.raises(ConfigError, match=match):
        getter(run)


def test_range_checks():
    t = parse_toml("a = -1\nb = 0\nc = [1, nan]\n", "f.toml")
    with pytest.raises(ConfigError, match="a: must be positive; got -1"):
        t.number("a", positive=True)
    with pytest.raises(ConfigError, match="a: must be non-negative"):
        t.number("a", nonnegative=True)
    with pytest.raises(ConfigError, match="c: must contain finite numbers only"):
        t.numbers("c")


def test_unknown_keys_are_rejected():
    run = parse_toml(DOC, "s.toml").table("run")
    run.number("rate")
    with pytest.raises(ConfigError, match=r"\[run\] clock: unknown key; expected one of 'rate'"):
        run.finish()


def test_rest_passes_options_through():
    run = parse_toml(DOC, "s.toml").table("run")
    run.number("rate")
    rest = run.rest()
    assert set(rest) == {"clock", "flag", "name", "gains", "sub"}
    run.finish()


def test_syntax_error_and_missing_file(tmp_path):
    with pytest.raises(ConfigError, match="bad.toml: invalid TOML"):
        parse_toml("a = = 1", "bad.toml")
    with pytest.raises(ConfigError, match="no such file"):
        load_toml(tmp_path / "nope.toml")
    (tmp_path / "ok.toml").write_text("x = 1\n")
    table, text = load_toml(tmp_path / "ok.toml")
    assert table.integer("x") == 1 and text == "x = 1\n"
