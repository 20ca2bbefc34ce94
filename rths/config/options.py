"""Validate a scenario table against a kind's frozen options dataclass.

The dataclass is the single statement of what a kind accepts: each field is a key, its type
annotation says how the TOML value is read, its default makes it optional, and the dataclass's own
``__post_init__`` checks the ranges (raising :class:`rths.core.errors.ParameterError`, which
becomes a :class:`rths.core.errors.ConfigError` naming the file and the table).

Types understood (``X | None`` means "optional, no TOML value for None"):

==========================  ==================================================================
annotation                  TOML value
==========================  ==================================================================
``float``                   a number (integers accepted), finite
``int``                     an integer
``bool``                    ``true`` / ``false``
``str``                     a string
``Literal["a", "b"]``       one of the strings
``tuple[float, ...]``       a non-empty list of numbers (``tuple[float, float]``: exactly two)
a frozen dataclass          a sub-table, validated the same way
``A | B``                   whichever member type the value fits
==========================  ==================================================================

Presets: an options class with classmethods ``presets() -> tuple[str, ...]`` and
``from_preset(name, **overrides)`` also accepts ``preset = "<name>"``; the other keys override
the preset's values.
"""

from __future__ import annotations

import dataclasses
import math
import re
import types
import typing
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any, Literal, get_args, get_origin, get_type_hints

from rths.config.toml import Table
from rths.core.errors import ConfigError, ParameterError
from rths.core.registry import first_sentence

__all__ = ["OptionDoc", "describe_options", "parse_options"]

_MISSING = dataclasses.MISSING


def parse_options(table: Table, options_cls: type) -> Any:
    """The ``options_cls`` instance the table describes (every key checked).

    Parameters
    ----------
    table : rths.config.toml.Table
        The scenario table (e.g. ``[actuator]``); every key is consumed and checked.
    options_cls : type
        The kind's frozen options dataclass (see the module docstring for the types understood).

    Raises
    ------
    ConfigError
        Unknown or missing key, wrong type, or a value the options class rejects; the message
        names the file, the table and the key.
    """
    hints = get_type_hints(options_cls)
    presets = _presets(options_cls)
    values: dict[str, Any] = {}
    preset = None
    if presets is not None:
        preset = table.choice("preset", presets) if "preset" in table else table.raw("preset", None)
    keys = [f for f in dataclasses.fields(options_cls) if f.init]
    for f in keys:  # mark every known key, so that a typo is named before anything else
        table.raw(f.name, None)
    table.finish()
    for f in keys:
        if f.name in table:
            values[f.name] = _read(table, f.name, hints[f.name])
        elif preset is None and _required(f):
            raise table.error(f.name, "missing (required)")
    try:
        if preset is not None:
            return options_cls.from_preset(preset, **values)  # type: ignore[attr-defined]
        return options_cls(**values)
    except ParameterError as exc:
        raise ConfigError(f"{table.source}: [{table.where}] {exc}") from None


@dataclass(frozen=True)
class OptionDoc:
    """One option of a kind, for help texts: key, type, default (``None``: required) and the
    description from the options class's numpydoc ``Parameters`` section.

    Attributes
    ----------
    key : str
        The TOML key (a field of the options class, or ``preset``).
    type : str
        The type as shown to users, e.g. ``float`` or ``'a' | 'b'``.
    default : str or None
        The default as text; None for a required key.
    description : str
        First sentence of the option's numpydoc description (``""`` if undocumented).
    """

    key: str
    type: str
    default: str | None
    description: str


def describe_options(options_cls: type) -> list[OptionDoc]:
    """The options of a kind, in declaration order (``preset`` first when the class has some).

    Parameters
    ----------
    options_cls : type
        The kind's frozen options dataclass.
    """
    hints = get_type_hints(options_cls)
    docs: dict[str, str] = {}
    for cls in reversed(options_cls.__mro__):  # a subclass's description wins
        docs |= {k: first_sentence(v) for k, v in _numpydoc_parameters(cls.__doc__ or "")}
    out = []
    presets = _presets(options_cls)
    if presets is not None:
        out.append(
            OptionDoc(
                "preset",
                " | ".join(repr(p) for p in presets),
                "none",
                "start from these values; other keys override them",
            )
        )
    for f in dataclasses.fields(options_cls):
        if not f.init:
            continue
        default = None if _required(f) else _default_text(f)
        out.append(OptionDoc(f.name, _type_text(hints[f.name]), default, docs.get(f.name, "")))
    return out


# ---------------------------------------------------------------------------------- reading
def _read(table: Table, key: str, hint: Any) -> Any:
    return _convert(table, key, table.raw(key), hint)


def _convert(table: Table, key: str, value: Any, hint: Any) -> Any:
    """``value`` (as parsed from TOML) as an instance of ``hint``; errors name ``key``."""
    origin, args = get_origin(hint), get_args(hint)
    if origin in (typing.Union, types.UnionType):
        members = [a for a in args if a is not type(None)]
        for member in members:
            if _fits(value, member):
                return _convert(table, key, value, member)
        raise table.error(key, f"must be {_type_text(hint)}; got {value!r}")
    if origin is Literal:
        if value not in args:
            raise table.error(key, f"must be one of {_type_text(hint)}; got {value!r}")
        return value
    if origin is tuple:
        if not isinstance(value, list) or not value:
            raise table.error(key, f"must be a non-empty list ({_type_text(hint)}); got {value!r}")
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_convert(table, key, v, args[0]) for v in value)
        if len(value) != len(args):
            raise table.error(key, f"must be a list of {len(args)} items; got {value!r}")
        return tuple(_convert(table, key, v, a) for v, a in zip(value, args, strict=True))
    if dataclasses.is_dataclass(hint) and isinstance(hint, type):
        if not isinstance(value, dict):
            raise table.error(key, f"must be a table; got {value!r}")
        where = f"{table.where}.{key}" if table.where else key
        return parse_options(Table(value, where, table.source), hint)
    if hint is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise table.error(key, f"must be a number; got {value!r}")
        if not math.isfinite(value):
            raise table.error(key, f"must be finite; got {value!r}")
        return float(value)
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise table.error(key, f"must be an integer; got {value!r}")
        return value
    if hint is bool:
        if not isinstance(value, bool):
            raise table.error(key, f"must be true or false; got {value!r}")
        return value
    if hint is str:
        if not isinstance(value, str):
            raise table.error(key, f"must be a string; got {value!r}")
        return value
    raise TypeError(f"option {key!r}: unsupported annotation {hint!r}")


def _fits(value: Any, hint: Any) -> bool:
    origin = get_origin(hint)
    if origin is Literal:
        return value in get_args(hint)
    if origin is tuple:
        return isinstance(value, list)
    if dataclasses.is_dataclass(hint):
        return isinstance(value, dict)
    if hint is float:
        return isinstance(value, int | float) and not isinstance(value, bool)
    if hint is int:
        return isinstance(value, int) and not isinstance(value, bool)
    return isinstance(value, hint)


def _required(f: dataclasses.Field[Any]) -> bool:
    return f.default is _MISSING and f.default_factory is _MISSING


def _presets(options_cls: type) -> tuple[str, ...] | None:
    presets = getattr(options_cls, "presets", None)
    if presets is None or not hasattr(options_cls, "from_preset"):
        return None
    return tuple(presets())


# ---------------------------------------------------------------------------------- docs
def _type_text(hint: Any) -> str:
    origin, args = get_origin(hint), get_args(hint)
    if origin in (typing.Union, types.UnionType):
        return " | ".join(_type_text(a) for a in args if a is not type(None))
    if origin is Literal:
        return " | ".join(repr(a) for a in args)
    if origin is tuple:
        if len(args) == 2 and args[1] is Ellipsis:
            return f"[{_type_text(args[0])}, ...]"
        return "[" + ", ".join(_type_text(a) for a in args) + "]"
    if dataclasses.is_dataclass(hint):
        return "table"
    return getattr(hint, "__name__", str(hint))


def _default_text(f: dataclasses.Field[Any]) -> str:
    factory: Any = f.default_factory
    value = f.default if f.default is not _MISSING else factory()
    if value is None:
        return "none"
    if dataclasses.is_dataclass(value):
        return "(table defaults)"
    return repr(list(value)) if isinstance(value, tuple) else repr(value)


def _numpydoc_parameters(doc: str) -> Iterator[tuple[str, str]]:
    """``(name, description)`` from a ``Parameters``/``Attributes`` section."""
    lines = [line.rstrip() for line in doc.expandtabs().splitlines()]
    section = False
    i = 0
    while i < len(lines):
        text = lines[i].strip()
        if (
            text in ("Parameters", "Attributes")
            and i + 1 < len(lines)
            and set(lines[i + 1].strip()) == {"-"}
        ):
            section, i = True, i + 2
            continue
        if section and text and set(lines[i + 1].strip() if i + 1 < len(lines) else "") == {"-"}:
            section = False
        if section and re.match(r"^\s{0,8}[A-Za-z_][\w, ]*(\s*:.*)?$", lines[i]) and text:
            indent = len(lines[i]) - len(lines[i].lstrip())
            names = [n.strip() for n in text.split(":")[0].split(",")]
            body: list[str] = []
            i += 1
            while i < len(lines) and (
                not lines[i].strip() or len(lines[i]) - len(lines[i].lstrip()) > indent
            ):
                body.append(lines[i].strip())
                i += 1
            description = " ".join(b for b in body if b)
            for name in names:
                yield name, description
            continue
        i += 1
