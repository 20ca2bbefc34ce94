"""Scenario files: what a run is, parsed strictly into frozen specifications.

A scenario is a TOML file with these tables (all SI; see ``scenarios/*.toml`` for commented
examples users copy)::

    [run]          name, duration [s], rate [Hz], clock, seed
    [scaling]      displacement (specimen/prototype), force (prototype/specimen)
    [substructure] kind + its options, e.g. kind = "cable" + geometry, [substructure.load]
    [specimen]     the physical specimen in the emulated lab (the truth): kind + options
    [actuator]     kind + options, e.g. "transfer_function" (num, den, delay, velocity_limit)
    [lab]          converters: bits, range, calibrations, noise
    [model]        what the numerical side believes about the specimen: the nominal device the
                   substructure carries, the compensator's plant, the fully numerical mock run
    [compensator]  kind + options
    [loop]         correction_filter [Hz], stroke [m] (interlock), max_velocity and
                   ramp_velocity [m/s] (the specimen side's guard), max_lag [steps]
                   (measurement watchdog), command_timeout [s] (the specimen's command watchdog)
    [monte_carlo]  draws (perturbed benchmark plants)
    [study]        a parameter study over this scenario's keys (``rths study``; read and
                   checked by :mod:`rths.analysis.study`, kept here as given)

The four component tables name a registered kind (:mod:`rths.core.registry`; ``rths kinds``
lists them with their options): the kind's frozen options dataclass says which keys the table
takes, and :func:`rths.config.options.parse_options` checks every one.  Every key is checked here,
before any process starts: a typo, a wrong type or an out-of-range value is a
:class:`rths.core.errors.ConfigError` naming the file, the table and the key.  Physical
consistency that needs the plants built (e.g. a stable actuator) is checked when
:mod:`rths.config.build` constructs them, with the table named in the message.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from plants.device_model import DeviceModel
from rths.config.kinds import registry
from rths.config.lab import LabSpec, parse_lab, parse_model
from rths.config.options import parse_options
from rths.config.toml import Table, load_toml, parse_toml
from rths.core.errors import ConfigError, ParameterError
from rths.core.scaling import Scaling

__all__ = [
    "CLOCKS",
    "MAX_DURATION",
    "MAX_RATE",
    "Component",
    "LoopSpec",
    "RunSpec",
    "Scenario",
    "load_scenario",
    "parse_scenario",
]

CLOCKS = ("lockstep", "realtime", "fast")
#: Fastest loop rate [Hz] a scenario may ask for: an order of magnitude above any RTHS loop
#: (the vRTHS benchmark runs at 4096 Hz; real-time Python at 2 kHz).
MAX_RATE = 100e3
#: Longest run [s]: a day (split longer tests into several runs).
MAX_DURATION = 86400.0


@dataclass(frozen=True)
class RunSpec:
    """``[run]``: name, duration [s], loop rate [Hz], clock and seed of the lab's noise.

    Attributes
    ----------
    name : str
        Name of the run (appears in the log's metadata and the run id).
    duration : float
        Simulated duration [s], > 0, at most :data:`MAX_DURATION` (a day) and at least one
        loop step ``1/rate``.
    rate : float
        Fixed loop rate [Hz], > 0, at most :data:`MAX_RATE` (vRTHS benchmark: 4096).
    clock : str
        One of :data:`CLOCKS`: ``"lockstep"`` (default; deterministic), ``"realtime"``
        (wall-clock paced) or ``"fast"`` (one process, no zenoh).
    seed : int
        Seed of the emulated lab's noise, >= 0 (default 0).
    """

    name: str
    duration: float
    rate: float
    clock: str = "lockstep"
    seed: int = 0

    @property
    def dt(self) -> float:
        """Loop step [s]."""
        return 1.0 / self.rate

    @property
    def steps(self) -> int:
        """Number of loop steps."""
        return max(1, round(self.duration * self.rate))


@dataclass(frozen=True)
class Component:
    """A component table: the registered ``kind`` and its validated options dataclass.

    Attributes
    ----------
    kind : str
        Name of the registered kind (``rths kinds`` lists them).
    options : Any
        The kind's frozen options dataclass, parsed by
        :func:`rths.config.options.parse_options` (units as documented there).
    """

    kind: str
    options: Any


#: Largest ``[loop] max_velocity`` [m/s]: a guard above it guards nothing.
MAX_VELOCITY = 10.0
#: Longest measurement age the watchdog may allow, ``max_lag * dt`` [s].
MAX_LAG_TIME = 1.0
#: The measurement watchdog's default age [s]: ``max_lag`` defaults to this many seconds of
#: steps, at least ``MIN_DEFAULT_LAG``.  A 2-core VM's scheduler alone delays a real-time C
#: loop's wake-up by more than 2.4 ms (5 steps at 2048 Hz) 11 to 72 times a minute, by up to
#: 7.9 ms (``tools/wakeup_floor.py``; README, "Real time"): a watchdog below that floor stops
#: runs for the machine, not the test.
DEFAULT_MAX_AGE = 0.010
#: Fewest steps of the default watchdog (at rates below 500 Hz it is 5 steps, not 10 ms).
MIN_DEFAULT_LAG = 5
#: The specimen's command watchdog's default [s] (``[loop] command_timeout``): while no command
#: comes the actuator holds its last one -- the servo-controller's own safe state -- and after
#: this long it ramps down.  Twice the measurement watchdog's default: the loop's watchdog, which
#: judges the measurement the compensator uses, is the first line.
DEFAULT_COMMAND_TIMEOUT = 0.020


@dataclass(frozen=True)
class LoopSpec:
    """``[loop]``: low-pass on the force correction [Hz] (0: none), the stroke interlock [m],
    the specimen side's command rate limit and ramp-down rate [m/s] and the measurement
    watchdog [steps] (:mod:`rths.runtime.guard`, :class:`rths.runtime.loop.Loop`).

    Attributes
    ----------
    correction_filter : float
        Cut-off [Hz] of the low-pass on the force correction, >= 0 and below the Nyquist
        frequency ``rate/2``; 0 turns it off (default 60).
    stroke : float
        Stroke interlock: largest ``|command|`` [m], > 0 (default inf: none).
    max_velocity : float
        Largest command rate [m/s] the specimen side lets through, > 0, at most
        ``MAX_VELOCITY`` = 10 m/s (default 0.5).
    ramp_velocity : float
        Rate [m/s] of the ramp back to zero after a trip or stop, > 0 and <= ``max_velocity``
        (default 0.05).
    max_lag : int
        Measurement watchdog [steps], >= 1, with ``max_lag * dt`` at most ``MAX_LAG_TIME`` =
        1 s (default: ``DEFAULT_MAX_AGE`` = 10 ms of steps rounded up, at least 5 -- 21
        steps at 2048 Hz, 41 at 4096 Hz).
    command_timeout : float
        The specimen's command watchdog [s] in real time: no command for this long ramps the
        actuator down, > 0 and at most ``MAX_LAG_TIME`` (default ``DEFAULT_COMMAND_TIMEOUT`` =
        20 ms, and never below ``max_lag * dt``).
    """

    correction_filter: float = 60.0
    stroke: float = math.inf
    max_velocity: float = 0.5
    ramp_velocity: float = 0.05
    max_lag: int = 5
    command_timeout: float = DEFAULT_COMMAND_TIMEOUT


def default_max_lag(rate: float) -> int:
    """The measurement watchdog's default [steps] at ``rate`` [Hz]: ``DEFAULT_MAX_AGE`` of
    steps, rounded up, at least ``MIN_DEFAULT_LAG``."""
    return max(MIN_DEFAULT_LAG, math.ceil(DEFAULT_MAX_AGE * rate - 1e-9))


@dataclass(frozen=True)
class Scenario:
    """A parsed scenario (see the module docstring).

    ``model`` is the ``[model]`` device at specimen scale, or None for ``kind = "none"``;
    ``study`` is the ``[study]`` table as parsed (None without one); ``overrides`` are the
    dotted-key overrides applied on top of ``text`` (:func:`parse_scenario`), in order.

    Attributes
    ----------
    source : str
        Where the scenario came from (a file path or ``"<scenario>"``), used in error messages.
    text : str
        The scenario's TOML text as read (logged as run metadata).
    run : RunSpec
        ``[run]``.
    scaling : rths.core.scaling.Scaling
        ``[scaling]``: specimen/prototype displacement and prototype/specimen force factors
        [-] (default 1, 1).
    substructure : Component
        ``[substructure]``: the numerical substructure kind (prototype scale).
    specimen : Component
        ``[specimen]``: the physical specimen of the emulated lab (the truth).
    actuator : Component
        ``[actuator]``: the lab's actuator kind.
    lab : LabSpec
        ``[lab]``: converters, calibrations and noise.
    model : plants.device_model.DeviceModel or None
        ``[model]``: the nominal device at specimen scale (inertance [kg], damping [N s/m],
        stiffness [N/m]); None for ``kind = "none"`` (default).
    compensator : Component
        ``[compensator]`` (default kind ``"ff_lqg"``).
    loop : LoopSpec
        ``[loop]``.
    monte_carlo_draws : int
        ``[monte_carlo] draws``: number of perturbed benchmark plants, >= 0 (default 0).
    study : mapping or None
        ``[study]`` as parsed (``rths study``'s keys, values and sampling); None without one.
    overrides : tuple of (str, object)
        Dotted keys and values applied on top of ``text`` (:func:`parse_scenario`), in order.
    """

    source: str
    text: str
    run: RunSpec
    scaling: Scaling
    substructure: Component
    specimen: Component
    actuator: Component
    lab: LabSpec
    model: DeviceModel | None
    compensator: Component
    loop: LoopSpec
    monte_carlo_draws: int = 0
    study: Mapping[str, Any] | None = None
    overrides: tuple[tuple[str, Any], ...] = ()

    @property
    def compensator_kind(self) -> str:
        """The ``[compensator]`` kind."""
        return self.compensator.kind


def load_scenario(path: str | Path, overrides: Mapping[str, Any] | None = None) -> Scenario:
    """Read and validate a scenario file (:class:`rths.core.errors.ConfigError` on any problem).

    Parameters
    ----------
    path : str or pathlib.Path
        The scenario's TOML file.
    overrides : mapping of str to object, optional
        Dotted keys and values replacing the file's (:func:`parse_scenario`).
    """
    doc, text = load_toml(path)
    if overrides:
        return parse_scenario(text, doc.source, overrides)
    return _parse(doc, text)


def parse_scenario(
    text: str, source: str = "<scenario>", overrides: Mapping[str, Any] | None = None
) -> Scenario:
    """Validate scenario text (for tests, logs that carry the scenario and campaigns).

    Parameters
    ----------
    text : str
        The scenario's TOML text.
    source : str
        Name used for the scenario in error messages (default ``"<scenario>"``).
    overrides : mapping of str to object, optional
        Dotted keys replacing values of the text before it is validated, e.g.
        ``{"specimen.inertance": 1200.0, "substructure.load.amplitude": 20.0}``: the value is
        checked like the file's own (a key the table does not take is an error naming it).  The
        returned scenario keeps ``text`` as given and the overrides in ``overrides``.
    """
    doc = parse_toml(text, source)
    if not overrides:
        return _parse(doc, text)
    data = tomllib.loads(text)
    for key, value in overrides.items():
        _override(data, key, value, source)
    return replace(_parse(Table(data, "", source), text), overrides=tuple(overrides.items()))


def _override(data: dict[str, Any], key: str, value: Any, source: str) -> None:
    """Set the dotted ``key`` of a parsed TOML document to ``value`` (tables created as needed)."""
    parts = key.split(".")
    if not key or any(not p for p in parts):
        raise ConfigError(
            f"{source}: override key must be dotted names like 'run.seed'; got {key!r}"
        )
    table = data
    for i, part in enumerate(parts[:-1]):
        nxt = table.setdefault(part, {})
        if not isinstance(nxt, dict):
            where = ".".join(parts[: i + 1])
            raise ConfigError(f"{source}: override {key!r}: {where!r} is a value, not a table")
        table = nxt
    if isinstance(table.get(parts[-1]), dict):
        raise ConfigError(f"{source}: override {key!r} names a table, not a value")
    table[parts[-1]] = value


def _parse(doc: Table, text: str) -> Scenario:
    run = _run(doc.table("run"))
    t = doc.table("scaling", {})
    factors = (t.number("displacement", 1.0, positive=True), t.number("force", 1.0, positive=True))
    t.finish()
    try:
        scaling = Scaling(*factors)
    except ParameterError as exc:
        raise ConfigError(f"{t.source}: [scaling] {exc}") from None
    sub = _component(doc.table("substructure"), "substructure")
    specimen = _component(doc.table("specimen"), "specimen")
    actuator = _component(doc.table("actuator"), "actuator")
    lab = parse_lab(doc.table("lab", {}))
    model = parse_model(doc.table("model", {"kind": "none"}))
    comp = _component(doc.table("compensator", {"kind": "ff_lqg"}), "compensator")
    t = doc.table("loop", {})
    loop = LoopSpec(
        t.number("correction_filter", 60.0, nonnegative=True),
        t.number("stroke", math.inf, positive=True),
        t.number("max_velocity", 0.5, positive=True),
        t.number("ramp_velocity", 0.05, positive=True),
        t.integer("max_lag", default_max_lag(run.rate), minimum=1),
        t.number("command_timeout", DEFAULT_COMMAND_TIMEOUT, positive=True),
    )
    if loop.ramp_velocity > loop.max_velocity:
        raise t.error("ramp_velocity", f"must not exceed max_velocity {loop.max_velocity!r} m/s")
    if loop.max_velocity > MAX_VELOCITY:
        raise t.error(
            "max_velocity",
            f"must be <= {MAX_VELOCITY:g} m/s (beyond any servo-hydraulic actuator: no guard at "
            f"all); got {loop.max_velocity!r}",
        )
    if loop.max_lag * run.dt > MAX_LAG_TIME:
        raise t.error(
            "max_lag",
            f"{loop.max_lag} steps is {loop.max_lag * run.dt:.3g} s at {run.rate:g} Hz; the "
            f"watchdog must trip within {MAX_LAG_TIME:g} s",
        )
    if loop.command_timeout > MAX_LAG_TIME:
        raise t.error(
            "command_timeout",
            f"must be <= {MAX_LAG_TIME:g} s (the command watchdog must trip within it); got "
            f"{loop.command_timeout!r}",
        )
    t.finish()
    t = doc.table("monte_carlo", {})
    draws = t.integer("draws", 0, minimum=0)
    t.finish()
    study = doc.raw("study", None)
    if study is not None and not isinstance(study, dict):
        raise doc.error("study", f"must be a table; got {study!r}")
    doc.finish()
    if loop.correction_filter and loop.correction_filter >= 0.5 * run.rate:
        raise doc.table("loop").error(
            "correction_filter",
            f"must lie below the Nyquist frequency {0.5 * run.rate:g} Hz; "
            f"got {loop.correction_filter!r}",
        )
    return Scenario(
        doc.source,
        text,
        run,
        scaling,
        sub,
        specimen,
        actuator,
        lab,
        model,
        comp,
        loop,
        draws,
        study,
    )


def _run(t: Table) -> RunSpec:
    spec = RunSpec(
        name=t.string("name"),
        duration=t.number("duration", positive=True),
        rate=t.number("rate", positive=True),
        clock=t.choice("clock", CLOCKS, default="lockstep"),
        seed=t.integer("seed", 0, minimum=0),
    )
    t.finish()
    if spec.rate > MAX_RATE:
        raise t.error(
            "rate", f"must be at most {MAX_RATE:g} Hz (a loop step of 10 µs); got {spec.rate!r}"
        )
    if spec.duration > MAX_DURATION:
        raise t.error(
            "duration",
            f"must be at most {MAX_DURATION:g} s (a day: split longer tests); got "
            f"{spec.duration!r}",
        )
    if spec.duration * spec.rate < 1.0:
        raise t.error(
            "duration",
            f"{spec.duration!r} s is shorter than one loop step (1/rate = {1 / spec.rate:g} s)",
        )
    return spec


def _component(t: Table, family: str) -> Component:
    """A ``kind`` of ``family`` and its options, validated against the registry."""
    kinds = registry(family)
    kind = t.choice("kind", kinds.names())
    return Component(kind, parse_options(t, kinds.get(kind).options))
