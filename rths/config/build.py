"""Build the plants, the emulated lab and the compensator of a
:class:`rths.config.scenario.Scenario`.

Every component is built through its registry (:mod:`rths.core.registry`): the scenario names
a kind, the kind's factory receives the validated options and the family's context.  The
coordinator (``rths run``) builds the substructure and the compensator; the specimen process
(``rths specimen``) builds the lab from the same scenario file; the fully numerical "mock" run
and the Monte-Carlo draws reuse the same functions, so every consumer sees the same plants.  A
parameter a plant rejects becomes a :class:`rths.core.errors.ConfigError` that names the
scenario file and the table.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import control
import numpy as np

from controllers.base import Compensator
from plants.actuator.base import Actuator
from plants.base import Specimen, Substructure
from plants.lab import Converter, EmulatedLab, LabConverters
from rths.config.kinds import registry
from rths.config.scenario import Scenario
from rths.core.errors import ConfigError, ParameterError
from rths.core.filters import LowPass
from rths.runtime.guard import GuardLimits

__all__ = [
    "actuator",
    "compensator",
    "converters",
    "correction_filter",
    "guard_limits",
    "lab",
    "model_stiffness",
    "nominal_device",
    "nominal_plant",
    "specimen",
    "substructure",
]


@contextmanager
def _table(scn: Scenario, name: str) -> Iterator[None]:
    """Re-raise a plant's ParameterError as a ConfigError naming the scenario table."""
    try:
        yield
    except ParameterError as exc:
        raise ConfigError(f"{scn.source}: [{name}] {exc}") from None


# ---------------------------------------------------------------------------------- structure
def nominal_device(scn: Scenario) -> object | None:
    """The ``[model]`` device at prototype scale (impedances times ``scaling.impedance``), in
    the form the substructure kind carries it (its ``nominal_device``); None for no model.

    Parameters
    ----------
    scn : rths.config.scenario.Scenario
        The parsed scenario.
    """
    target = registry("substructure").get(scn.substructure.kind).target
    model = None if scn.model is None else scn.model.scaled(scn.scaling.impedance)
    with _table(scn, "model"):
        convert = getattr(target, "nominal_device", None)
        if convert is None:
            if model is not None:
                raise ParameterError(
                    f"substructure kind {scn.substructure.kind!r} carries no nominal device; "
                    f'use kind = "none"'
                )
            return None
        return convert(model)


def substructure(scn: Scenario, device: Any = "model") -> Substructure:
    """The scenario's numerical substructure carrying ``device`` (default: the ``[model]``).

    Parameters
    ----------
    scn : rths.config.scenario.Scenario
        The parsed scenario.
    device : object
        The damper the substructure carries, in the form its kind takes (see
        :func:`nominal_device`), or ``None`` for a bare substructure; the default ``"model"``
        installs the ``[model]`` device at prototype scale.
    """
    dev = nominal_device(scn) if isinstance(device, str) and device == "model" else device
    kind = registry("substructure").get(scn.substructure.kind)
    with _table(scn, "substructure"):
        built: Substructure = kind.build(scn.substructure.options, dt=scn.run.dt, device=dev)
    return built


# ---------------------------------------------------------------------------------- specimen
def specimen(scn: Scenario, rng: np.random.Generator | None = None) -> Specimen:
    """The physical specimen of the emulated lab (``rng``: a Monte-Carlo draw).

    Parameters
    ----------
    scn : rths.config.scenario.Scenario
        The parsed scenario.
    rng : numpy.random.Generator or None
        Draws the specimen's perturbed parameters of a Monte-Carlo sample; None (default)
        builds the nominal specimen.
    """
    kind = registry("specimen").get(scn.specimen.kind)
    with _table(scn, "specimen"):
        built: Specimen = kind.build(scn.specimen.options, rng=rng)
    return built


def model_stiffness(scn: Scenario) -> control.TransferFunction | float:
    """Dynamic stiffness ``K(s) = F/x`` [N/m] of the ``[model]`` device, specimen scale.

    Parameters
    ----------
    scn : rths.config.scenario.Scenario
        The parsed scenario.
    """
    return 0.0 if scn.model is None else scn.model.dynamic_stiffness()


# ---------------------------------------------------------------------------------- actuator
def actuator(scn: Scenario, spec: Specimen, rng: np.random.Generator | None = None) -> Actuator:
    """The lab's actuator driving ``spec`` (``rng``: a Monte-Carlo draw).

    Parameters
    ----------
    scn : rths.config.scenario.Scenario
        The parsed scenario.
    spec : plants.base.Specimen
        The specimen the actuator drives (its force couples back: control-structure
        interaction).
    rng : numpy.random.Generator or None
        Draws the actuator's perturbed parameters of a Monte-Carlo sample; None (default)
        builds the nominal actuator.
    """
    kind = registry("actuator").get(scn.actuator.kind)
    with _table(scn, "actuator"):
        built: Actuator = kind.build(scn.actuator.options, specimen=spec, dt=scn.run.dt, rng=rng)
    return built


def nominal_plant(scn: Scenario) -> tuple[control.TransferFunction, float]:
    """The compensator's command→measured model and its transport delay [s] (the actuator
    kind's ``nominal_plant`` with the ``[model]`` device installed).

    Parameters
    ----------
    scn : rths.config.scenario.Scenario
        The parsed scenario.
    """
    target = registry("actuator").get(scn.actuator.kind).target
    with _table(scn, "actuator"):
        plant: tuple[control.TransferFunction, float] = target.nominal_plant(
            scn.actuator.options, model=scn.model, dt=scn.run.dt
        )
    return plant


# ---------------------------------------------------------------------------------- lab, loop
def converters(scn: Scenario) -> LabConverters:
    """DAC and ADC channels of ``[lab]``.

    Parameters
    ----------
    scn : rths.config.scenario.Scenario
        The parsed scenario.
    """
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

    Parameters
    ----------
    scn : rths.config.scenario.Scenario
        The parsed scenario.
    seed : int or None
        Seed of the converters' noise; None (default) takes ``[run] seed``.
    rng : numpy.random.Generator or None
        Draws the specimen and actuator of a Monte-Carlo sample; None (default): nominal.
    """
    spec = specimen(scn, rng)
    return EmulatedLab(
        actuator(scn, spec, rng), converters(scn), seed=scn.run.seed if seed is None else seed
    )


def compensator(scn: Scenario, kind: str | None = None, extra_delay: float = 0.0) -> Compensator:
    """The ``[compensator]`` (or ``kind`` with its default options) on the nominal plant.

    ``extra_delay`` [s] is added to the nominal plant's transport delay (e.g. the realtime link's).

    Parameters
    ----------
    scn : rths.config.scenario.Scenario
        The parsed scenario.
    kind : str or None
        A registered compensator kind to build instead, with its default options; None
        (default) builds the ``[compensator]`` table's kind with its options.
    extra_delay : float
        Delay [s] added to the nominal plant's transport delay (default 0).
    """
    plant, delay = nominal_plant(scn)
    name = scn.compensator.kind if kind is None else kind
    entry = registry("compensator").get(name)
    options = scn.compensator.options if name == scn.compensator.kind else entry.options()
    with _table(scn, "compensator"):
        built: Compensator = entry.build(
            options, dt=scn.run.dt, nominal=plant, delay=delay + extra_delay
        )
    return built


def correction_filter(scn: Scenario) -> LowPass | None:
    """The low-pass on the force correction (None when ``correction_filter = 0``).

    Parameters
    ----------
    scn : rths.config.scenario.Scenario
        The parsed scenario.
    """
    f = scn.loop.correction_filter
    with _table(scn, "loop"):
        return LowPass(f, scn.run.dt) if f > 0 else None


def guard_limits(scn: Scenario) -> GuardLimits:
    """The specimen side's command guard (:mod:`rths.runtime.guard`) from ``[loop]``.

    Parameters
    ----------
    scn : rths.config.scenario.Scenario
        The parsed scenario.
    """
    lp = scn.loop
    with _table(scn, "loop"):
        return GuardLimits(lp.stroke, lp.max_velocity, lp.ramp_velocity)
