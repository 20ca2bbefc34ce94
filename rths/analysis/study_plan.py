"""What a parameter study varies and how it samples it (:mod:`rths.analysis.study` runs it).

``[study]`` table (or the ``rths study`` options)::

    [study]
    sampling = "grid"            # "grid" (every combination) | "lhs" (Latin hypercube)
    samples = 20                 # lhs: number of points
    seed = 1                     # lhs: seed of the design
    [[study.vary]]
    keys = ["specimen.inertance", "model.inertance"]   # one value for both
    range = [200.0, 2400.0]      # with count (grid) or alone (lhs)
    count = 8
    spacing = "linear"           # | "log"
    [[study.vary]]
    keys = ["specimen.damping", "model.damping"]
    values = [4000.0, 8841.0]    # explicit values (grid only)
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from rths.campaign.runs import Scalar
from rths.config.scenario import Scenario
from rths.core.errors import ConfigError

__all__ = ["SAMPLINGS", "StudyPlan", "Vary", "parse_vary", "plan"]

SAMPLINGS = ("grid", "lhs")


@dataclass(frozen=True)
class Vary:
    """One varied quantity: the dotted keys it sets and its values or range.

    Parameters
    ----------
    keys
        Dotted scenario keys that all take the value.
    values
        Explicit values (grid sampling).
    low, high
        Range (grid with ``count``; Latin hypercube).
    count
        Grid points over ``[low, high]``, ends included.
    log
        Geometric spacing (grid) or log-uniform sampling (Latin hypercube).
    """

    keys: tuple[str, ...]
    values: tuple[Scalar, ...] = ()
    low: float | None = None
    high: float | None = None
    count: int | None = None
    log: bool = False

    def __post_init__(self) -> None:
        name = ",".join(self.keys)
        if not self.keys or any(not k or k.startswith(".") or k.endswith(".") for k in self.keys):
            raise ConfigError(f"vary: keys must be dotted scenario keys; got {self.keys!r}")
        if self.values and self.low is not None:
            raise ConfigError(f"vary {name}: give values or a range, not both")
        if not self.values and (self.low is None or self.high is None):
            raise ConfigError(f"vary {name}: give values or a range low:high")
        if self.low is not None and self.high is not None:
            if not self.low < self.high:
                raise ConfigError(
                    f"vary {name}: range needs low < high; got {self.low}:{self.high}"
                )
            if self.log and self.low <= 0:
                raise ConfigError(f"vary {name}: a log range needs low > 0; got {self.low}")
        if self.count is not None and self.count < 2:
            raise ConfigError(f"vary {name}: count must be >= 2; got {self.count}")

    @property
    def label(self) -> str:
        """The first key (axis label)."""
        return self.keys[0]

    def grid(self) -> tuple[Scalar, ...]:
        """The grid values."""
        if self.values:
            return self.values
        if self.count is None:
            raise ConfigError(f"vary {self.label}: a grid over a range needs a count (lo:hi:n)")
        assert self.low is not None and self.high is not None
        space = np.geomspace if self.log else np.linspace
        return tuple(float(v) for v in space(self.low, self.high, self.count))

    def at(self, u: float) -> float:
        """The range's value at a fraction of it (Latin hypercube).

        Parameters
        ----------
        u
            Fraction in [0, 1] (of the logarithm of the range with ``log``).
        """
        if self.low is None or self.high is None:
            raise ConfigError(f"vary {self.label}: Latin hypercube sampling needs a range lo:hi")
        if self.log:
            return float(math.exp(math.log(self.low) + u * math.log(self.high / self.low)))
        return float(self.low + u * (self.high - self.low))


def _number(text: str, where: str) -> Scalar:
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    if text in ("true", "false"):
        return text == "true"
    if not text:
        raise ConfigError(f"{where}: empty value")
    return text


def parse_vary(text: str) -> Vary:
    """``KEY[,KEY...]=SPEC`` of ``rths study --vary``.

    SPEC is ``v1,v2,...`` (values; numbers, ``true``/``false`` or text), ``lo:hi:n`` (grid of n
    points, ends included) or ``lo:hi`` (a range for Latin hypercube sampling); ``:log`` at the
    end spaces them geometrically.  E.g. ``specimen.inertance,model.inertance=200:2400:8``.

    Parameters
    ----------
    text
        The option's value.
    """
    where = f"--vary {text!r}"
    keys, sep, spec = text.partition("=")
    if not sep or not keys or not spec:
        raise ConfigError(
            f"{where}: expected KEY[,KEY...]=VALUES, e.g. specimen.inertance=100:900:5"
        )
    names = tuple(k.strip() for k in keys.split(","))
    if ":" not in spec:
        return Vary(names, tuple(_number(v.strip(), where) for v in spec.split(",")))
    parts = spec.split(":")
    log = parts[-1] == "log"
    parts = parts[:-1] if log else parts
    if len(parts) not in (2, 3):
        raise ConfigError(f"{where}: a range is lo:hi or lo:hi:n (optionally :log)")
    try:
        low, high = float(parts[0]), float(parts[1])
        count = int(parts[2]) if len(parts) == 3 else None
    except ValueError:
        raise ConfigError(f"{where}: lo and hi must be numbers and n an integer") from None
    return Vary(names, (), low, high, count, log)


def _vary_table(t: Any, where: str) -> Vary:
    if not isinstance(t, Mapping):
        raise ConfigError(f"{where}: each [[study.vary]] must be a table; got {t!r}")
    unknown = set(t) - {"keys", "key", "values", "range", "count", "spacing"}
    if unknown:
        raise ConfigError(f"{where}: unknown key {sorted(unknown)[0]!r}")
    keys = t.get("keys", [t["key"]] if "key" in t else [])
    if isinstance(keys, str):
        keys = [keys]
    spacing = t.get("spacing", "linear")
    if spacing not in ("linear", "log"):
        raise ConfigError(f"{where}: spacing must be 'linear' or 'log'; got {spacing!r}")
    rng = t.get("range")
    if rng is not None and (not isinstance(rng, list) or len(rng) != 2):
        raise ConfigError(f"{where}: range must be [low, high]; got {rng!r}")
    low, high = (None, None) if rng is None else (float(rng[0]), float(rng[1]))
    values = tuple(t.get("values", ()))
    return Vary(tuple(keys), values, low, high, t.get("count"), spacing == "log")


@dataclass(frozen=True)
class StudyPlan:
    """What a study varies and how it samples.

    Parameters
    ----------
    varies
        The varied quantities.
    sampling
        ``"grid"`` (every combination) or ``"lhs"`` (Latin hypercube over the ranges).
    samples
        Latin hypercube points.
    seed
        Latin hypercube seed.
    """

    varies: tuple[Vary, ...]
    sampling: str = "grid"
    samples: int | None = None
    seed: int = 0

    def __post_init__(self) -> None:
        if not self.varies:
            raise ConfigError("a study needs at least one --vary (or a [study] table with vary)")
        if self.sampling not in SAMPLINGS:
            raise ConfigError(f"sampling must be 'grid' or 'lhs'; got {self.sampling!r}")
        if self.sampling == "lhs" and (self.samples is None or self.samples < 1):
            raise ConfigError(f"Latin hypercube sampling needs samples >= 1; got {self.samples!r}")
        keys = [k for v in self.varies for k in v.keys]
        if len(set(keys)) != len(keys):
            raise ConfigError(f"a key is varied twice: {keys}")

    def points(self) -> list[dict[str, Scalar]]:
        """The overrides of every point (dotted key -> value), in run order."""
        combos: Iterable[tuple[Scalar, ...]]
        if self.sampling == "grid":
            combos = itertools.product(*(v.grid() for v in self.varies))
        else:
            from scipy.stats import qmc

            u = qmc.LatinHypercube(d=len(self.varies), seed=self.seed).random(self.samples or 0)
            combos = (
                tuple(v.at(float(x)) for v, x in zip(self.varies, row, strict=True)) for row in u
            )
        return [
            {k: value for v, value in zip(self.varies, combo, strict=True) for k in v.keys}
            for combo in combos
        ]


def plan(
    scn: Scenario,
    varies: Sequence[str] = (),
    sampling: str | None = None,
    samples: int | None = None,
    seed: int | None = None,
) -> StudyPlan:
    """The study of ``scn``: its ``[study]`` table, with the command-line options overriding it
    (``varies`` given: they replace the table's ``vary`` list).

    Parameters
    ----------
    scn
        The scenario.
    varies
        ``--vary`` texts (:func:`parse_vary`).
    sampling, samples, seed
        Override the table's.
    """
    table = dict(scn.study or {})
    where = f"{scn.source}: [study]"
    unknown = set(table) - {"sampling", "samples", "seed", "vary"}
    if unknown:
        raise ConfigError(
            f"{where} {sorted(unknown)[0]}: unknown key; expected one of "
            "'sampling', 'samples', 'seed', 'vary'"
        )
    if varies:
        chosen = tuple(parse_vary(v) for v in varies)
    else:
        entries = table.get("vary", [])
        if not isinstance(entries, list):
            raise ConfigError(f"{where} vary: must be an array of tables [[study.vary]]")
        chosen = tuple(_vary_table(t, f"{where} vary #{i + 1}") for i, t in enumerate(entries))
    return StudyPlan(
        chosen,
        sampling or table.get("sampling", "grid"),
        samples if samples is not None else table.get("samples"),
        seed if seed is not None else table.get("seed", 0),
    )
