"""Monte-Carlo RTHS: the scenario re-run on perturbed labs, compensators compared draw by draw.

Draw ``i`` perturbs the emulated lab with the generator ``default_rng([seed, i])`` -- for the
vRTHS benchmark actuator ``a3``, ``beta1``, ``beta2`` and the specimen stiffness, with the
documented standard deviations (Silva et al. 2020) -- while every compensator is designed on the
*nominal* plant, as in a real test.  Every compensator sees the same draws, so the comparison is
paired.  The draws x compensators runs are a campaign (:mod:`rths.campaign`): independent tasks
on a Dask cluster (embedded by default), each on the in-process ``fast`` clock with no log, one
table row per run (J1-J3, sync RMSE, interlock, wall time); the summary is J2 (normalised RMS
tracking error, the benchmark's index) per compensator: median and worst.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from rths.campaign import Campaign, CampaignStats, Cluster, ResultTable, execute
from rths.campaign.scenario import scenario_run, scenario_task
from rths.campaign.table import Row
from rths.config.scenario import Scenario
from rths.metrics import normalised_rms_error
from rths.session.batch import draw_lab, run_in_process

__all__ = ["MonteCarloResult", "campaign", "j2_figure", "run_draws", "run_one"]


@dataclass(frozen=True)
class MonteCarloResult:
    """The outcome of a Monte-Carlo campaign.

    Attributes
    ----------
    j2
        J2 [-] per compensator kind and draw (``j2[kind][i]``; NaN if the draw was interlocked
        or failed).
    stopped
        Per kind, ``"draw i: reason"`` of every draw without a J2.
    rows
        The campaign's table rows, in run order.
    stats
        How the campaign ran (:class:`rths.campaign.CampaignStats`).
    """

    j2: dict[str, np.ndarray]
    stopped: dict[str, list[str]]
    rows: list[Row] = field(default_factory=list)
    stats: CampaignStats = field(default_factory=CampaignStats)

    def table(self) -> list[dict[str, Any]]:
        """Rows ``{kind, median, worst, draws, stopped}`` (J2 as fractions)."""
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

    Parameters
    ----------
    scn
        The scenario.
    kind
        Compensator kind.
    draw
        Draw number: the lab is perturbed with ``default_rng([seed, draw])`` and its noise
        seeded with ``seed + draw`` (:func:`rths.session.batch.draw_lab`).
    seed
        Monte-Carlo seed.
    """
    run = run_in_process(scn, compensator=kind, **draw_lab(draw, seed))
    if run.stopped:
        return float("nan"), run.stopped
    return normalised_rms_error(run.target, run.measured), None


def campaign(scn: Scenario, kinds: list[str], draws: int, seed: int) -> Campaign:
    """The Monte-Carlo campaign: ``draws`` perturbed labs x ``kinds`` (draw-major order).

    Parameters
    ----------
    scn
        The scenario.
    kinds
        Compensator kinds.
    draws
        Number of perturbed labs.
    seed
        Monte-Carlo seed.
    """
    runs = [
        scenario_run(scn, compensator=k, draw=i, seed=seed) for i in range(draws) for k in kinds
    ]
    return Campaign(f"{scn.run.name} Monte Carlo", runs, scenario_task)


def run_draws(
    scn: Scenario,
    kinds: list[str],
    draws: int,
    seed: int,
    progress: bool = True,
    *,
    cluster: Cluster | None = None,
    table: str | Path | ResultTable | None = None,
    retry_failed: bool = False,
    batch: int | None = None,
) -> MonteCarloResult:
    """Run ``draws`` perturbed labs for every compensator in ``kinds``.

    Parameters
    ----------
    scn
        The scenario.
    kinds
        Compensator kinds.
    draws
        Number of perturbed labs, >= 1.
    seed
        Monte-Carlo seed (draw ``i`` uses ``default_rng([seed, i])``).
    progress
        Progress bar over runs (only when stderr is a terminal).
    cluster
        Where to run (default: an embedded cluster sized to the machine).
    table
        Results table (path ``*.parquet``/``*.csv`` or a :class:`ResultTable`); runs it
        already holds are not run again.  None: in memory only.
    retry_failed
        Run again the runs whose rows say ``status = "error"``.
    batch
        Runs per task (None: automatic, :func:`rths.campaign.executor.batch_size`).
    """
    c = campaign(scn, kinds, draws, seed)
    t = table if isinstance(table, ResultTable) else ResultTable(table)
    stats = execute(c, t, cluster, progress=progress, retry_failed=retry_failed, batch=batch)
    rows = t.rows(r.key for r in c.runs)
    j2 = {k: np.full(draws, np.nan) for k in kinds}
    stopped: dict[str, list[str]] = {k: [] for k in kinds}
    for row in rows:
        kind, i = str(row["compensator"]), row["draw"]
        assert isinstance(i, int)
        value = row.get("j2")
        if isinstance(value, float) and row.get("status") == "ok":
            j2[kind][i] = value
        else:
            reason = row.get("stopped") or row.get("error") or "not measured"
            stopped[kind].append(f"draw {i}: {reason}")
    return MonteCarloResult(j2, stopped, rows, stats)


def j2_figure(result: MonteCarloResult, path: str | Path, title: str = "") -> Path:
    """J2 of every draw per compensator (dots; interlocked or failed draws as crosses at the
    top), with the median; writes a PNG and returns its path.

    Parameters
    ----------
    result
        The Monte Carlo.
    path
        PNG to write.
    title
        Figure title (default: the number of draws).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    kinds = list(result.j2)
    fig, ax = plt.subplots(figsize=(1.2 * len(kinds) + 2.5, 4.0))
    finite_all = np.concatenate([v[np.isfinite(v)] for v in result.j2.values()] or [np.zeros(0)])
    top = 100.0 * float(finite_all.max()) * 1.5 if finite_all.size else 1.0
    rng = np.random.default_rng(0)  # horizontal jitter only, for legibility
    for x, kind in enumerate(kinds):
        values = 100.0 * result.j2[kind]
        ok = np.isfinite(values)
        jitter = rng.uniform(-0.15, 0.15, values.size)
        ax.plot(x + jitter[ok], values[ok], ".", color="C0", alpha=0.7)
        if (~ok).any():
            ax.plot(x + jitter[~ok], np.full((~ok).sum(), top), "x", color="C3")
        if ok.any():
            ax.hlines(np.median(values[ok]), x - 0.3, x + 0.3, color="k", lw=2)
    ax.set_xticks(range(len(kinds)), kinds)
    ax.set_yscale("log")
    ax.set_ylabel("J2 [%] (median: bar; x: interlocked or failed)")
    draws = next(iter(result.j2.values())).size if result.j2 else 0
    ax.set_title(title or f"J2 over {draws} perturbed labs")
    ax.grid(True, which="both", axis="y", alpha=0.3)
    fig.tight_layout()
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out
