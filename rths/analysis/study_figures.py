"""Figures of a parameter study (:mod:`rths.analysis.study`).

``damping``  modal damping ratio over the first varied key, one colour per combination of the
             other keys: the (up to two) modes of the RTHS free decay (filled dots), of the
             numerical twin (open squares) and
             the exact frequency equation's roots on a fine grid (lines of small dots; what
             ``rths damping`` prints) -- for a grid study; for a Latin hypercube, measured
             against exact (one dot per point, the 1:1 line);
``peak``     peak midspan displacement while loaded over the first varied key (RTHS and
             numerical twin).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from rths.analysis.study import StudyPlan, exact_damping
from rths.campaign.table import Row
from rths.config.scenario import Scenario, parse_scenario

__all__ = ["study_figures"]


def _series(rows: Sequence[Row], study: StudyPlan) -> dict[tuple[Any, ...], list[Row]]:
    """Rows grouped by the values of every vary but the first."""
    others = [v.label for v in study.varies[1:]]
    groups: dict[tuple[Any, ...], list[Row]] = {}
    for r in rows:
        groups.setdefault(tuple(r.get(k) for k in others), []).append(r)
    for members in groups.values():
        members.sort(key=lambda r: float(r[study.varies[0].label] or 0.0))
    return groups


def _values(rows: Sequence[Row], column: str) -> np.ndarray:
    return np.array([np.nan if r.get(column) is None else float(r[column]) for r in rows])  # type: ignore[arg-type]


def _exact_curve(
    scn: Scenario, study: StudyPlan, fixed: dict[str, Any], n: int = 80
) -> tuple[np.ndarray, np.ndarray]:
    """(x, zeta) of every exact root along the first vary (others held at ``fixed``)."""
    first = study.varies[0]
    grid = [float(v) for v in first.grid()]  # type: ignore[arg-type]
    lo, hi = min(grid), max(grid)
    xs = np.geomspace(lo, hi, n) if first.log and lo > 0 else np.linspace(lo, hi, n)
    px, pz = [], []
    for x in xs:
        point = {**fixed, **{k: float(x) for k in first.keys}}
        zetas = exact_damping(parse_scenario(scn.text, scn.source, point)) or ()
        px += [x] * len(zetas)
        pz += list(zetas)
    return np.array(px), np.array(pz)


def study_figures(
    scn: Scenario, study: StudyPlan, rows: Sequence[Row], stem: Path, title: str = ""
) -> list[Path]:
    """Write the study's figures as ``<stem>_damping.png`` and ``<stem>_peak.png``.

    Parameters
    ----------
    scn
        The scenario studied (for the exact curve).
    study
        The plan.
    rows
        The campaign's rows.
    stem
        Path prefix of the figures.
    title
        Figure title (default: the scenario name).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    title = title or f"{scn.run.name}: parameter study ({len(rows)} points)"
    first = study.varies[0]
    out = []
    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    if study.sampling == "grid":
        for i, (key, members) in enumerate(_series(rows, study).items()):
            colour = f"C{i}"
            label = ", ".join(
                f"{v.label} = {k:g}" if isinstance(k, float) else f"{v.label} = {k}"
                for v, k in zip(study.varies[1:], key, strict=True)
            )
            x = _values(members, first.label)
            fixed = {k: members[0][v.label] for v in study.varies[1:] for k in v.keys}
            ex, ez = _exact_curve(scn, study, fixed)
            if ez.size:
                ax.plot(ex, 100 * ez, ".", ms=2, color=colour, alpha=0.6)
            for i in (1, 2):
                first_mode = i == 1
                ax.plot(
                    x,
                    100 * _values(members, f"zeta_{i}"),
                    "o",
                    color=colour,
                    label=f"RTHS {label}".strip() if first_mode else None,
                )
                ax.plot(
                    x,
                    100 * _values(members, f"zeta_numerical_{i}"),
                    "s",
                    mfc="none",
                    color=colour,
                    ms=8,
                    label=f"numerical {label}".strip() if first_mode else None,
                )
        ax.plot([], [], ".", color="0.4", label="exact roots (+ cable's intrinsic)")
        ax.set_xlabel(
            first.label + ("" if len(first.keys) == 1 else f" (= {', '.join(first.keys[1:])})")
        )
        ax.set_xscale("log" if first.log else "linear")
    else:
        exact = _values(rows, "zeta_exact_min")
        ax.plot(100 * exact, 100 * _values(rows, "zeta"), "o", label="RTHS")
        ax.plot(
            100 * exact, 100 * _values(rows, "zeta_numerical"), "s", mfc="none", label="numerical"
        )
        lim = np.nanmax(100 * exact) if np.isfinite(exact).any() else 1.0
        ax.plot([0, lim], [0, lim], "k-", lw=0.8, label="1:1")
        ax.set_xlabel("exact damping ratio, least-damped root [%]")
    ax.set_ylabel("modal damping ratio from the free decay [%]")
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    stem.parent.mkdir(parents=True, exist_ok=True)
    path = stem.with_name(stem.name + "_damping.png")
    fig.savefig(path, dpi=120)
    plt.close(fig)
    out.append(path)

    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    x = _values(rows, first.label)
    order = np.argsort(x)
    ax.plot(x[order], 1e3 * _values(rows, "peak_midspan_m")[order], "o", label="RTHS")
    ax.plot(
        x[order],
        1e3 * _values(rows, "peak_midspan_numerical_m")[order],
        "s",
        mfc="none",
        label="numerical",
    )
    ax.set_xlabel(first.label)
    ax.set_ylabel("peak midspan displacement while loaded [mm]")
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    path = stem.with_name(stem.name + "_peak.png")
    fig.savefig(path, dpi=120)
    plt.close(fig)
    out.append(path)
    return out
