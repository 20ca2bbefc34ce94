"""Build the plants, the emulated lab and the compensator of a :class:`rths.config.scenario.Scenario`.

The coordinator (``rths run``) builds the substructure and the compensator; the specimen process
(``rths specimen``) builds the lab from the same scenario file; the fully numerical "mock" run and
the Monte-Carlo draws reuse the same functions, so every consumer sees the same plants.  A
parameter a plant rejects becomes a :class:`rths.core.errors.ConfigError` that names the scenario file
and the table.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import fields, replace
from typing import Any

import control
import numpy as np

from controllers.base import Compensator
from controllers.factory import make_compensator
from plants.actuator.models import (
    BENCHMARK,
    HEAVY_INERTIAL_LOAD,
    MTS_IDENTIFIED,
    BenchmarkParameters,
    ServoHydraulicActuator,
    TransferFunctionActuator,
)
from plants.base import Actuator, Specimen
from plants.cable.model import (
    Cable,
    CableProperties,
    DistributedLoad,
    InterfaceDevice,
    RayleighDamping,
    elements_for,
)
from plants.excitation.stepped_sine import stepped_sine_acceleration
from plants.imd.models import IMDParameters, imd_from_parameters
from plants.lab import Converter, EmulatedLab, LabConverters
from plants.linear_specimen import BenchmarkSpecimenParameters, LinearSpecimen
from plants.tmdi.inerter import IdealInerter, RackPinionInerter, rack_pinion_preset
from plants.tmdi.structure import NominalInerter, TMDISubstructure, s1_configuration
from rths.config.scenario import CableSpec, Scenario, TMDISpec
from rths.core.errors import ConfigError, ParameterError
from rths.core.filters import LowPass

__all__ = [
    "actuator",
    "cable",
    "cable_properties",
    "compensator",
    "converters",
    "correction_filter",
    "lab",
    "model_stiffness",
    "nominal_device",
    "nominal_plant",
    "specimen",
    "substructure",
    "tmdi",
]

_ACTUATOR_PRESETS = {"benchmark": BENCHMARK, "heavy_inertial_load": HEAVY_INERTIAL_LOAD}
_TF_PRESETS = {"mts_identified": MTS_IDENTIFIED}


@contextmanager
def _table(scn: Scenario, name: str) -> Iterator[None]:
    """Re-raise a plant's ParameterError as a ConfigError naming the scenario table."""
    try:
        yield
    except ParameterError as exc:
        raise ConfigError(f"{scn.source}: [{name}] {exc}") from None
    except TypeError as exc:  # unknown keyword in an options table
        raise ConfigError(f"{scn.source}: [{name}] {exc}") from None


# ---------------------------------------------------------------------------------- structure
def cable_properties(scn: Scenario) -> CableProperties:
    """Tension, mass per length and length of the scenario's cable."""
    s = scn.substructure
    assert isinstance(s, CableSpec)
    with _table(scn, "substructure"):
        return CableProperties(length=s.length, tension=s.tension, mass_per_length=s.mass_per_length)


def nominal_device(scn: Scenario) -> InterfaceDevice | NominalInerter | None:
    """The ``[model]`` device at prototype scale (impedances times ``scaling.impedance``):
    an :class:`plants.cable.model.InterfaceDevice` for a cable, a :class:`plants.tmdi.structure.NominalInerter`
    for the TMDI structure."""
    m, lam = scn.model, scn.scaling.impedance
    tmdi = isinstance(scn.substructure, TMDISpec)
    with _table(scn, "model"):
        if m.kind == "none":
            return None
        if tmdi != (m.kind == "inerter"):
            kinds = "'inerter'" if tmdi else "'imd' or 'linear'"
            raise ParameterError(f"a {'tmdi' if tmdi else 'cable'} substructure takes a model of "
                                 f"kind {kinds} (or 'none'); got {m.kind!r}")  # fmt: skip
        if m.kind == "inerter":
            return NominalInerter(lam * m.inertance, lam * m.damping)
        if m.kind == "linear":
            return InterfaceDevice(
                inertance=lam * m.inertance, damping=lam * m.damping, stiffness=lam * m.stiffness
            )
        if m.series_stiffness is None:
            return InterfaceDevice(inertance=lam * m.inertance, damping=lam * m.damping)
        return InterfaceDevice(
            series_stiffness=lam * m.series_stiffness,
            series_inertance=lam * m.inertance,
            series_damping=lam * m.damping,
        )


def cable(scn: Scenario, device: InterfaceDevice | None | str = "model") -> Cable:
    """The scenario's cable carrying ``device`` (default: the ``[model]`` nominal device).

    With ``elements = "auto"`` the mesh is the finest of 100 elements and what the nominal
    device's series stiffness needs for the damper node to radiate (``plants.cable.model.elements_for``).
    """
    s = scn.substructure
    assert isinstance(s, CableSpec)
    props = cable_properties(scn)
    dev = nominal_device(scn) if device == "model" else device
    with _table(scn, "substructure"):
        n = s.elements
        if n is None:
            stiff = getattr(dev, "series_stiffness", None) if dev is not None else None
            n = elements_for(props, s.damper_position, stiff, minimum=100)
        omega = None if s.load_frequency is None else 2.0 * math.pi * s.load_frequency
        return Cable(
            props,
            s.damper_position,
            scn.run.dt,
            elements=n,
            load=DistributedLoad(amplitude=s.load_amplitude, mode=s.load_mode, frequency=omega),
            intrinsic_damping=RayleighDamping(s.intrinsic_damping) if s.intrinsic_damping else None,
            damper=dev,
        )


def tmdi(scn: Scenario, device: NominalInerter | None | str = "model") -> TMDISubstructure:
    """The S1 primary structure + TMD under the stepped-sine excitation, carrying ``device``."""
    s = scn.substructure
    assert isinstance(s, TMDISpec)
    dev = nominal_device(scn) if device == "model" else device
    with _table(scn, "substructure"):
        params, _ = s1_configuration(s.mass, s.flywheel, s.isolators, hdrb=s.hdrb)
        ground = stepped_sine_acceleration(s.frequencies, s.pga, s.cycles)
        return TMDISubstructure(params, ground, scn.run.dt, device=dev)


def substructure(scn: Scenario, device: Any = "model") -> Cable | TMDISubstructure:
    """The scenario's numerical substructure carrying ``device`` (default: the ``[model]``)."""
    if isinstance(scn.substructure, TMDISpec):
        return tmdi(scn, device)
    return cable(scn, device)


# ---------------------------------------------------------------------------------- specimen
def specimen(scn: Scenario, rng: np.random.Generator | None = None) -> Specimen:
    """The physical specimen of the emulated lab (``rng`` draws a perturbed benchmark one)."""
    sp = scn.specimen
    with _table(scn, "specimen"):
        if sp.kind in ("imd", "imd_simplified", "imd_internal"):
            options = dict(sp.options)
            if sp.preset is not None:
                params = IMDParameters.preset(sp.preset, **options)
            else:
                params = IMDParameters(**options)
            return imd_from_parameters(params, sp.kind)
        if sp.kind == "linear":
            known = {"mass", "damping", "stiffness"}
            bad = set(sp.options) - known
            if bad:
                raise ParameterError(f"unknown key {sorted(bad)[0]!r}; expected one of {sorted(known)}")
            return LinearSpecimen(**sp.options)
        if sp.kind == "rack_pinion":
            return RackPinionInerter(replace(rack_pinion_preset(sp.preset or "IF"), **sp.options))
        if sp.kind == "ideal_inerter":
            return IdealInerter(**sp.options)
        base = BenchmarkSpecimenParameters(**sp.options)
        return (base.sample(rng) if rng is not None else base).specimen()


def model_stiffness(scn: Scenario) -> control.TransferFunction | float:
    """Dynamic stiffness ``K(s) = F/x`` [N/m] of the ``[model]`` device, specimen scale."""
    m = scn.model
    s = control.tf("s")
    if m.kind == "none":
        return 0.0
    if m.kind == "linear":
        return m.inertance * s**2 + m.damping * s + m.stiffness
    if m.kind == "inerter" or m.series_stiffness is None:
        return m.inertance * s**2 + m.damping * s
    k, flywheel = m.series_stiffness, m.inertance * s**2 + m.damping * s
    return k * flywheel / (flywheel + k)


# ---------------------------------------------------------------------------------- actuator
def _servo_parameters(scn: Scenario) -> BenchmarkParameters:
    a = scn.actuator
    base = _ACTUATOR_PRESETS.get(a.preset or "benchmark")
    if base is None:
        raise ParameterError(
            f"unknown servo_hydraulic preset {a.preset!r}; choose one of {sorted(_ACTUATOR_PRESETS)}"
        )
    known = {f.name for f in fields(BenchmarkParameters)}
    bad = set(a.options) - known
    if bad:
        raise ParameterError(f"unknown key {sorted(bad)[0]!r}; expected one of {sorted(known)}")
    return replace(base, **a.options)


def _tf(scn: Scenario) -> tuple[tuple[float, ...], tuple[float, ...]]:
    a = scn.actuator
    if a.num is not None and a.den is not None:
        return a.num, a.den
    preset = _TF_PRESETS.get(a.preset or "")
    if preset is None:
        raise ParameterError(
            f"unknown transfer_function preset {a.preset!r}; choose one of {sorted(_TF_PRESETS)}"
        )
    return preset.num, preset.den


def actuator(
    scn: Scenario, spec: Specimen, rng: np.random.Generator | None = None
) -> Actuator:
    """The lab's actuator driving ``spec`` (``rng``: a Monte-Carlo draw of the benchmark)."""
    a, dt = scn.actuator, scn.run.dt
    with _table(scn, "actuator"):
        if a.kind == "transfer_function":
            num, den = _tf(scn)
            return TransferFunctionActuator(
                list(num), list(den), spec, dt, delay=a.delay, velocity_limit=a.velocity_limit
            )
        params = _servo_parameters(scn)
        if rng is not None:
            params = params.sample(rng)
        return ServoHydraulicActuator(
            spec, dt, params, substeps=a.substeps, delay=a.delay, velocity_limit=a.velocity_limit
        )


def nominal_plant(scn: Scenario) -> tuple[control.TransferFunction, float]:
    """The compensator's command→measured model and its transport delay [s].

    A transfer-function actuator is its own nominal (or ``nominal_num``/``nominal_den``); a
    servo-hydraulic one is linearised with the ``[model]`` device as the specimen (the lab
    engineer identifies the transfer system with the specimen installed).
    """
    a = scn.actuator
    with _table(scn, "actuator"):
        if a.kind == "transfer_function":
            if a.nominal_num is not None and a.nominal_den is not None:
                return control.tf(list(a.nominal_num), list(a.nominal_den)), a.delay
            num, den = _tf(scn)
            return control.tf(list(num), list(den)), a.delay
        m = scn.model
        remainder: Any = None
        if m.kind == "linear":
            device = LinearSpecimen(m.inertance, m.damping, m.stiffness)
        elif m.kind == "inerter" or (m.kind == "imd" and m.series_stiffness is None):
            device = LinearSpecimen(m.inertance, m.damping, 0.0)
        else:
            device = LinearSpecimen(0.0, 0.0, 0.0)
            remainder = model_stiffness(scn) if m.kind == "imd" else None
        act = ServoHydraulicActuator(device, scn.run.dt, _servo_parameters(scn))
        return control.minreal(act.transfer_function(remainder), verbose=False), a.delay


# ---------------------------------------------------------------------------------- lab, loop
def converters(scn: Scenario) -> LabConverters:
    """DAC and ADC channels of ``[lab]``."""
    c = scn.lab
    with _table(scn, "lab"):
        return LabConverters(
            command=Converter(c.displacement_per_volt, c.bits, c.full_scale, c.command_noise),
            displacement=Converter(
                c.displacement_per_volt, c.bits, c.full_scale, c.displacement_noise
            ),
            force=Converter(c.force_per_volt, c.bits, c.full_scale, c.force_noise),
        )


def lab(
    scn: Scenario, seed: int | None = None, rng: np.random.Generator | None = None
) -> EmulatedLab:
    """The emulated lab (specimen behind the actuator, converters, noise seeded by ``seed``).

    ``rng`` draws the specimen and actuator of a Monte-Carlo sample.
    """
    spec = specimen(scn, rng)
    return EmulatedLab(
        actuator(scn, spec, rng), converters(scn), seed=scn.run.seed if seed is None else seed
    )


def compensator(scn: Scenario, kind: str | None = None, extra_delay: float = 0.0) -> Compensator:
    """The ``[compensator]`` (or ``kind`` with default options) on the nominal plant.

    ``extra_delay`` [s] is added to the nominal plant's transport delay (e.g. the realtime link's).
    """
    plant, delay = nominal_plant(scn)
    delay += extra_delay
    options = dict(scn.compensator_options) if kind is None else {}
    with _table(scn, "compensator"):
        return make_compensator(kind or scn.compensator_kind, scn.run.dt, plant, delay=delay,
                                **options)  # fmt: skip


def correction_filter(scn: Scenario) -> LowPass | None:
    """The low-pass on the force correction (None when ``correction_filter = 0``)."""
    f = scn.loop.correction_filter
    with _table(scn, "loop"):
        return LowPass(f, scn.run.dt) if f > 0 else None
