"""Strict, typed access to a parsed TOML table with errors that name file, key and value.

Getters return the checked value, or the ``default`` as given (often None) when the key is
absent, hence their ``Any`` return annotations.

Used by the scenario and nominal-model readers::

    doc = load_toml(path)                # ConfigError on a missing file or a TOML syntax error
    run = doc.table("run")
    rate = run.number("rate", positive=True)
    clock = run.choice("clock", ("lockstep", "realtime", "fast"), default="lockstep")
    run.finish()                         # unknown keys are errors: typos never pass silently
"""

from __future__ import annotations

import difflib
import math
import tomllib
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from rths.core.errors import ConfigError, format_choices

__all__ = ["Table", "load_toml", "parse_toml"]

_MISSING: Any = object()


class Table:
    """A TOML table whose keys are consumed one by one; :meth:`finish` rejects the leftovers.

    Parameters
    ----------
    data : dict
        The table's parsed keys and values (copied).
    where : str
        Dotted name of the table in the document (``""``: the top level), used in error messages.
    source : str
        Name of the document (a file path or ``"<scenario>"``), used in error messages.
    """

    def __init__(self, data: dict[str, Any], where: str, source: str) -> None:
        self._data = dict(data)
        self._seen: set[str] = set()
        self.where = where
        self.source = source

    # -- helpers ---------------------------------------------------------------------------
    def _name(self, key: str) -> str:
        return f"{self.where}.{key}" if self.where else key

    def error(self, key: str, message: str) -> ConfigError:
        """A :class:`ConfigError` naming the source and the key."""
        return ConfigError(f"{self.source}: [{self.where or 'top level'}] {key}: {message}")

    def __contains__(self, key: str) -> bool:
        return key in self._data

    def keys(self) -> list[str]:
        """Keys present in the table."""
        return list(self._data)

    def _get(self, key: str, default: Any) -> Any:
        self._seen.add(key)
        if key in self._data:
            return self._data[key]
        if default is _MISSING:
            raise self.error(key, "missing (required)" + self._typo_of(key))
        return default

    def _typo_of(self, key: str) -> str:
        """``"; is 'durration' a typo of it?"`` when an unknown key of the table is close."""
        unknown = [k for k in self._data if k not in self._seen]
        close = difflib.get_close_matches(key, unknown, n=1, cutoff=0.6)
        return f"; is {close[0]!r} a typo of it?" if close else ""

    # -- typed getters -------------------------------------------------------------------------
    def raw(self, key: str, default: Any = _MISSING) -> Any:
        """The value as parsed, unchecked (for keys that accept several types)."""
        return self._get(key, default)

    def number(
        self,
        key: str,
        default: Any = _MISSING,
        *,
        positive: bool = False,
        nonnegative: bool = False,
        lo: float | None = None,
        hi: float | None = None,
    ) -> Any:
        """A finite float (ints accepted) with range checks (the default is not checked)."""
        if key not in self._data and default is not _MISSING:
            self._seen.add(key)
            return default
        value = self._get(key, default)
        if value is None:
            return value
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.error(key, f"must be a number; got {value!r}")
        x = float(value)
        if not math.isfinite(x):
            raise self.error(key, f"must be finite; got {value!r}")
        if positive and x <= 0:
            raise self.error(key, f"must be positive; got {value!r}")
        if nonnegative and x < 0:
            raise self.error(key, f"must be non-negative; got {value!r}")
        if lo is not None and x < lo or hi is not None and x > hi:
            if lo is None or hi is None:
                bound = f">= {lo:g}" if hi is None else f"<= {hi:g}"
                raise self.error(key, f"must be {bound}; got {value!r}")
            raise self.error(key, f"must lie in [{lo:g}, {hi:g}]; got {value!r}")
        return x

    def integer(self, key: str, default: Any = _MISSING, *, minimum: int | None = None) -> Any:
        """An integer with an optional lower bound."""
        value = self._get(key, default)
        if value is None:
            return value
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.error(key, f"must be an integer; got {value!r}")
        if minimum is not None and value < minimum:
            raise self.error(key, f"must be >= {minimum}; got {value!r}")
        return value

    def boolean(self, key: str, default: Any = _MISSING) -> bool:
        """A boolean."""
        value = self._get(key, default)
        if not isinstance(value, bool):
            raise self.error(key, f"must be true or false; got {value!r}")
        return value

    def string(self, key: str, default: Any = _MISSING) -> Any:
        """A string."""
        value = self._get(key, default)
        if value is None:
            return value
        if not isinstance(value, str):
            raise self.error(key, f"must be a string; got {value!r}")
        return value

    def choice(self, key: str, choices: Sequence[str], default: Any = _MISSING) -> str:
        """A string among ``choices``."""
        value = self.string(key, default)
        if value not in choices:
            raise self.error(key, f"must be one of {format_choices(choices)}; got {value!r}")
        return value

    def numbers(self, key: str, default: Any = _MISSING, *, min_length: int = 1) -> Any:
        """A non-empty list of finite numbers."""
        value = self._get(key, default)
        if value is None:
            return value
        if not isinstance(value, list) or len(value) < min_length:
            raise self.error(
                key, f"must be a list of at least {min_length} number(s); got {value!r}"
            )
        out = []
        for v in value:
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                raise self.error(key, f"must contain finite numbers only; got {v!r}")
            out.append(float(v))
        return out

    def table(self, key: str, default: Any = _MISSING) -> Table:
        """A sub-table (``default={}`` makes it optional)."""
        value = self._get(key, default)
        if not isinstance(value, dict):
            raise self.error(key, f"must be a table; got {value!r}")
        return Table(value, self._name(key), self.source)

    def rest(self) -> dict[str, Any]:
        """The keys not consumed yet (marks them consumed): for pass-through option tables."""
        out = {k: v for k, v in self._data.items() if k not in self._seen}
        self._seen.update(out)
        return out

    def finish(self) -> None:
        """Raise on keys that were never consumed (typos, unsupported options)."""
        unknown = [k for k in self._data if k not in self._seen]
        if unknown:
            expected = sorted(self._seen) or ["(none)"]
            raise self.error(
                unknown[0],
                f"unknown key; expected one of {format_choices(expected)}",
            )


def parse_toml(text: str, source: str) -> Table:
    """Parse TOML text; syntax errors become :class:`ConfigError` naming ``source``.

    Parameters
    ----------
    text : str
        The TOML text.
    source : str
        Name of the document (a file path or ``"<scenario>"``), used in error messages.
    """
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{source}: invalid TOML: {exc}") from None
    except RecursionError:  # tomllib recurses once per nesting level
        raise ConfigError(f"{source}: invalid TOML: arrays or tables nested too deeply") from None
    return Table(data, "", source)


def load_toml(path: str | Path) -> tuple[Table, str]:
    """Read and parse a TOML file; returns the top-level table and the raw text.

    Parameters
    ----------
    path : str or pathlib.Path
        The UTF-8 TOML file.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError(f"{p}: no such file") from None
    except UnicodeDecodeError as exc:
        raise ConfigError(
            f"{p}: not a UTF-8 text file (byte {exc.start} is {exc.object[exc.start]:#04x})"
        ) from None
    except OSError as exc:
        raise ConfigError(f"{p}: cannot read: {exc.strerror or exc}") from None
    return parse_toml(text, str(p)), text
