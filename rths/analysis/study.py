"""Parameter studies for damper designers: a grid or Latin hypercube over scenario keys.

A study varies dotted scenario keys (``specimen.inertance``, ``model.damping``...; several keys
can share one value, e.g. the specimen and the model of the same damper) and runs every point as
an RTHS on the fast clock, as a campaign (:mod:`rths.campaign`).  Per point it measures, from
the substructure's ``midspan_displacement``:

* ``peak_midspan_m`` -- the largest midspan displacement [m] while the load acts;
* ``zeta_1``, ``hz_1``, ``zeta_2``, ``hz_2`` -- when the load stops before the end of the run
  (``[substructure.load] duration``), the damping ratios and frequencies of the (up to) two
  modes near the load's frequency in the free decay that follows (matrix pencil,
  :func:`rths.metrics.free_decay`), ascending in frequency; ``zeta``, ``decay_hz``: the
  least-damped of them (the one a designer must raise);
* the same two from the fully numerical run of the point (``*_numerical``,
  :func:`rths.session.mock.numerical_run`: what a perfect RTHS would measure with this protocol);
* ``zeta_exact_min``/``zeta_exact_max`` -- the damping ratios of the roots of the exact
  cable-damper frequency equation near the load's mode (S0 Eq.23 normalisation,
  :mod:`plants.cable.frequency_equation`, the numbers ``rths damping`` prints) plus the cable's
  own intrinsic damping (the Rayleigh ratio, exact at the anchor mode, added to first order),
  for a linear IMD specimen (``imd``, ``imd_simplified``, ``imd_internal`` without damping law,
  friction or backlash).

Near the optimum of an IMD two roots nearly coalesce (S0 §5.3: 0.0905 and 0.0878); the free
decay is then close to ``(a + b t) e^{-sigma t}``, a single fitted exponential would read a
damping below both, and the pencil resolves them less sharply -- the numerical run shows how
much, which is how to tell this from a tracking error.

The plan -- ``--vary`` options or the scenario's ``[study]`` table -- is
:mod:`rths.analysis.study_plan`'s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rths.analysis.study_plan import SAMPLINGS, StudyPlan, Vary, parse_vary, plan
from rths.campaign import Campaign
from rths.campaign.runs import Scalar
from rths.campaign.scenario import ScenarioRun, scenario_run, tracking_row
from rths.config.scenario import Scenario, parse_scenario
from rths.core.errors import DataError
from rths.metrics import free_decay
from rths.session.mock import numerical_run

__all__ = [
    "SAMPLINGS",
    "StudyPlan",
    "StudyRun",
    "Vary",
    "campaign",
    "exact_damping",
    "parse_vary",
    "plan",
    "study_task",
]

MIDSPAN = "midspan_displacement"
_LINEAR_IMD = ("imd", "imd_simplified", "imd_internal")


# ------------------------------------------------------------------------------ one point
def exact_damping(scn: Scenario) -> tuple[float, ...] | None:
    """Damping ratios [-] of the exact frequency equation's roots near the load's mode, plus the
    cable's intrinsic ratio; None when the scenario is not a cable with a linear IMD specimen.

    Parameters
    ----------
    scn
        The scenario (cable, damper position, load mode, specimen, scaling).
    """
    sub, spec = scn.substructure, scn.specimen
    if sub.kind != "cable" or spec.kind not in _LINEAR_IMD:
        return None
    o = spec.options
    if o.damping_law is not None or o.friction or o.clearance:
        return None
    from plants.cable.frequency_equation import exact_roots
    from plants.cable.properties import CableProperties, normalised_damper, normalised_stiffness

    c = sub.options
    cable = CableProperties(c.length, c.tension, c.mass_per_length)
    lam = scn.scaling.impedance
    m_e, c_d = normalised_damper(cable, o.inertance * lam, o.damping * lam)
    series = spec.kind != "imd_simplified" and o.has_internal_stiffness
    k_e = normalised_stiffness(cable, o.stiffness * lam) if series else None
    roots = exact_roots(c.load.mode, c.damper_position, m_e, c_d, k_e=k_e)
    return tuple(r.zeta + c.intrinsic_damping for r in roots)


def _response(scn: Scenario, midspan: np.ndarray, suffix: str) -> dict[str, Scalar]:
    """Peak while loaded and the modes of the free decay after the load stops: the
    least-damped one (``zeta``, ``decay_hz``) and each of the two the pencil keeps
    (``zeta_1``/``hz_1``, ``zeta_2``/``hz_2``, ascending in frequency)."""
    out: dict[str, Scalar] = {f"peak_midspan{suffix}_m": None, f"zeta{suffix}": None}
    out[f"decay{suffix}_hz"] = None
    for i in (1, 2):
        out[f"zeta{suffix}_{i}"] = out[f"hz{suffix}_{i}"] = None
    if midspan.size == 0 or not np.all(np.isfinite(midspan)):
        return out
    dt = scn.run.dt
    options = scn.substructure.options
    end = getattr(getattr(options, "load", None), "duration", None)
    k = midspan.size if end is None else min(midspan.size, round(end / dt))
    out[f"peak_midspan{suffix}_m"] = float(np.max(np.abs(midspan[:k]))) if k else None
    period = getattr(options, "excitation_period", None)
    if end is None or period is None or midspan.size - k < 64:
        return out
    try:
        found = free_decay(midspan[k:], dt, modes=2, band=(0.6 / period, 1.4 / period))
    except DataError:
        return out
    if found:
        least = min(found, key=lambda m: m.damping_ratio)
        out[f"zeta{suffix}"], out[f"decay{suffix}_hz"] = least.damping_ratio, least.frequency
    for i, mode in enumerate(found[:2], 1):
        out[f"zeta{suffix}_{i}"], out[f"hz{suffix}_{i}"] = mode.damping_ratio, mode.frequency
    return out


@dataclass(frozen=True)
class StudyRun:
    """The payload of a study point: the scenario run and whether to run the numerical twin.

    Parameters
    ----------
    run
        The scenario run (keeps ``midspan_displacement``).
    numerical
        Also run the fully numerical model of the point (``*_numerical`` columns).
    """

    run: ScenarioRun
    numerical: bool = True


def study_task(spec: StudyRun) -> dict[str, Scalar]:
    """One study point: tracking columns, response, numerical twin and exact damping.

    Parameters
    ----------
    spec
        The point.
    """
    scn = spec.run.scenario()
    batch = spec.run.execute(scn)
    row = tracking_row(batch)
    midspan = batch.outputs.get(MIDSPAN, np.zeros(0))
    row.update(_response(scn, midspan if not batch.stopped else np.zeros(0), ""))
    if spec.numerical:
        twin = numerical_run(scn)
        row.update(_response(scn, twin.get(MIDSPAN, np.zeros(0)), "_numerical"))
    exact = exact_damping(scn)
    row["zeta_exact_min"] = None if not exact else min(exact)
    row["zeta_exact_max"] = None if not exact else max(exact)
    return row


def campaign(
    scn: Scenario, study: StudyPlan, compensator: str | None = None, numerical: bool = True
) -> Campaign:
    """The study's campaign; every point's overrides are validated here first (a bad key or
    value is one :class:`ConfigError` before anything runs).

    Parameters
    ----------
    scn
        The scenario studied.
    study
        What varies and how it is sampled.
    compensator
        Compensator kind overriding the scenario's.
    numerical
        Also run each point's fully numerical twin.
    """
    runs = []
    for point in study.points():
        parse_scenario(scn.text, scn.source, point)  # raises on a bad key or value
        base = scenario_run(
            scn,
            overrides=point,
            compensator=compensator,
            outputs=(MIDSPAN,),
            extra=("study", numerical),
        )
        runs.append(type(base)(base.key, base.inputs, StudyRun(base.payload, numerical)))
    return Campaign(f"{scn.run.name} study", runs, study_task)
