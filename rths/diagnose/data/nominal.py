"""``NOMINAL.toml``: what the "sim" believes about the transfer system and the specimen.

Format (design.md section 7; every key below is required except ``delay``, ``damping``,
``stiffness``, ``friction`` and the two amplitude-damping keys, which default to 0; unknown keys
are errors)::

    [actuator]            # measured/command, continuous-time TF, descending powers of s
    num = [b0]
    den = [1.0, a2, a1, a0]
    delay = 0.0           # s
    [specimen]            # F = inertance*a + damping*v + stiffness*x + friction*sign(v)
    inertance = 1500.0    # kg
    damping = 0.0         # N s/m
    stiffness = 0.0       # N/m
    friction = 0.0        # N
    amplitude_c1 = 0.0    # N s  } optional amplitude-dependent damping c1/(A + c2)
    amplitude_c2 = 1e-3   # m    } (S0 Eq.17-18 form), A the running load amplitude

The specimen form is the simplified IMD of S0 Eq.1 plus a parallel spring.  What the file
declares is the baseline: the diagnosis re-calibrates these parameters (and the actuator's
gain, pole frequencies, pole damping, offsets and a +/-1 sample alignment) and calls everything
else an effect -- e.g. ``amplitude_damping`` is an effect unless ``amplitude_c1`` is declared.
Errors are :class:`rths.core.errors.ConfigError` naming the file, the table, the key and the value.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rths.config.toml import Table, load_toml, parse_toml
from rths.core.errors import ParameterError

__all__ = [
    "ActuatorNominal",
    "NominalModel",
    "SpecimenNominal",
    "load_nominal",
    "nominal_toml",
    "parse_nominal",
]


@dataclass(frozen=True)
class ActuatorNominal:
    """Nominal command→measured-displacement model ``e^{-s delay} num(s)/den(s)``.

    Attributes
    ----------
    num, den
        Coefficients in descending powers of ``s`` [m/m]; proper and stable.
    delay
        Pure delay [s], >= 0.
    """

    num: tuple[float, ...]
    den: tuple[float, ...]
    delay: float = 0.0

    @property
    def dc_gain(self) -> float:
        """``num(0)/den(0)`` [-]."""
        return float(self.num[-1] / self.den[-1])


@dataclass(frozen=True)
class SpecimenNominal:
    """Nominal specimen ``F = m a + c v + k x + F_r sign(v)`` (S0 Eq.1 with a parallel spring).

    Attributes
    ----------
    inertance
        ``m`` [kg], >= 0.
    damping
        ``c`` [N s/m], >= 0.
    stiffness
        ``k`` [N/m] (any sign: a negative value is a negative-stiffness device).
    friction
        ``F_r`` [N], >= 0.
    amplitude_c1, amplitude_c2
        Amplitude-dependent damping ``c1/(A + c2)`` [N s], [m] (S0 Eq.17-18 form; ``c1 = 0``:
        none declared), ``c2 > 0``.
    """

    inertance: float
    damping: float = 0.0
    stiffness: float = 0.0
    friction: float = 0.0
    amplitude_c1: float = 0.0
    amplitude_c2: float = 1e-3

    @property
    def declares_amplitude_damping(self) -> bool:
        """Whether the nominal holds an amplitude-dependent damping (then it is baseline)."""
        return self.amplitude_c1 > 0.0


@dataclass(frozen=True)
class NominalModel:
    """The nominal transfer system and specimen (the two tables of ``NOMINAL.toml``).

    Attributes
    ----------
    actuator
        The ``[actuator]`` table: command -> measured displacement.
    specimen
        The ``[specimen]`` table: measured displacement -> force.
    source
        Where the model came from (a path or ``"<nominal>"``), named in errors.
    """

    actuator: ActuatorNominal
    specimen: SpecimenNominal
    source: str = "<nominal>"


#: Longest nominal transport delay [s]: no servo-hydraulic actuator lags by more.
MAX_DELAY = 1.0
#: Largest magnitude of a specimen parameter (SI): beyond it a number is not a device's.
MAX_VALUE = 1e12


def _actuator(t: Table) -> ActuatorNominal:
    num = t.numbers("num")
    den = t.numbers("den")
    delay = t.number("delay", 0.0, nonnegative=True, hi=MAX_DELAY)
    t.finish()
    while len(num) > 1 and num[0] == 0.0:
        num = num[1:]
    if den[0] == 0.0:
        raise t.error("den", f"leading coefficient must be non-zero; got {den!r}")
    if not any(num):
        raise t.error("num", f"must not be all zero; got {num!r}")
    if len(num) > len(den):
        raise t.error(
            "num",
            f"transfer function must be proper (len(num) <= len(den)); got num={num!r}, "
            f"den={den!r}",
        )
    with np.errstate(all="ignore"):
        poles = np.roots(den) if len(den) > 1 else np.array([])
        gain = num[-1] / den[-1] if den[-1] else np.inf
    if not (np.all(np.isfinite(poles)) and np.isfinite(gain)):
        raise t.error("den", f"coefficients out of range: poles or gain not finite for {den!r}")
    if np.any(poles.real >= 0.0):
        listed = ", ".join(f"{p:.6g}" for p in poles)
        raise t.error("den", f"transfer function must be stable; poles [{listed}] rad/s")
    return ActuatorNominal(tuple(num), tuple(den), delay)


def _specimen(t: Table) -> SpecimenNominal:
    s = SpecimenNominal(
        inertance=t.number("inertance", nonnegative=True, hi=MAX_VALUE),
        damping=t.number("damping", 0.0, nonnegative=True, hi=MAX_VALUE),
        stiffness=t.number("stiffness", 0.0, lo=-MAX_VALUE, hi=MAX_VALUE),
        friction=t.number("friction", 0.0, nonnegative=True, hi=MAX_VALUE),
        amplitude_c1=t.number("amplitude_c1", 0.0, nonnegative=True, hi=MAX_VALUE),
        amplitude_c2=t.number("amplitude_c2", 1e-3, nonnegative=True, hi=MAX_VALUE),
    )
    if s.amplitude_c2 <= 0.0:
        raise t.error("amplitude_c2", f"must be positive; got {s.amplitude_c2!r}")
    t.finish()
    return s


def _parse(doc: Table) -> NominalModel:
    actuator = _actuator(doc.table("actuator"))
    specimen = _specimen(doc.table("specimen"))
    doc.finish()
    return NominalModel(actuator, specimen, doc.source)


def parse_nominal(text: str, source: str = "<nominal>") -> NominalModel:
    """Parse ``NOMINAL.toml`` text.

    Parameters
    ----------
    text
        The TOML text.
    source
        What the text is (a path or a label), named in errors.

    Raises
    ------
    ConfigError
        As :func:`load_nominal`.
    """
    return _parse(parse_toml(text, source))


def load_nominal(path: str | os.PathLike[str]) -> NominalModel:
    """Read ``NOMINAL.toml``.

    Parameters
    ----------
    path
        The file.

    Raises
    ------
    ConfigError
        Missing file, TOML syntax error, missing/unknown key, wrong type or out-of-range value,
        improper or unstable actuator transfer function.
    """
    doc, _ = load_toml(Path(path))
    return _parse(doc)


def nominal_toml(model: NominalModel, comment: str = "") -> str:
    """The TOML text of a nominal model (what :func:`load_nominal` reads back exactly).

    Parameters
    ----------
    model
        The model to write.
    comment
        Text put at the top as ``#`` comment lines (may hold several lines).

    Raises
    ------
    ParameterError
        A negative inertance or delay (the message names the value).
    """
    a, s = model.actuator, model.specimen
    for name, value in (("inertance", s.inertance), ("delay", a.delay)):
        if value < 0.0:
            raise ParameterError(f"nominal {name} must be non-negative; got {value!r}")
    head = "".join(f"# {line}\n" for line in comment.splitlines())
    return (
        f"{head}[actuator]            # measured/command, continuous-time TF, descending powers\n"
        f"num = [{', '.join(repr(float(c)) for c in a.num)}]\n"
        f"den = [{', '.join(repr(float(c)) for c in a.den)}]\n"
        f"delay = {float(a.delay)!r}  # s\n\n"
        f"[specimen]            # F = inertance*a + damping*v + stiffness*x + friction*sign(v)\n"
        f"inertance = {float(s.inertance)!r}  # kg\n"
        f"damping = {float(s.damping)!r}  # N s/m\n"
        f"stiffness = {float(s.stiffness)!r}  # N/m\n"
        f"friction = {float(s.friction)!r}  # N\n"
        + (
            f"amplitude_c1 = {float(s.amplitude_c1)!r}  # N s\n"
            f"amplitude_c2 = {float(s.amplitude_c2)!r}  # m\n"
            if s.declares_amplitude_damping
            else ""
        )
    )
