"""Monte-Carlo RTHS: the scenario re-run on perturbed labs, compensators compared draw by draw.

Draw ``i`` perturbs the emulated lab with the generator ``default_rng([seed, i])`` -- for the
vRTHS benchmark actuator ``a3``, ``beta1``, ``beta2`` and the specimen stiffness, with the
documented standard deviations (Silva et al. 2020) -- while every compensator is designed on the
*nominal* plant, as in a real test.  Every compensator sees the same draws, so the comparison is
paired.  Runs use the in-process ``fast`` clock and write no log; the result is a table of J2
(normalised RMS tracking error, the benchmark's index) per compensator: median and worst.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from typing import Any

import numpy as np
from tqdm import tqdm

from rths.config.scenario import Scenario
from rths.metrics import normalised_rms_error
from rths.session.batch import draw_lab, run_in_process

__all__ = ["MonteCarloResult", "run_draws", "run_one"]


@dataclass(frozen=True)
class MonteCarloResult:
    """J2 [-] per compensator kind and draw (``j2[kind][i]``; NaN if the draw was interlocked)."""

    j2: dict[str, np.ndarray]
    stopped: dict[str, list[str]]

    def table(self) -> list[dict[str, Any]]:
        """Rows ``{kind, median, worst, stopped}`` (J2 as fractions)."""
        rows = []
        for kind, values in self.j2.items():
            finite = values[np.isfinite(values)]
            rows.append(
                {
                    "kind": kind,
                    "median": float(np.median(finite)) if finite.size else None,
                    "worst": float(np.max(finite)) if finite.size == values.size else None,
                    "draws": int(values.size),
                    "stopped": len(self.stopped[kind]),
                }
            )
        return rows


def run_one(scn: Scenario, kind: str, draw: int, seed: int) -> tuple[float, str | None]:
    """J2 of one compensator on perturbed lab ``draw``; (nan, reason) if it was interlocked.

    Draw ``draw`` perturbs the lab with ``default_rng([seed, draw])`` and seeds its noise with
    ``seed + draw`` (:func:`rths.session.batch.draw_lab`).
    """
    run = run_in_process(scn, compensator=kind, **draw_lab(draw, seed))
    if run.stopped:
        return float("nan"), run.stopped
    return normalised_rms_error(run.target, run.measured), None


def run_draws(
    scn: Scenario, kinds: list[str], draws: int, seed: int, progress: bool = True
) -> MonteCarloResult:
    """Run ``draws`` perturbed labs for every compensator in ``kinds``."""
    j2 = {k: np.full(draws, np.nan) for k in kinds}
    stopped: dict[str, list[str]] = {k: [] for k in kinds}
    # disable=None: no bar when stderr is not a terminal (CI logs)
    bar = tqdm(
        total=draws * len(kinds),
        unit="run",
        disable=None if progress else True,
        file=sys.stderr,
        leave=False,
        desc=f"{scn.run.name} Monte Carlo",
    )
    for i in range(draws):
        for kind in kinds:
            value, reason = run_one(scn, kind, i, seed)
            j2[kind][i] = value
            if reason:
                stopped[kind].append(f"draw {i}: {reason}")
            bar.update()
    bar.close()
    return MonteCarloResult(j2, stopped)
