"""Stepped-sine shake-table emulation of the S1 specimens (in process, the ``fast`` path).

The S1 campaign (§2.3) in software: the table is driven in displacement control with a stepped
sine 1→10 Hz and 10→1 Hz (fine steps near resonance, 20 cycles per step) at PGA 0.05/0.10/0.15 g;
the table's measured acceleration ``ü_G`` excites the whole physical model; FRFs follow S1 Eq.7.

Per PGA and direction::

    grid (fine near the linearised f0, f1, f2)  ──►  SteppedSine  ──►  command -A_k sin(ω_k τ)
        A_k = PGA g / |table acceleration gain at f_k|   (= PGA g / ω_k² for a perfect table)
    command ──► table model (rths.experiments.s1_shake_table.shake_table) ──► measured ü_G
    ü_G ──► TMDIStructure.run  (uncontrolled PS; TMDI with rack-and-pinion inerter, S1 Eq.9-12;
                                TMDI with the ideal inerter of S1 §4.2; HDRBs per ``hdrb``)
    responses ──► frf.estimate_frf (S1 Eq.7) + the last cycle of every step (loops)

Each PGA and direction is one job (:class:`SweepJob`, :func:`sweep_level`: the table motion,
then every model on it); with a ``cluster`` the jobs run as a campaign on Dask workers
(:func:`rths.campaign.map_tasks`), with the same result as in this process.

The table signal does not depend on the specimen (no control-structure interaction: the table
transfer function is understood as identified with the specimen on it), so it is computed once
per PGA and direction and shared by the specimens.  The scenario file is described in
:mod:`rths.experiments.s1_shake_table.config`.
:func:`plants.excitation.stepped_sine.stepped_sine_acceleration` gives the same excitation as a
function of time for an RTHS substructure (:class:`plants.tmdi.structure.TMDISubstructure`).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from plants.base import Specimen
from plants.excitation.stepped_sine import (
    SteppedSine,
    frequency_grid,
    stepped_sine_acceleration,
)
from plants.tmdi import (
    EQ7_QUANTITIES,
    NominalInerter,
    TMDIParameters,
    TMDIStructure,
    linearised_frequencies,
    s1_configuration,
)
from rths.campaign import Cluster, map_tasks
from rths.core.errors import ParameterError, check_positive, format_choices
from rths.experiments.s1_shake_table.config import (
    DIRECTIONS,
    MODELS,
    STANDARD_GRAVITY,
    GridSpec,
    SweepConfig,
    TableSpec,
    load_sweep,
    parse_sweep,
)
from rths.experiments.s1_shake_table.frf import FRF, estimate_frf, steady_state_windows
from rths.experiments.s1_shake_table.shake_table import (
    IdealTable,
    ShakeTable,
    TableMotion,
    TransferFunctionTable,
)

__all__ = [
    "DIRECTIONS",
    "MODELS",
    "STANDARD_GRAVITY",
    "GridSpec",
    "IdealTable",
    "ShakeTable",
    "SteppedSine",
    "SweepConfig",
    "SweepResult",
    "SweepJob",
    "SweepRun",
    "TableMotion",
    "TableSpec",
    "TransferFunctionTable",
    "build_table",
    "command_amplitudes",
    "frequency_grid",
    "load_sweep",
    "model_configuration",
    "parse_sweep",
    "run_model",
    "run_sweep",
    "step_frequencies",
    "stepped_sine_acceleration",
    "sweep_level",
    "sweep_structure",
]

#: S1 Eq.7 quantities of the PS alone (the uncontrolled model has no secondary mass).
PRIMARY_QUANTITIES = ("u_I", "a_I_tot", "F_I")


def model_configuration(
    model: str, mass: str = "IM", flywheel: str = "IF", hdrb: str = "amplitude"
) -> tuple[TMDIParameters, Specimen | None]:
    """Structure and inerter of a swept model (:data:`MODELS`).

    Parameters
    ----------
    model
        ``"uncontrolled"``: the PS alone; ``"rack_pinion"`` / ``"ideal"``: the TMDI with that
        inerter (S1 Eq.9-11, or the ideal inerter and dampers of S1 §4.2).
    mass, flywheel
        S1 Table 1 secondary mass (``"SM"``, ``"IM"``, ``"LM"``) and flywheel (``"NF"``,
        ``"IF"``, ``"LF"``) of the TMDI models.
    hdrb
        ``"amplitude"``: the primary HDRB's amplitude-dependent damping -- for the PS the bearing
        calibrated on S1's uncontrolled tests (:data:`plants.tmdi.hdrb.S1_PRIMARY_UNCONTROLLED`),
        with a TMDI the S1 §4.2 bearing anchored at S1's ``c_I``; ``"viscous"``: the S1 §4.2
        isolators as identified, the PS with the TMDI's primary bearing
        (:func:`plants.tmdi.structure.s1_configuration`).

    Returns
    -------
    tuple
        (:class:`plants.tmdi.structure.TMDIParameters`, inerter specimen or None).
    """
    if model == "uncontrolled":
        return s1_configuration(None, hdrb=hdrb)
    if model in ("rack_pinion", "ideal"):
        return s1_configuration(mass, flywheel, inerter=model, hdrb=hdrb)
    raise ParameterError(f"model must be one of {format_choices(MODELS)}; got {model!r}")


def _inertance(inerter: Specimen | None) -> float:
    """Rigid-limit inertance [kg] of an inerter (0 without one)."""
    return 0.0 if inerter is None else NominalInerter.matching(inerter).inertance


def step_frequencies(config: SweepConfig) -> NDArray[np.float64]:
    """The scenario's ascending step frequencies [Hz] (:func:`frequency_grid`).

    "Near resonance" is defined reproducibly as ``fine_band`` times each small-amplitude natural
    frequency (:func:`plants.tmdi.structure.linearised_frequencies`, HDRB ``k1``, nominal inertance)
    of the models swept: ``f0`` of the PS, ``f1`` and ``f2`` of each TMDI.

    Parameters
    ----------
    config
        The scenario (its ``grid``, ``models``, ``mass`` and ``flywheel``).
    """
    centres: list[float] = []
    for model in config.models:
        structure, inerter = model_configuration(model, config.mass, config.flywheel, config.hdrb)
        centres.extend(linearised_frequencies(structure, _inertance(inerter)))
    g = config.grid
    return frequency_grid(g.f_start, g.f_stop, g.coarse_step, g.fine_step, centres, g.fine_band)


def build_table(spec: TableSpec, dt: float) -> ShakeTable:
    """The table model of a ``[table]`` specification.

    Parameters
    ----------
    spec
        ``kind`` ``"ideal"`` (:class:`IdealTable`) or ``"transfer_function"``
        (:class:`TransferFunctionTable` of ``num``/``den``).
    dt
        Sampling step [s].
    """
    if spec.kind == "ideal":
        return IdealTable()
    return TransferFunctionTable(spec.num, spec.den, dt)


def command_amplitudes(
    table: ShakeTable, frequencies: ArrayLike, pga: float, dt: float, correction: bool = True
) -> NDArray[np.float64]:
    """Displacement command amplitudes [m] for a target PGA [g] at each frequency [Hz].

    Parameters
    ----------
    table
        The table model.
    frequencies
        Step frequencies [Hz].
    pga
        Target peak table acceleration [g], > 0.
    dt
        Sampling step [s] of the table.
    correction
        False: ``A = PGA g / ω²`` (S1 §2.3, displacement control); True: ``PGA g`` divided by
        the table's steady acceleration gain, so that the measured amplitude is the PGA.
    """
    target = check_positive(pga, "PGA") * STANDARD_GRAVITY
    f = np.asarray(frequencies, dtype=float)
    if correction:
        return target / table.acceleration_gain(f, dt)
    return target / (2.0 * np.pi * f) ** 2


@dataclass(frozen=True)
class SweepRun:
    """One specimen, one direction, one PGA.

    Attributes
    ----------
    model, direction, pga
        Which run (``pga`` in g).
    frf
        Steady-state amplitudes (S1 Eq.7 normalisation via :meth:`FRF.normalised`).
    last_cycles
        For each FRF frequency (ascending), the last cycle of the step: arrays of the S1 Eq.7
        quantities and ``"a_G"`` keyed by name (for force-deformation loops, S1 Fig.9-12).
    """

    model: str
    direction: str
    pga: float
    frf: FRF
    last_cycles: tuple[dict[str, NDArray[np.float64]], ...]

    def cycle_at(self, frequency: float) -> tuple[float, dict[str, NDArray[np.float64]]]:
        """The step nearest ``frequency`` [Hz]: its frequency [Hz] and its last cycle."""
        i = int(np.argmin(np.abs(self.frf.frequency - frequency)))
        return float(self.frf.frequency[i]), self.last_cycles[i]


@dataclass(frozen=True)
class SweepResult:
    """All runs of a scenario, the frequency grid [Hz] and the wall time [s] they took.

    Attributes
    ----------
    config : SweepConfig
        The scenario that was run.
    grid : numpy.ndarray
        Ascending step frequencies [Hz] of every run (:func:`step_frequencies`).
    runs : tuple of SweepRun
        One run per PGA, direction and model, in that nesting order.
    wall_time : float
        Wall-clock time [s] the whole sweep took (``time.perf_counter``; depends on the
        machine and its load).
    """

    config: SweepConfig
    grid: NDArray[np.float64]
    runs: tuple[SweepRun, ...]
    wall_time: float

    @property
    def pgas(self) -> tuple[float, ...]:
        """PGAs run [g], in order."""
        return tuple(dict.fromkeys(r.pga for r in self.runs))

    def get(self, model: str, direction: str, pga: float) -> SweepRun:
        """The run of ``model`` in ``direction`` at ``pga`` [g] (:class:`ParameterError` if
        there is none)."""
        for r in self.runs:
            if r.model == model and r.direction == direction and abs(r.pga - pga) < 1e-12:
                return r
        raise ParameterError(f"no run of model {model!r}, direction {direction!r}, PGA {pga!r} g")


def sweep_structure(
    structure: TMDIParameters,
    inerter: Specimen | None,
    motion: TableMotion,
    sine: SteppedSine,
    dt: float,
    steady_cycles: float = 5.0,
    amplitude: str = "peak",
) -> tuple[FRF, tuple[dict[str, NDArray[np.float64]], ...]]:
    """Drive a structure (:class:`plants.tmdi.structure.TMDIStructure`) with a table motion.

    Parameters
    ----------
    structure, inerter
        The specimen (e.g. from :func:`model_configuration`).
    motion
        Table motion; its acceleration [m/s²] is the ground acceleration ``ü_G``.
    sine
        The stepped sine that produced ``motion``.
    dt
        Sampling step [s] of ``motion``.
    steady_cycles, amplitude
        Window and amplitude measure of :func:`rths.experiments.s1_shake_table.frf.estimate_frf`.

    Returns
    -------
    frf : FRF
        The S1 Eq.7 quantities (only ``u_I``, ``a_I_tot``, ``F_I`` without a secondary mass).
    last_cycles : tuple of dict
        For each FRF frequency (ascending), the last cycle of the step: those quantities and
        ``"a_G"`` [SI].
    """
    response = TMDIStructure(structure, inerter, dt).run(motion.acceleration)
    names = EQ7_QUANTITIES if structure.has_tmd else PRIMARY_QUANTITIES
    signals = {name: getattr(response, name) for name in names}
    frf = estimate_frf(
        signals,
        motion.acceleration,
        sine.frequencies,
        sine.boundaries,
        dt,
        steady_cycles,
        amplitude,
    )
    windows = steady_state_windows(
        sine.boundaries, sine.frequencies, dt, motion.acceleration.size, 1.0
    )
    signals["a_G"] = motion.acceleration
    cycles = [{name: np.array(x[w]) for name, x in signals.items()} for w in windows]
    return frf, tuple(cycles[i] for i in np.argsort(sine.frequencies))


def run_model(
    model: str,
    motion: TableMotion,
    sine: SteppedSine,
    config: SweepConfig,
    pga: float,
    direction: str,
) -> SweepRun:
    """Drive one of the scenario's specimens with a table motion.

    Parameters
    ----------
    model
        One of :data:`MODELS`.
    motion, sine
        Table motion and the stepped sine that produced it.
    config
        The scenario (sampling step, amplitude measure, S1 configuration).
    pga, direction
        Labels of the run (``pga`` in g).
    """
    structure, inerter = model_configuration(model, config.mass, config.flywheel, config.hdrb)
    frf, cycles = sweep_structure(
        structure, inerter, motion, sine, config.dt, config.steady_cycles, config.amplitude
    )
    return SweepRun(model, direction, pga, frf, cycles)


@dataclass(frozen=True)
class SweepJob:
    """One PGA and direction of a sweep: every model of ``config`` driven by one table motion
    (the unit of work :func:`run_sweep` hands to a campaign).

    Parameters
    ----------
    config
        The scenario.
    grid
        Step frequencies [Hz] (:func:`step_frequencies`).
    pga
        Target PGA [g].
    direction
        ``"up"`` or ``"down"``.
    """

    config: SweepConfig
    grid: NDArray[np.float64]
    pga: float
    direction: str


def sweep_level(job: SweepJob) -> tuple[SweepRun, ...]:
    """Run one :class:`SweepJob`: the table motion, then every model of the scenario.

    Parameters
    ----------
    job
        The PGA and direction.
    """
    config = job.config
    table = build_table(config.table, config.dt)
    sine = SteppedSine.sweep(job.grid, job.direction, config.cycles)
    amplitudes = command_amplitudes(
        table, sine.frequencies, job.pga, config.dt, config.table.amplitude_correction
    )
    motion = table.run(sine, amplitudes, config.dt)
    return tuple(run_model(m, motion, sine, config, job.pga, job.direction) for m in config.models)


def run_sweep(
    config: SweepConfig,
    pga: Sequence[float] | None = None,
    progress: bool = False,
    cluster: Cluster | None = None,
) -> SweepResult:
    """Run every model of ``config`` in every direction at every PGA [g].

    Parameters
    ----------
    config
        The scenario.
    pga
        PGAs [g] overriding ``config.pga``.
    progress
        Show a progress bar (over PGA x direction) on stderr.
    cluster
        Run the PGA x direction jobs as a campaign on this Dask cluster
        (:func:`rths.campaign.map_tasks`); None: one after the other in this process.  The
        result is the same either way.
    """
    from tqdm import tqdm

    pgas = tuple(config.pga if pga is None else (check_positive(p, "PGA") for p in pga))
    if not pgas:
        raise ParameterError("at least one PGA is needed; got none")
    start = time.perf_counter()
    grid = step_frequencies(config)
    jobs = [SweepJob(config, grid, level, d) for level in pgas for d in config.directions]
    if cluster is not None:
        levels = map_tasks(
            sweep_level, jobs, cluster, progress=progress, desc=f"sweep {config.name}"
        )
    else:
        levels = [
            sweep_level(job)
            for job in tqdm(
                jobs, unit="level", desc=f"sweep {config.name}", disable=not progress, leave=False
            )
        ]
    runs = tuple(run for level in levels for run in level)
    return SweepResult(config, grid, runs, time.perf_counter() - start)
