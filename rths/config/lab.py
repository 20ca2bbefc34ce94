"""The ``[lab]`` and ``[model]`` tables of a scenario: the emulated lab's converters
(:class:`LabSpec`, which :mod:`rths.config.build` turns into :class:`plants.lab.LabConverters`) and
what the numerical side believes about the specimen (a :class:`plants.device_model.DeviceModel`:
the nominal device the substructure carries, the compensator's plant, the fully numerical mock
run).  Parsed strictly, like the rest of the scenario (:mod:`rths.config.scenario`): a bad key is
a :class:`rths.core.errors.ConfigError` naming the file, the table and the key.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from plants.device_model import DeviceModel
from rths.config.toml import Table
from rths.core.errors import ConfigError, ParameterError

__all__ = ["MAX_RANGE", "MODEL_KINDS", "LabSpec", "parse_lab", "parse_model"]

#: Largest displacement range [m] and force range [N] of the lab's converters (the
#: calibration times the full scale): beyond them no actuator or load cell exists.
MAX_RANGE = {"displacement_per_volt": 10.0, "force_per_volt": 1e9}
#: Kinds of ``[model]`` (what the numerical side believes about the specimen).
MODEL_KINDS = ("imd", "linear", "inerter", "none")


@dataclass(frozen=True)
class LabSpec:
    """``[lab]``: converters (bits, +/- full scale [V]), calibrations and noise [V RMS].

    The command DAC and the displacement ADC share ``displacement_per_volt``; the force ADC uses
    ``force_per_volt`` (:class:`plants.lab.Converter`).

    Attributes
    ----------
    bits : int
        Converter resolution [bits], >= 1 (default 16; vRTHS benchmark: 18).
    full_scale : float
        Converter input range ``+/- full_scale`` [V], > 0 (default 10; benchmark: 3.8).
    displacement_per_volt : float
        Displacement calibration [m/V], > 0 (default 0.0076); ``displacement_per_volt *
        full_scale`` at most 10 m.
    force_per_volt : float
        Load-cell calibration [N/V], > 0 (default 220); ``force_per_volt * full_scale`` at
        most 1e9 N.
    command_noise : float
        RMS of the noise on the command DAC [V], 0 .. ``full_scale`` (default 0).
    displacement_noise : float
        RMS of the noise on the displacement ADC [V], 0 .. ``full_scale`` (default 5e-4).
    force_noise : float
        RMS of the noise on the force ADC [V], 0 .. ``full_scale`` (default 1e-3).
    """

    bits: int = 16
    full_scale: float = 10.0
    displacement_per_volt: float = 0.0076
    force_per_volt: float = 220.0
    command_noise: float = 0.0
    displacement_noise: float = 5e-4
    force_noise: float = 1e-3


def parse_lab(t: Table) -> LabSpec:
    """``[lab]``, every key checked: noise within the full scale, ranges within any sensor's.

    Parameters
    ----------
    t
        The ``[lab]`` table (an empty one gives the defaults).
    """
    d = LabSpec()
    spec = LabSpec(
        bits=t.integer("bits", d.bits, minimum=1),
        full_scale=t.number("full_scale", d.full_scale, positive=True),
        displacement_per_volt=t.number(
            "displacement_per_volt", d.displacement_per_volt, positive=True
        ),
        force_per_volt=t.number("force_per_volt", d.force_per_volt, positive=True),
        command_noise=t.number("command_noise", d.command_noise, nonnegative=True),
        displacement_noise=t.number("displacement_noise", d.displacement_noise, nonnegative=True),
        force_noise=t.number("force_noise", d.force_noise, nonnegative=True),
    )
    t.finish()
    for key in ("command_noise", "displacement_noise", "force_noise"):
        if getattr(spec, key) > spec.full_scale:
            raise t.error(
                key,
                f"{getattr(spec, key)!r} V RMS exceeds the converters' full scale "
                f"{spec.full_scale!r} V",
            )
    for key, largest in MAX_RANGE.items():
        span = getattr(spec, key) * spec.full_scale
        if span > largest:
            raise t.error(
                key,
                f"{getattr(spec, key)!r} per volt x full scale {spec.full_scale!r} V = a range of "
                f"{span:.3g}, beyond any sensor (at most {largest:g} SI units)",
            )
    return spec


def parse_model(t: Table) -> DeviceModel | None:
    """``[model]``: the nominal device (specimen scale), or None for ``kind = "none"``.

    Parameters
    ----------
    t
        The ``[model]`` table: ``kind`` (:data:`MODEL_KINDS`) and that kind's keys.
    """
    kind = t.choice("kind", MODEL_KINDS)
    if kind == "none":
        t.finish()
        return None
    try:
        return _device(t, kind)
    except ParameterError as exc:
        raise ConfigError(f"{t.source}: [model] {exc}") from None


def _device(t: Table, kind: str) -> DeviceModel:
    if kind == "inerter":
        model = DeviceModel(
            "inerter",
            inertance=t.number("inertance", nonnegative=True),
            damping=t.number("damping", 0.0, nonnegative=True),
        )
    elif kind == "linear":
        model = DeviceModel(
            "linear",
            inertance=t.number("mass", nonnegative=True),
            damping=t.number("damping", 0.0, nonnegative=True),
            stiffness=t.number("stiffness", 0.0, nonnegative=True),
        )
    else:
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
        model = DeviceModel("imd", inertance, damping or 0.0, series_stiffness=series)
    t.finish()
    return model
