"""The shake-table scenario file of ``rths sweep`` (private; re-exported by
:mod:`rths.experiments.s1_shake_table.sweep`).

Schema (all SI except the PGA, given in units of standard gravity ``g = 9.80665 m/s²`` as S1
does; every key is checked and an unknown key is an error naming the file, table and key)::

    [sweep]
    name = "tmdi_shake_table"
    rate = 1000.0                 # Hz, sampling and integration rate
    pga = [0.05, 0.10, 0.15]      # g, target peak table acceleration
    directions = ["up", "down"]   # increasing / decreasing frequency
    cycles = 20                   # whole cycles per step (S1 §2.3)
    steady_cycles = 5             # final cycles of a step used for its amplitude
    amplitude = "peak"            # "peak" (S1 §3.1) | "harmonic" (first harmonic)

    [sweep.grid]
    f_start = 1.0                 # Hz
    f_stop = 10.0                 # Hz
    coarse_step = 0.1             # Hz, away from resonance
    fine_step = 0.05              # Hz, near resonance
    fine_band = [0.75, 1.15]      # "near": these factors times each linearised f0, f1, f2

    [specimen]
    mass = "IM"                   # S1 Table 1 secondary mass: SM | IM | LM
    flywheel = "IF"               # S1 Table 1 flywheel: NF | IF | LF
    models = ["uncontrolled", "rack_pinion", "ideal"]
    hdrb = "amplitude"            # "viscous" (S1 §4.2 as identified) | "amplitude"

    [table]
    kind = "transfer_function"    # | "ideal" (perfect tracking)
    preset = "mts_identified"     # or num = [...], den = [...] (descending powers of s)
    amplitude_correction = true   # command amplitude / steady table gain (drive iteration)
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final

from plants.excitation.stepped_sine import STANDARD_GRAVITY
from rths.config.toml import Table, load_toml, parse_toml

__all__ = [
    "DIRECTIONS",
    "MODELS",
    "STANDARD_GRAVITY",
    "GridSpec",
    "SweepConfig",
    "TableSpec",
    "load_sweep",
    "parse_sweep",
]

#: Sweep directions: increasing and decreasing frequency.
DIRECTIONS: Final[tuple[str, ...]] = ("up", "down")
#: Specimens: the uncontrolled PS, the TMDI with the S1 Eq.9-11 rack-and-pinion inerter, and the
#: S1 §4.2 variant with an ideal inerter (each with its own identified isolator damping).
MODELS: Final[tuple[str, ...]] = ("uncontrolled", "rack_pinion", "ideal")
TABLE_KINDS: Final[tuple[str, ...]] = ("transfer_function", "ideal")
TABLE_PRESETS: Final[tuple[str, ...]] = ("mts_identified",)
AMPLITUDES: Final[tuple[str, ...]] = ("peak", "harmonic")


@dataclass(frozen=True)
class GridSpec:
    """``[sweep.grid]``: range [Hz], steps [Hz] and the near-resonance band (factors).

    The defaults are the S1 §2.3 sine sweep: 1-10 Hz in steps of 0.1 Hz away from resonance
    and 0.05 Hz near it (:func:`plants.excitation.stepped_sine.frequency_grid`).

    Attributes
    ----------
    f_start : float, default 1.0
        Lowest step frequency [Hz], > 0.
    f_stop : float, default 10.0
        Highest step frequency [Hz], > ``f_start``.
    coarse_step : float, default 0.1
        Frequency step [Hz], > 0, away from resonance.
    fine_step : float, default 0.05
        Frequency step [Hz], > 0, near resonance.
    fine_band : tuple of (float, float), default (0.75, 1.15)
        ``(lo, hi)`` factors [-], ``0 < lo <= 1 <= hi``: "near resonance" is
        ``[lo f_c, hi f_c]`` around each small-amplitude natural frequency ``f_c`` (``f0``,
        ``f1``, ``f2``) of the models swept; wider below because the HDRBs soften (S1 §3.1).
    """

    f_start: float = 1.0
    f_stop: float = 10.0
    coarse_step: float = 0.1
    fine_step: float = 0.05
    fine_band: tuple[float, float] = (0.75, 1.15)


@dataclass(frozen=True)
class TableSpec:
    """``[table]``: the shaking-table model.

    ``kind`` is ``"transfer_function"`` (``num``/``den`` in descending powers of ``s``, command
    [m] → table displacement [m]) or ``"ideal"``; ``amplitude_correction`` divides each step's
    command amplitude by the model's steady acceleration gain.

    Attributes
    ----------
    kind : {"transfer_function", "ideal"}, default "transfer_function"
        Table model: a command→displacement transfer function
        (:class:`rths.experiments.s1_shake_table.shake_table.TransferFunctionTable`) or perfect
        tracking (``IdealTable``).
    num : tuple of float, default ()
        Numerator coefficients of the command→displacement ``G(s)`` (dimensionless, m/m;
        ``s`` in rad/s), descending powers of ``s``; the preset ``"mts_identified"`` fills
        it.  Empty for ``"ideal"``.
    den : tuple of float, default ()
        Denominator coefficients of ``G(s)``, descending powers of ``s``; relative degree
        ``len(den) - len(num) >= 3``.  Empty for ``"ideal"``.
    amplitude_correction : bool, default True
        Divide each step's command amplitude by the table's steady acceleration gain so that
        the measured table acceleration amplitude is the target PGA (what the drive iteration
        of S1's table controller achieves); False commands ``PGA / ω²`` (S1 §2.3).
    """

    kind: str = "transfer_function"
    num: tuple[float, ...] = ()
    den: tuple[float, ...] = ()
    amplitude_correction: bool = True


@dataclass(frozen=True)
class SweepConfig:
    """A shake-table scenario (see the module docstring for the file format).

    Attributes
    ----------
    name
        Scenario name.
    rate
        Sampling/integration rate [Hz].
    pga
        Target peak table accelerations [g].
    directions
        Sweep directions, among :data:`DIRECTIONS`.
    cycles, steady_cycles
        Cycles per step and final cycles used for the amplitude.
    amplitude
        ``"peak"`` or ``"harmonic"`` (:mod:`rths.experiments.s1_shake_table.frf`).
    grid
        Frequency grid.
    mass, flywheel
        S1 Table 1 configuration of the TMDI models.
    models
        Specimens swept, among :data:`MODELS`.
    hdrb
        HDRB damping model, among :data:`plants.tmdi.structure.HDRB_MODELS`:
        ``"amplitude"`` (the primary bearing's amplitude law; the uncontrolled PS calibrated on
        S1's uncontrolled tests) or ``"viscous"`` (S1 §4.2 as identified).
    table
        Shaking-table model.
    """

    name: str
    rate: float
    pga: tuple[float, ...]
    directions: tuple[str, ...] = DIRECTIONS
    cycles: int = 20
    steady_cycles: float = 5.0
    amplitude: str = "peak"
    grid: GridSpec = GridSpec()
    mass: str = "IM"
    flywheel: str = "IF"
    models: tuple[str, ...] = MODELS
    table: TableSpec = TableSpec()
    hdrb: str = "amplitude"

    @property
    def dt(self) -> float:
        """Sampling step [s]."""
        return 1.0 / self.rate


def _names(table: Table, key: str, choices: tuple[str, ...], default: tuple[str, ...]) -> tuple:
    value: Any = table.raw(key, list(default))
    if not isinstance(value, list) or not value:
        raise table.error(key, f"must be a non-empty list of strings; got {value!r}")
    for item in value:
        if item not in choices:
            options = ", ".join(repr(c) for c in choices)
            raise table.error(key, f"entries must be among {options}; got {item!r}")
    if len(set(value)) != len(value):
        raise table.error(key, f"entries must be distinct; got {value!r}")
    return tuple(value)


def _grid(table: Table) -> GridSpec:
    f_start = table.number("f_start", 1.0, positive=True)
    f_stop = table.number("f_stop", 10.0, positive=True)
    if f_stop <= f_start:
        raise table.error("f_stop", f"must exceed f_start = {f_start!r}; got {f_stop!r}")
    coarse = table.number("coarse_step", 0.1, positive=True)
    fine = table.number("fine_step", 0.05, positive=True)
    band = table.numbers("fine_band", [0.75, 1.15], min_length=2)
    if len(band) != 2 or not 0.0 < band[0] <= 1.0 <= band[1]:
        raise table.error("fine_band", f"must be [lo, hi] with 0 < lo <= 1 <= hi; got {band!r}")
    table.finish()
    return GridSpec(f_start, f_stop, coarse, fine, (band[0], band[1]))


def _table(table: Table) -> TableSpec:
    kind = table.choice("kind", TABLE_KINDS, "transfer_function")
    correction = table.boolean("amplitude_correction", True)
    if kind == "ideal":
        table.finish()
        return TableSpec("ideal", amplitude_correction=correction)
    if "preset" in table:
        if "num" in table or "den" in table:
            raise table.error("preset", "give either preset or num/den, not both")
        table.choice("preset", TABLE_PRESETS)
        from plants.actuator import MTS_IDENTIFIED

        num, den = MTS_IDENTIFIED.num, MTS_IDENTIFIED.den
    else:
        num, den = tuple(table.numbers("num")), tuple(table.numbers("den"))
        if len(den) - len(num) < 3:
            raise table.error("den", f"relative degree must be >= 3; got {len(den) - len(num)}")
    table.finish()
    return TableSpec(kind, tuple(num), tuple(den), correction)


def _config(doc: Table) -> SweepConfig:
    from plants.tmdi import HDRB_MODELS, SECONDARY_MASSES
    from plants.tmdi.inerter import FLYWHEELS

    sweep = doc.table("sweep")
    name = sweep.string("name")
    rate = sweep.number("rate", positive=True)
    pga = tuple(sweep.numbers("pga"))
    for value in pga:
        if value <= 0.0:
            raise sweep.error("pga", f"entries must be positive (g); got {value!r}")
    directions = _names(sweep, "directions", DIRECTIONS, DIRECTIONS)
    cycles = sweep.integer("cycles", 20, minimum=1)
    steady = sweep.number("steady_cycles", 5.0, positive=True)
    if steady > cycles:
        raise sweep.error("steady_cycles", f"must not exceed cycles = {cycles}; got {steady!r}")
    amplitude = sweep.choice("amplitude", AMPLITUDES, "peak")
    grid = _grid(sweep.table("grid", {}))
    sweep.finish()
    spec = doc.table("specimen", {})
    mass = spec.choice("mass", tuple(SECONDARY_MASSES), "IM")
    flywheel = spec.choice("flywheel", tuple(FLYWHEELS), "IF")
    models = _names(spec, "models", MODELS, MODELS)
    hdrb = spec.choice("hdrb", HDRB_MODELS, "amplitude")
    spec.finish()
    table = _table(doc.table("table", {}))
    doc.finish()
    return SweepConfig(
        name,
        rate,
        pga,
        directions,
        cycles,
        steady,
        amplitude,
        grid,
        mass,
        flywheel,
        models,
        table,
        hdrb,
    )


def parse_sweep(text: str, source: str = "<string>") -> SweepConfig:
    """Parse a shake-table scenario from TOML text.

    Raises :class:`rths.core.errors.ConfigError` naming ``source``, the table and the key.

    Parameters
    ----------
    text : str
        The scenario as TOML (schema in the module docstring).
    source : str, default "<string>"
        Where the text came from (e.g. a file name), used in error messages.
    """
    return _config(parse_toml(text, source))


def load_sweep(path: str | Path) -> SweepConfig:
    """Read a shake-table scenario file (:class:`rths.core.errors.ConfigError` on any problem).

    Parameters
    ----------
    path : str or pathlib.Path
        The TOML scenario file (schema in the module docstring).
    """
    doc, _ = load_toml(path)
    return _config(doc)
