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
data) and :func:`run_one` runs and scores one.  :func:`run_comparison` runs them as a campaign
(:mod:`rths.campaign`): one run = one case x plant draw x compensator
(:func:`comparison_campaign`), on an embedded Dask ``LocalCluster`` or a cluster, one table row
per trial (:func:`trial_row`: J1-J9, noise-free J2, noise floor, peak force, interlock, wall and
CPU time), resumable; the rows give back exactly the trials run in this process
(:func:`trial_from_row`).  Tables are built by :mod:`~rths.experiments.vrths.tables`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits

from plants.frame.cases import CASES
from plants.frame.ground_motion import DEFAULT_INTENSITY, GroundMotion, ground_motion
from rths.campaign import Campaign, CampaignStats, Cluster, ResultTable, Run, execute
from rths.campaign.runs import run_key
from rths.campaign.table import Row
from rths.core.errors import ParameterError, RTHSError, format_choices
from rths.experiments.vrths.draws import PlantDraw, draw_plants
from rths.experiments.vrths.rig import benchmark_compensator, reference_for, run_trial, score
from rths.metrics.vrths import ACTUATOR_CAPACITY, CRITERIA

__all__ = [
    "COMPENSATORS",
    "Comparison",
    "TrialResult",
    "TrialSpec",
    "comparison_campaign",
    "run_comparison",
    "run_one",
    "trial_from_row",
    "trial_row",
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

    BLAS runs on one thread during the trial: the scoring's long dot products (J1's 50 lags of
    ~170,000 samples) would otherwise start BLAS threads that spin for work on a machine whose
    cores are already busy with the other trials (measured: 1.2 s of CPU per trial on the 2-core
    VM, 40 times the single-threaded cost), and a sum split across threads depends on the
    thread count, which must not change a result.  (The campaign executor limits its workers
    likewise; this covers any other caller.)

    Parameters
    ----------
    job
        The trial (:func:`trial_specs`).
    """
    with threadpool_limits(limits=1, user_api="blas"):
        return _run_one(job)


def _run_one(job: TrialSpec) -> TrialResult:
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


#: Result columns of a trial's row, in order (J's are NaN when an interlock stopped the run).
RESULT_COLUMNS: tuple[str, ...] = (
    *CRITERIA,
    "j2_noise_free",
    "noise_floor",
    "peak_force",
    "over_capacity",
    "stopped",
)


def trial_row(job: TrialSpec) -> Row:
    """The campaign's task: :func:`run_one` as a table row (:data:`RESULT_COLUMNS` and
    ``status``: ``ok``, ``interlock`` or ``rejected``, a plant whose loop could not be built).

    Parameters
    ----------
    job
        The trial (a run's payload).
    """
    r = run_one(job)
    scores = r.scores or {}
    row: Row = {name: scores.get(name, math.nan) for name in CRITERIA}
    row.update(
        j2_noise_free=r.j2_noise_free,
        noise_floor=r.noise_floor,
        peak_force=r.peak_force,
        over_capacity=r.over_capacity,
        stopped=r.stopped,
    )
    if r.stopped is not None:
        row["status"] = "rejected" if r.stopped.startswith("rejected:") else "interlock"
    return row


def trial_from_row(row: Row) -> TrialResult:
    """The :class:`TrialResult` a campaign row holds (bit for bit: floats travel unchanged;
    ``wall`` is the row's ``wall_s``).  A failed row (``status = "error"``) is a trial stopped
    by its error.

    Parameters
    ----------
    row
        A row of :func:`comparison_campaign`'s table.
    """

    def number(name: str) -> float:
        value = row.get(name)
        return float(value) if isinstance(value, int | float) else math.nan

    stopped = row.get("stopped")
    if row.get("status") == "error":
        stopped = f"error: {row.get('error')}"
    scores = None if stopped is not None else {name: number(name) for name in CRITERIA}
    return TrialResult(
        str(row["compensator"]),
        int(number("case")),
        int(number("plant")),
        scores,
        number("j2_noise_free"),
        number("noise_floor"),
        number("peak_force"),
        None if stopped is None else str(stopped),
        number("wall_s"),
    )


def _inputs(job: TrialSpec) -> dict[str, Any]:
    inputs: dict[str, Any] = {
        "compensator": job.kind,
        "case": job.case,
        "plant": job.plant_index,
        "ground": job.ground,
        "intensity": job.intensity,
        "seed": job.seed,
    }
    inputs.update(asdict(job.plant))
    inputs.update({f"chirp.{k}": v for k, v in job.chirp})
    return inputs


def comparison_campaign(specs: Sequence[TrialSpec]) -> Campaign:
    """The comparison as a campaign: one run per trial (case x plant draw x compensator), keyed
    by everything that determines its result (not the package's path), task :func:`trial_row`.

    Parameters
    ----------
    specs
        The trials (:func:`trial_specs`), in table order.
    """
    runs = []
    for job in specs:
        inputs = _inputs(job)
        runs.append(Run(run_key("vrths-compare", inputs), inputs, job))
    return Campaign("vRTHS comparison", runs, trial_row)


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
    stats
        What the campaign did (runs resumed from the table, failures, timing), if it ran as one.
    keys
        The campaign's run keys, in the order of :attr:`results` (their rows' digest:
        :meth:`rths.campaign.ResultTable.digest`).
    """

    ground: str
    intensity: float
    perturbed: int
    results: list[TrialResult] = field(default_factory=list)
    wall: float = 0.0
    workers: int = 1
    stats: CampaignStats | None = None
    keys: list[str] = field(default_factory=list)

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
    cluster: Cluster | None = None,
    table: ResultTable | None = None,
    progress: bool = False,
    retry_failed: bool = False,
) -> Comparison:
    """Run every (kind, case, plant) trial as a campaign (:func:`comparison_campaign`).

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
        Benchmark package folder for the records (default: ``RTHS_VRTHS_PACKAGE``, else
        ``RTHS_DATA``'s); on a cluster, every worker must see the records at this path (or
        through its own environment).
    chirp
        Chirp options (``f_start``, ``f_end``, ``duration``) when ``ground = "chirp"``.
    cluster
        Where the trials run (default: an embedded ``LocalCluster``, one worker per core).
    table
        Results table (default: in memory); trials it already holds are not run again.
    progress
        A progress bar over trials on stderr (when it is a terminal).
    retry_failed
        Run again the trials whose rows say ``status = "error"``.
    """
    specs = trial_specs(
        kinds,
        cases,
        ground=ground,
        perturbed=perturbed,
        intensity=intensity,
        seed=seed,
        package=package,
        chirp=chirp,
    )
    campaign = comparison_campaign(specs)
    table = table if table is not None else ResultTable(None)
    stats = execute(campaign, table, cluster, progress=progress, retry_failed=retry_failed)
    rows = table.rows([run.key for run in campaign.runs])  # in campaign order (reindexed)
    return Comparison(
        ground,
        intensity,
        perturbed,
        [trial_from_row(r) for r in rows],
        wall=stats.wall,
        workers=stats.workers,
        stats=stats,
        keys=[str(r["run"]) for r in rows],
    )
