"""Every compensator on the benchmark's four cases, nominal and perturbed plants: F4's table.

For each compensator kind, case and plant (the nominal one and ``perturbed`` draws of F1's
uncertain parameters, :mod:`~rths.experiments.vrths.draws`) one trial runs through the project's
loop (:func:`~rths.experiments.vrths.rig.run_trial`) and is scored with F4's J1-J9
(:mod:`~rths.metrics.vrths`).  Beside them, per trial: the peak hydraulic force
against the 8.9 kN capacity, whether an interlock stopped the run, and the noise-free tracking
error ``J2 (noise-free)`` -- F4's J2 with the lab's true specimen displacement instead of the
measured one (F4's J2 has a floor of ``std(noise)/std(target)``: the LVDT noise alone, 16 um,
is 1.3-2.5 % of the first floor's motion under El Centro at intensity 0.4).

Trials are independent: :func:`trial_specs` lists them (:class:`TrialSpec`, plain picklable
data) and :func:`run_one` runs and scores one, so a campaign can map ``run_one`` over
``trial_specs(...)`` on any executor (``dask.distributed``: ``client.map(run_one, specs)``);
:func:`run_comparison` does it with worker processes.  Tables are built by
:mod:`~rths.experiments.vrths.tables`.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from plants.frame.cases import CASES
from plants.frame.ground_motion import DEFAULT_INTENSITY, GroundMotion, ground_motion
from rths.core.errors import ParameterError, RTHSError, format_choices
from rths.experiments.vrths.draws import PlantDraw, draw_plants
from rths.experiments.vrths.rig import benchmark_compensator, reference_for, run_trial, score
from rths.metrics.vrths import ACTUATOR_CAPACITY, CRITERIA

__all__ = [
    "COMPENSATORS",
    "Comparison",
    "TrialResult",
    "TrialSpec",
    "run_comparison",
    "run_one",
    "trial_specs",
]

#: Compensator kinds compared, the benchmark's sample controller first.
COMPENSATORS: tuple[str, ...] = ("pi_lead", "ff_lqg", "ff", "lqg", "ats", "polynomial", "none")


@dataclass(frozen=True)
class TrialResult:
    """Outcome of one trial.

    Attributes
    ----------
    kind, case, plant
        Compensator kind, case number (1-4) and plant index (0 = nominal, 1.. = perturbed).
    scores
        F4's ``{"J1": ms, "J2".."J9": %}``; ``None`` when an interlock stopped the run.
    j2_noise_free
        ``100 std(x_true - y_1) / std(y_1)`` [%] of the completed part of the run.
    noise_floor
        ``100 std(LVDT noise) / std(y_1)`` [%]: the least F4's J2 can be.
    peak_force
        ``max |F_a|`` [N] over the run (``Force_act``).
    stopped
        The interlock's reason, or ``None``.
    wall
        Wall time of the trial [s].
    """

    kind: str
    case: int
    plant: int
    scores: dict[str, float] | None
    j2_noise_free: float
    noise_floor: float
    peak_force: float
    stopped: str | None
    wall: float

    @property
    def over_capacity(self) -> bool:
        """F4's check: ``max |F_a| >= 8.9 kN``."""
        return self.peak_force >= ACTUATOR_CAPACITY


# one ground motion and reference per worker process
_CACHE: dict[Any, Any] = {}


def _ground(name: str, package: str | None, chirp: tuple[tuple[str, float], ...]) -> GroundMotion:
    key = ("ground", name, package, chirp)
    if key not in _CACHE:
        _CACHE[key] = ground_motion(name, package, **dict(chirp))
    return _CACHE[key]


def _reference(case: int, ground: GroundMotion, intensity: float) -> np.ndarray:
    key = ("reference", case, id(ground), intensity)
    if key not in _CACHE:
        _CACHE[key] = reference_for(CASES[case], ground, intensity=intensity)
    return _CACHE[key]


@dataclass(frozen=True)
class TrialSpec:
    """One (compensator, case, plant draw) trial of the comparison: everything a worker needs.

    Attributes
    ----------
    kind
        Compensator kind (:data:`COMPENSATORS`).
    case
        Partitioning case, 1-4.
    plant_index
        0 for the nominal plant, ``i`` for the ``i``-th perturbed draw.
    plant
        The plant draw itself (:class:`~rths.experiments.vrths.draws.PlantDraw`).
    ground
        Ground-motion name.
    package
        Benchmark package folder, or ``None`` for the environment's.
    chirp
        Chirp options as sorted ``(name, value)`` pairs (``()`` for a record).
    intensity
        ``eq_intensity`` [-].
    seed
        Comparison seed; the trial's sensor-noise seed is ``seed + 1000 plant_index + case``.
    """

    kind: str
    case: int
    plant_index: int
    plant: PlantDraw
    ground: str
    package: str | None
    chirp: tuple[tuple[str, float], ...]
    intensity: float
    seed: int


def trial_specs(
    kinds: Sequence[str] = COMPENSATORS,
    cases: Sequence[int] = (1, 2, 3, 4),
    *,
    ground: str = "el_centro",
    perturbed: int = 20,
    intensity: float = DEFAULT_INTENSITY,
    seed: int = 123,
    package: str | None = None,
    chirp: dict[str, float] | None = None,
) -> list[TrialSpec]:
    """Every (kind, case, plant) trial of a comparison, validated.

    Parameters
    ----------
    kinds
        Compensator kinds (:data:`COMPENSATORS`).
    cases
        Case numbers (1-4).
    ground
        Ground motion (:data:`plants.frame.GROUND_MOTIONS`).
    perturbed
        Perturbed plants per case (the same draws for every kind and case).
    intensity
        ``eq_intensity`` [-].
    seed
        Seed of the plant draws and of the sensor noise.
    package
        Benchmark package folder (default: ``RTHS_VRTHS_PACKAGE``, else ``RTHS_DATA``'s).
    chirp
        Chirp options (``f_start``, ``f_end``, ``duration``) when ``ground = "chirp"``.

    Raises
    ------
    ParameterError
        An unknown case or compensator kind.
    ConfigError
        The records' package is missing (checked here, before any worker starts).
    """
    for c in cases:
        if c not in CASES:
            raise ParameterError(f"benchmark case must be one of 1, 2, 3, 4; got {c!r}")
    known = set(COMPENSATORS)
    bad = [k for k in kinds if k not in known]
    if bad:
        raise ParameterError(
            f"unknown compensator(s) {format_choices(bad)}; "
            f"choose from {format_choices(COMPENSATORS)}"
        )
    chirp_items = tuple(sorted((chirp or {}).items()))
    _ground(ground, package, chirp_items)  # fail early (missing package) in this process
    plants = draw_plants(perturbed, seed)
    return [TrialSpec(kind, case, i, p, ground, package, chirp_items, intensity, seed)
            for case in cases for i, p in enumerate(plants) for kind in kinds]  # fmt: skip


def run_one(job: TrialSpec) -> TrialResult:
    """Run and score one trial (top-level and pure, so any executor can map it).

    Parameters
    ----------
    job
        The trial (:func:`trial_specs`).
    """
    start = time.perf_counter()
    ground = _ground(job.ground, job.package, job.chirp)
    case = CASES[job.case]
    try:
        comp = benchmark_compensator(job.kind)
        trial = run_trial(case, ground, comp, job.plant, intensity=job.intensity,
                          seed=job.seed + 1000 * job.plant_index + job.case)  # fmt: skip
    except RTHSError as exc:  # e.g. a drawn plant whose loop is unstable
        return TrialResult(job.kind, job.case, job.plant_index, None, math.nan, math.nan,
                           math.nan, f"rejected: {exc}", time.perf_counter() - start)  # fmt: skip
    target = trial.numerical[:, 0]
    sd_target = float(np.std(target, ddof=1)) if target.size > 1 else 0.0
    lvdt = trial.measured - trial.true_displacement
    if sd_target > 0.0:
        clean = 100.0 * float(np.std(trial.true_displacement - target, ddof=1)) / sd_target
        floor = 100.0 * float(np.std(lvdt, ddof=1)) / sd_target
    else:
        clean = floor = math.nan
    scores = None
    if trial.stopped is None:
        scores = score(trial, _reference(job.case, ground, job.intensity)).to_dict()
    return TrialResult(job.kind, job.case, job.plant_index, scores, clean, floor,
                       trial.peak_actuator_force, trial.stopped,
                       time.perf_counter() - start)  # fmt: skip


@dataclass
class Comparison:
    """All trials of a comparison and how it was run.

    Attributes
    ----------
    ground
        Ground-motion name.
    intensity
        ``eq_intensity`` [-].
    perturbed
        Number of perturbed plants per case.
    results
        One :class:`TrialResult` per (kind, case, plant).
    wall
        Wall time of the whole comparison [s].
    workers
        Worker processes used.
    """

    ground: str
    intensity: float
    perturbed: int
    results: list[TrialResult] = field(default_factory=list)
    wall: float = 0.0
    workers: int = 1

    @property
    def kinds(self) -> list[str]:
        """Compensator kinds present, in :data:`COMPENSATORS` order."""
        present = {r.kind for r in self.results}
        return [k for k in COMPENSATORS if k in present] + sorted(present - set(COMPENSATORS))

    @property
    def cases(self) -> list[int]:
        """Case numbers present, ascending."""
        return sorted({r.case for r in self.results})

    def select(self, kind: str, case: int, nominal: bool) -> list[TrialResult]:
        """The nominal trial (``nominal=True``) or the perturbed ones of ``kind`` on ``case``."""
        return [r for r in self.results
                if r.kind == kind and r.case == case and (r.plant == 0) == nominal]  # fmt: skip

    def criterion(self, kind: str, case: int, name: str, nominal: bool) -> np.ndarray:
        """Values of criterion ``name`` (``"J1".."J9"``, ``"j2_noise_free"``, ``"peak_force"``);
        NaN for interlocked trials' J."""
        out = []
        for r in self.select(kind, case, nominal):
            if name in CRITERIA:
                out.append(math.nan if r.scores is None else r.scores[name])
            else:
                out.append(float(getattr(r, name)))
        return np.asarray(out, dtype=float)

    def to_dict(self) -> dict[str, Any]:
        """Plain data (``json.dumps`` accepts it)."""
        return {
            "ground": self.ground, "intensity": self.intensity, "perturbed": self.perturbed,
            "wall_s": self.wall, "workers": self.workers,
            "results": [asdict(r) for r in self.results],
        }  # fmt: skip


def run_comparison(
    kinds: Sequence[str] = COMPENSATORS,
    cases: Sequence[int] = (1, 2, 3, 4),
    *,
    ground: str = "el_centro",
    perturbed: int = 20,
    intensity: float = DEFAULT_INTENSITY,
    seed: int = 123,
    package: str | None = None,
    chirp: dict[str, float] | None = None,
    workers: int | None = None,
    progress: Callable[[TrialResult, int, int], None] | None = None,
) -> Comparison:
    """Run every (kind, case, plant) trial.

    Parameters
    ----------
    kinds
        Compensator kinds (``pi_lead`` or :mod:`controllers.factory` kinds).
    cases
        Case numbers (1-4).
    ground
        Ground motion (:data:`plants.frame.GROUND_MOTIONS`).
    perturbed
        Perturbed plants per case (the same draws for every kind and case).
    intensity
        ``eq_intensity`` [-].
    seed
        Seed of the plant draws and of the sensor noise.
    package
        Benchmark package folder for the records (default: ``RTHS_VRTHS_PACKAGE``).
    chirp
        Chirp options (``f_start``, ``f_end``, ``duration``) when ``ground = "chirp"``.
    workers
        Worker processes (default: the CPU count); 1 runs in this process.
    progress
        Called as ``progress(result, done, total)`` after each trial.
    """
    jobs = trial_specs(kinds, cases, ground=ground, perturbed=perturbed, intensity=intensity,
                       seed=seed, package=package, chirp=chirp)  # fmt: skip
    n_workers = max(1, min(workers or os.cpu_count() or 1, len(jobs)))
    result = Comparison(ground, intensity, perturbed, workers=n_workers)
    start = time.perf_counter()
    if n_workers == 1:
        done = map(run_one, jobs)
        for r in done:
            result.results.append(r)
            if progress:
                progress(r, len(result.results), len(jobs))
    else:
        with ProcessPoolExecutor(max_workers=n_workers) as pool:
            for r in pool.map(run_one, jobs, chunksize=1):
                result.results.append(r)
                if progress:
                    progress(r, len(result.results), len(jobs))
    result.wall = time.perf_counter() - start
    return result
