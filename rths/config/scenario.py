"""Scenario files: what a run is, parsed strictly into frozen specifications.

A scenario is a TOML file with these tables (all SI; see ``scenarios/*.toml`` for commented
examples users copy)::

    [run]          name, duration [s], rate [Hz], clock, seed
    [scaling]      displacement (specimen/prototype), force (prototype/specimen)
    [substructure] kind = "cable" + geometry; [substructure.load] (S0 Eq.22)
                   or kind = "tmdi" (S1 2-DOF + TMDI); [substructure.excitation] (stepped sine)
    [specimen]     the physical specimen in the emulated lab (the truth): kind, preset, effects
    [actuator]     kind = "transfer_function" | "servo_hydraulic", delay, velocity_limit, ...
    [lab]          converters: bits, range, calibrations, noise
    [model]        what the numerical side believes about the specimen: the nominal device the
                   substructure carries, the compensator's plant, the fully numerical mock run
    [compensator]  kind + options (controllers.factory)
    [loop]         correction_filter [Hz], stroke [m] (interlock)
    [monte_carlo]  draws (perturbed benchmark plants)

Every key is checked here, before any process starts: a typo, a wrong type or an out-of-range
value is a :class:`rths.core.errors.ConfigError` naming the file, the table and the key.  Physical
consistency (e.g. a preset name, a stable actuator) is checked when :mod:`rths.config.build` constructs the
plants, with the table named in the message.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rths.config.toml import Table, load_toml, parse_toml
from rths.core.scaling import Scaling

__all__ = [
    "CLOCKS",
    "ActuatorSpec",
    "CableSpec",
    "TMDISpec",
    "LabSpec",
    "LoopSpec",
    "ModelSpec",
    "RunSpec",
    "Scenario",
    "SpecimenSpec",
    "load_scenario",
    "parse_scenario",
]

CLOCKS = ("lockstep", "realtime", "fast")
SPECIMEN_KINDS = (
    "imd", "imd_simplified", "imd_internal", "linear", "benchmark", "rack_pinion", "ideal_inerter",
)
ACTUATOR_KINDS = ("transfer_function", "servo_hydraulic")
MODEL_KINDS = ("imd", "linear", "inerter", "none")


@dataclass(frozen=True)
class RunSpec:
    """``[run]``: name, duration [s], loop rate [Hz], clock and seed of the lab's noise."""

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
class CableSpec:
    """``[substructure]`` of kind ``cable``: taut cable (S0 §5.1) and its load (S0 Eq.22).

    ``elements`` None means "enough for the nominal device" (see :func:`rths.config.build.cable`).
    """

    length: float
    tension: float
    mass_per_length: float
    damper_position: float
    elements: int | None
    intrinsic_damping: float
    load_amplitude: float
    load_mode: int
    load_frequency: float | None  # Hz; None: the undamped cable's mode-n frequency


@dataclass(frozen=True)
class TMDISpec:
    """``[substructure]`` of kind ``tmdi``: the S1 primary structure + TMD (numerical) with the
    grounded inerter as the physical specimen, under a stepped-sine base acceleration (S1 §2.3).

    ``mass``: S1 Table 1 secondary mass (SM, IM, LM); ``flywheel`` (NF, IF, LF); ``isolators``:
    which S1 §4.2 identification of the HDRBs ("rack_pinion" or "ideal"); ``hdrb``: "viscous"
    (S1 §4.2) or "amplitude" (amplitude-dependent damping, plants.tmdi.hdrb); excitation: ``pga``
    [g], step ``frequencies`` [Hz] in playing order, ``cycles`` per step.
    """

    mass: str
    flywheel: str
    isolators: str
    pga: float
    frequencies: tuple[float, ...]
    cycles: int = 20
    hdrb: str = "viscous"


@dataclass(frozen=True)
class SpecimenSpec:
    """``[specimen]``: kind, optional preset and parameter overrides (specimen scale, SI)."""

    kind: str
    preset: str | None = None
    options: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class ActuatorSpec:
    """``[actuator]``: transfer system of the emulated lab.

    ``transfer_function``: ``num``/``den`` (or ``preset = "mts_identified"``) and optionally a
    different ``nominal_num``/``nominal_den`` for the compensator (identification error).
    ``servo_hydraulic``: ``preset`` (``benchmark`` | ``heavy_inertial_load``), parameter
    ``options`` and ``substeps``.  Both: ``delay`` [s], ``velocity_limit`` [m/s].
    """

    kind: str
    preset: str | None = None
    num: tuple[float, ...] | None = None
    den: tuple[float, ...] | None = None
    nominal_num: tuple[float, ...] | None = None
    nominal_den: tuple[float, ...] | None = None
    delay: float = 0.0
    velocity_limit: float | None = None
    substeps: int | None = None
    options: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class LabSpec:
    """``[lab]``: converters (bits, +/- full scale [V]), calibrations and noise [V RMS]."""

    bits: int = 16
    full_scale: float = 10.0
    displacement_per_volt: float = 0.0076
    force_per_volt: float = 220.0
    command_noise: float = 0.0
    displacement_noise: float = 5e-4
    force_noise: float = 1e-3


@dataclass(frozen=True)
class ModelSpec:
    """``[model]``: the numerical side's model of the device (specimen scale).

    ``imd``: ``inertance`` [kg], ``damping`` [N s/m] or ``damping_ratio`` (with the series
    stiffness), optional ``series_stiffness`` [N/m] (S0 Eq.12).  ``linear``: ``mass``,
    ``damping``, ``stiffness``.  ``none``: no nominal device (plain RTHS feedback).
    """

    kind: str
    inertance: float = 0.0
    damping: float = 0.0
    stiffness: float = 0.0
    series_stiffness: float | None = None


@dataclass(frozen=True)
class LoopSpec:
    """``[loop]``: low-pass on the force correction [Hz] (0: none) and the stroke interlock [m]."""

    correction_filter: float = 60.0
    stroke: float = math.inf


@dataclass(frozen=True)
class Scenario:
    """A parsed scenario (see the module docstring)."""

    source: str
    text: str
    run: RunSpec
    scaling: Scaling
    substructure: CableSpec | TMDISpec
    specimen: SpecimenSpec
    actuator: ActuatorSpec
    lab: LabSpec
    model: ModelSpec
    compensator_kind: str
    compensator_options: dict[str, Any]
    loop: LoopSpec
    monte_carlo_draws: int = 0


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario file (:class:`rths.core.errors.ConfigError` on any problem)."""
    doc, text = load_toml(path)
    return _parse(doc, text)


def parse_scenario(text: str, source: str = "<scenario>") -> Scenario:
    """Validate scenario text (for tests and for logs that carry the scenario)."""
    return _parse(parse_toml(text, source), text)


def _parse(doc: Table, text: str) -> Scenario:
    run = _run(doc.table("run"))
    t = doc.table("scaling", {})
    scaling = Scaling(
        t.number("displacement", 1.0, positive=True), t.number("force", 1.0, positive=True)
    )
    t.finish()
    sub = _substructure(doc.table("substructure"))
    specimen = _specimen(doc.table("specimen"))
    actuator = _actuator(doc.table("actuator"))
    lab = _lab(doc.table("lab", {}))
    model = _model(doc.table("model", {"kind": "none"}))
    comp = doc.table("compensator", {"kind": "ff_lqg"})
    kind = comp.string("kind")
    options = comp.rest()
    t = doc.table("loop", {})
    loop = LoopSpec(
        t.number("correction_filter", 60.0, nonnegative=True),
        t.number("stroke", math.inf, positive=True),
    )
    t.finish()
    t = doc.table("monte_carlo", {})
    draws = t.integer("draws", 0, minimum=0)
    t.finish()
    doc.finish()
    if loop.correction_filter and loop.correction_filter >= 0.5 * run.rate:
        raise doc.table("loop").error(
            "correction_filter",
            f"must lie below the Nyquist frequency {0.5 * run.rate:g} Hz; "
            f"got {loop.correction_filter!r}",
        )
    return Scenario(
        doc.source, text, run, scaling, sub, specimen, actuator, lab, model, kind, options, loop,
        draws,
    )  # fmt: skip


def _run(t: Table) -> RunSpec:
    spec = RunSpec(
        name=t.string("name"),
        duration=t.number("duration", positive=True),
        rate=t.number("rate", positive=True),
        clock=t.choice("clock", CLOCKS, default="lockstep"),
        seed=t.integer("seed", 0, minimum=0),
    )
    t.finish()
    return spec


def _substructure(t: Table) -> CableSpec | TMDISpec:
    kind = t.choice("kind", ("cable", "tmdi"))
    return _cable(t) if kind == "cable" else _tmdi(t)


def _tmdi(t: Table) -> TMDISpec:
    ex = t.table("excitation")
    spec = TMDISpec(
        mass=t.choice("mass", ("SM", "IM", "LM")),
        flywheel=t.choice("flywheel", ("NF", "IF", "LF")),
        isolators=t.choice("isolators", ("rack_pinion", "ideal"), default="rack_pinion"),
        pga=ex.number("pga", positive=True),
        frequencies=tuple(ex.numbers("frequencies")),
        cycles=ex.integer("cycles", 20, minimum=1),
        hdrb=t.choice("hdrb", ("viscous", "amplitude"), default="viscous"),
    )
    if any(f <= 0 for f in spec.frequencies):
        raise ex.error("frequencies", f"must be positive; got {list(spec.frequencies)!r}")
    ex.finish()
    t.finish()
    return spec


def _cable(t: Table) -> CableSpec:
    elements: Any = t.raw("elements", "auto")
    if elements != "auto" and (isinstance(elements, bool) or not isinstance(elements, int)
                               or elements < 2):  # fmt: skip
        raise t.error("elements", f'must be an integer >= 2 or "auto"; got {elements!r}')
    load = t.table("load", {})
    frequency = load.number("frequency", None, positive=True)
    spec = CableSpec(
        length=t.number("length", positive=True),
        tension=t.number("tension", positive=True),
        mass_per_length=t.number("mass_per_length", positive=True),
        damper_position=t.number("damper_position", lo=1e-6, hi=1 - 1e-6),
        elements=None if elements == "auto" else elements,
        intrinsic_damping=t.number("intrinsic_damping", 0.001, lo=0.0, hi=0.99),
        load_amplitude=load.number("amplitude", 0.0),
        load_mode=load.integer("mode", 1, minimum=1),
        load_frequency=frequency,
    )
    load.finish()
    t.finish()
    return spec


def _specimen(t: Table) -> SpecimenSpec:
    kind = t.choice("kind", SPECIMEN_KINDS)
    preset = t.string("preset", None)
    return SpecimenSpec(kind, preset, t.rest())


def _numbers(t: Table, key: str) -> tuple[float, ...] | None:
    values = t.numbers(key, None)
    return None if values is None else tuple(values)


def _actuator(t: Table) -> ActuatorSpec:
    kind = t.choice("kind", ACTUATOR_KINDS)
    spec = ActuatorSpec(
        kind=kind,
        preset=t.string("preset", None),
        num=_numbers(t, "num"),
        den=_numbers(t, "den"),
        nominal_num=_numbers(t, "nominal_num"),
        nominal_den=_numbers(t, "nominal_den"),
        delay=t.number("delay", 0.0, nonnegative=True),
        velocity_limit=t.number("velocity_limit", None, positive=True),
        substeps=t.integer("substeps", None, minimum=1),
        options=t.rest(),
    )
    if kind == "transfer_function":
        if (spec.num is None) != (spec.den is None) or (spec.num is None and spec.preset is None):
            raise t.error("num", "give both num and den, or a preset")
        if (spec.nominal_num is None) != (spec.nominal_den is None):
            raise t.error("nominal_num", "give both nominal_num and nominal_den, or neither")
        if spec.options:
            raise t.error(next(iter(spec.options)), "unknown key for a transfer_function actuator")
    elif spec.num is not None or spec.nominal_num is not None:
        raise t.error("num", "only a transfer_function actuator takes num/den")
    return spec


def _lab(t: Table) -> LabSpec:
    d = LabSpec()
    spec = LabSpec(
        bits=t.integer("bits", d.bits, minimum=1),
        full_scale=t.number("full_scale", d.full_scale, positive=True),
        displacement_per_volt=t.number("displacement_per_volt", d.displacement_per_volt,
                                       positive=True),  # fmt: skip
        force_per_volt=t.number("force_per_volt", d.force_per_volt, positive=True),
        command_noise=t.number("command_noise", d.command_noise, nonnegative=True),
        displacement_noise=t.number("displacement_noise", d.displacement_noise, nonnegative=True),
        force_noise=t.number("force_noise", d.force_noise, nonnegative=True),
    )
    t.finish()
    return spec


def _model(t: Table) -> ModelSpec:
    kind = t.choice("kind", MODEL_KINDS)
    if kind == "none":
        t.finish()
        return ModelSpec("none")
    if kind == "inerter":
        spec = ModelSpec(
            "inerter",
            inertance=t.number("inertance", nonnegative=True),
            damping=t.number("damping", 0.0, nonnegative=True),
        )
        t.finish()
        return spec
    if kind == "linear":
        spec = ModelSpec(
            "linear",
            inertance=t.number("mass", nonnegative=True),
            damping=t.number("damping", 0.0, nonnegative=True),
            stiffness=t.number("stiffness", 0.0, nonnegative=True),
        )
        t.finish()
        return spec
    inertance = t.number("inertance", positive=True)
    series = t.number("series_stiffness", None, positive=True)
    damping = t.number("damping", None, nonnegative=True)
    ratio = t.number("damping_ratio", None, lo=0.0, hi=10.0)
    if damping is not None and ratio is not None:
        raise t.error("damping_ratio", "give damping or damping_ratio, not both")
    if ratio is not None:
        if series is None:
            raise t.error("damping_ratio", "needs series_stiffness (c = 2 xi sqrt(k m))")
        damping = 2.0 * ratio * math.sqrt(series * inertance)
    t.finish()
    return ModelSpec("imd", inertance=inertance, damping=damping or 0.0, series_stiffness=series)
