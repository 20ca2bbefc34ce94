"""Parameter studies for damper designers: a grid or Latin hypercube over scenario keys.

A study varies dotted scenario keys (``specimen.inertance``, ``model.damping``...; several keys
can share one value, e.g. the specimen and the model of the same damper) and runs every point as
an RTHS on the fast clock, as a campaign (:mod:`rths.campaign`).  Per point it measures, from
the substructure's ``midspan_displacement``:

* ``peak_midspan_m`` -- the largest midspan displacement [m] while the load acts;
* ``zeta_1``, ``hz_1``, ``zeta_2``, ``hz_2`` -- when the load stops before the end of the run
  (``[substructure.load] duration``), the damping ratios and frequencies of the (up to) two
  modes near the load's frequency in the free decay that follows (matrix pencil,
  :func:`rths.metrics.free_decay`), ascending in frequency; ``zeta``, ``decay_hz``: the
  least-damped of them (the one a designer must raise);
* the same two from the fully numerical run of the point (``*_numerical``,
  :func:`rths.session.mock.numerical_run`: what a perfect RTHS would measure with this protocol);
* ``zeta_exact_min``/``zeta_exact_max`` -- the damping ratios of the roots of the exact
  cable-damper frequency equation near the load's mode (S0 Eq.23 normalisation,
  :mod:`plants.cable.frequency_equation`, the numbers ``rths damping`` prints) plus the cable's
  own intrinsic damping (the Rayleigh ratio, exact at the anchor mode, added to first order),
  for a linear IMD specimen (``imd``, ``imd_simplified``, ``imd_internal`` without damping law,
  friction or backlash).

Near the optimum of an IMD two roots nearly coalesce (S0 §5.3: 0.0905 and 0.0878); the free
decay is then close to ``(a + b t) e^{-sigma t}``, a single fitted exponential would read a
damping below both, and the pencil resolves them less sharply -- the numerical run shows how
much, which is how to tell this from a tracking error.

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

from rths.campaign import Campaign
from rths.campaign.runs import Scalar
from rths.campaign.scenario import ScenarioRun, scenario_run, tracking_row
from rths.config.scenario import Scenario, parse_scenario
from rths.core.errors import ConfigError, DataError
from rths.metrics import free_decay
from rths.session.mock import numerical_run

__all__ = [
    "SAMPLINGS",
    "StudyPlan",
    "StudyRun",
    "Vary",
    "campaign",
    "exact_damping",
    "parse_vary",
    "plan",
    "study_task",
]

SAMPLINGS = ("grid", "lhs")
MIDSPAN = "midspan_displacement"
_LINEAR_IMD = ("imd", "imd_simplified", "imd_internal")


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


# ------------------------------------------------------------------------------ one point
def exact_damping(scn: Scenario) -> tuple[float, ...] | None:
    """Damping ratios [-] of the exact frequency equation's roots near the load's mode, plus the
    cable's intrinsic ratio; None when the scenario is not a cable with a linear IMD specimen.

    Parameters
    ----------
    scn
        The scenario (cable, damper position, load mode, specimen, scaling).
    """
    sub, spec = scn.substructure, scn.specimen
    if sub.kind != "cable" or spec.kind not in _LINEAR_IMD:
        return None
    o = spec.options
    if o.damping_law is not None or o.friction or o.clearance:
        return None
    from plants.cable.frequency_equation import exact_roots
    from plants.cable.properties import CableProperties, normalised_damper, normalised_stiffness

    c = sub.options
    cable = CableProperties(c.length, c.tension, c.mass_per_length)
    lam = scn.scaling.impedance
    m_e, c_d = normalised_damper(cable, o.inertance * lam, o.damping * lam)
    series = spec.kind != "imd_simplified" and o.has_internal_stiffness
    k_e = normalised_stiffness(cable, o.stiffness * lam) if series else None
    roots = exact_roots(c.load.mode, c.damper_position, m_e, c_d, k_e=k_e)
    return tuple(r.zeta + c.intrinsic_damping for r in roots)


def _response(scn: Scenario, midspan: np.ndarray, suffix: str) -> dict[str, Scalar]:
    """Peak while loaded and the modes of the free decay after the load stops: the
    least-damped one (``zeta``, ``decay_hz``) and each of the two the pencil keeps
    (``zeta_1``/``hz_1``, ``zeta_2``/``hz_2``, ascending in frequency)."""
    out: dict[str, Scalar] = {f"peak_midspan{suffix}_m": None, f"zeta{suffix}": None}
    out[f"decay{suffix}_hz"] = None
    for i in (1, 2):
        out[f"zeta{suffix}_{i}"] = out[f"hz{suffix}_{i}"] = None
    if midspan.size == 0 or not np.all(np.isfinite(midspan)):
        return out
    dt = scn.run.dt
    options = scn.substructure.options
    end = getattr(getattr(options, "load", None), "duration", None)
    k = midspan.size if end is None else min(midspan.size, round(end / dt))
    out[f"peak_midspan{suffix}_m"] = float(np.max(np.abs(midspan[:k]))) if k else None
    period = getattr(options, "excitation_period", None)
    if end is None or period is None or midspan.size - k < 64:
        return out
    try:
        found = free_decay(midspan[k:], dt, modes=2, band=(0.6 / period, 1.4 / period))
    except DataError:
        return out
    if found:
        least = min(found, key=lambda m: m.damping_ratio)
        out[f"zeta{suffix}"], out[f"decay{suffix}_hz"] = least.damping_ratio, least.frequency
    for i, mode in enumerate(found[:2], 1):
        out[f"zeta{suffix}_{i}"], out[f"hz{suffix}_{i}"] = mode.damping_ratio, mode.frequency
    return out


@dataclass(frozen=True)
class StudyRun:
    """The payload of a study point: the scenario run and whether to run the numerical twin.

    Parameters
    ----------
    run
        The scenario run (keeps ``midspan_displacement``).
    numerical
        Also run the fully numerical model of the point (``*_numerical`` columns).
    """

    run: ScenarioRun
    numerical: bool = True


def study_task(spec: StudyRun) -> dict[str, Scalar]:
    """One study point: tracking columns, response, numerical twin and exact damping.

    Parameters
    ----------
    spec
        The point.
    """
    scn = spec.run.scenario()
    batch = spec.run.execute(scn)
    row = tracking_row(batch)
    midspan = batch.outputs.get(MIDSPAN, np.zeros(0))
    row.update(_response(scn, midspan if not batch.stopped else np.zeros(0), ""))
    if spec.numerical:
        twin = numerical_run(scn)
        row.update(_response(scn, twin.get(MIDSPAN, np.zeros(0)), "_numerical"))
    exact = exact_damping(scn)
    row["zeta_exact_min"] = None if not exact else min(exact)
    row["zeta_exact_max"] = None if not exact else max(exact)
    return row


def campaign(
    scn: Scenario, study: StudyPlan, compensator: str | None = None, numerical: bool = True
) -> Campaign:
    """The study's campaign; every point's overrides are validated here first (a bad key or
    value is one :class:`ConfigError` before anything runs).

    Parameters
    ----------
    scn
        The scenario studied.
    study
        What varies and how it is sampled.
    compensator
        Compensator kind overriding the scenario's.
    numerical
        Also run each point's fully numerical twin.
    """
    runs = []
    for point in study.points():
        parse_scenario(scn.text, scn.source, point)  # raises on a bad key or value
        base = scenario_run(
            scn,
            overrides=point,
            compensator=compensator,
            outputs=(MIDSPAN,),
            extra=("study", numerical),
        )
        runs.append(type(base)(base.key, base.inputs, StudyRun(base.payload, numerical)))
    return Campaign(f"{scn.run.name} study", runs, study_task)
