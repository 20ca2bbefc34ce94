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

from rths.config import build
from rths.config.scenario import Scenario
from rths.core.channels import RowBlock
from rths.metrics import normalised_rms_error
from rths.runtime.loop import InProcessLink, Loop

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
    """J2 of one compensator on perturbed lab ``draw``; (nan, reason) if it was interlocked."""
    lab = build.lab(scn, seed=seed + draw, rng=np.random.default_rng([seed, draw]))
    n = scn.run.steps
    target, measured = np.zeros(n), np.zeros(n)

    def sink(block: RowBlock) -> None:
        k0, m = int(block.seq[0]), block.count
        target[k0 : k0 + m], measured[k0 : k0 + m] = (
            block.column("target"),
            block.column("measured"),
        )

    loop = Loop(
        build.substructure(scn),
        build.compensator(scn, kind),
        InProcessLink(lab),
        scn.scaling,
        n,
        sink=sink,
        command_limit=scn.loop.stroke,
        force_filter=build.correction_filter(scn),
    )
    result = loop.run()
    if result.stopped:
        return float("nan"), result.stopped
    return normalised_rms_error(target, measured), None


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
