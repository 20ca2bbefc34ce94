"""Tables and the J2 figure of a benchmark comparison (:mod:`~rths.experiments.vrths.compare`).

The nominal table has the benchmark's layout: criteria J1-J9 as rows (J1 in ms, J2-J9 in %,
F4's rounding), the four cases as columns.  The perturbed table gives the median and the worst
(largest) value over the perturbed plants; interlocked trials have no J and are counted apart.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from rths.experiments.vrths.compare import Comparison
from rths.metrics.vrths import ACTUATOR_CAPACITY, CRITERIA

__all__ = ["nominal_table", "perturbed_table", "plot_j2", "render", "worst_j2_table"]

_UNITS = {"J1": "ms"} | {name: "%" for name in CRITERIA[1:]}
_WIDTH = 24  # characters of a kind's tables' label column


def _fmt(value: float, digits: int = 2) -> str:
    return "-" if not math.isfinite(value) else f"{value:.{digits}f}"


def _label(name: str) -> str:
    return f"{name} [{_UNITS[name]}]"


def _head(title: str, cases: Sequence[int], column: int, width: int = _WIDTH) -> list[str]:
    """A table's title and its header: a blank label column, then ``Case n`` per case."""
    return [title, " " * width + "".join(f"{'Case ' + str(n):>{column}}" for n in cases)]


def _row(label: str, cells: list[str], column: int, width: int = _WIDTH) -> str:
    """One line of a table: the label, then each cell right-aligned in ``column`` characters."""
    return f"{label:<{width}}" + "".join(f"{cell:>{column}}" for cell in cells)


def _title(c: Comparison, kind: str, what: str) -> str:
    return f"{kind} -- {c.ground} x {c.intensity:g}, {what}"


def nominal_table(c: Comparison, kind: str) -> str:
    """J1-J9 of ``kind`` on the nominal plant, one column per case (the benchmark's layout).

    Parameters
    ----------
    c : rths.experiments.vrths.compare.Comparison
        The finished comparison (trials of every kind, case and plant).
    kind : str
        The compensator kind whose trials are tabulated (one of ``c.kinds``).
    """
    cases = c.cases
    lines = _head(_title(c, kind, "nominal plant (F4_evaluation.m)"), cases, 10)
    for name in CRITERIA:
        digits = 1 if name == "J1" else 2
        row = [_fmt(float(c.criterion(kind, n, name, True)[0]), digits) for n in cases]
        lines.append(_row(_label(name), row, 10))
    extra = (("J2 noise-free [%]", "j2_noise_free", 1.0, 2),
             ("J2 noise floor [%]", "noise_floor", 1.0, 2),
             ("max|F_a| [kN]", "peak_force", 1e-3, 2))  # fmt: skip
    for label, attr, scale, digits in extra:
        row = [_fmt(scale * float(c.criterion(kind, n, attr, True)[0]), digits) for n in cases]
        lines.append(_row(label, row, 10))
    stopped = [c.select(kind, n, True)[0].stopped for n in cases]
    lines.append(_row("interlock", ["yes" if s else "no" for s in stopped], 10))
    return "\n".join(lines)


def perturbed_table(c: Comparison, kind: str) -> str:
    """Median / worst of J1-J9 over the perturbed plants, interlocks and actuator force.

    Parameters
    ----------
    c : rths.experiments.vrths.compare.Comparison
        The finished comparison (trials of every kind, case and plant).
    kind : str
        The compensator kind whose trials are tabulated (one of ``c.kinds``).
    """
    cases = c.cases
    lines = _head(_title(c, kind, f"{c.perturbed} perturbed plants: median / worst"), cases, 16)
    names = [*CRITERIA, "j2_noise_free"]
    for name in names:
        digits = 1 if name == "J1" else 2
        cells = []
        for n in cases:
            v = c.criterion(kind, n, name, False)
            v = v[np.isfinite(v)]
            cells.append("-" if v.size == 0 else f"{_fmt(float(np.median(v)), digits)} / "
                         f"{_fmt(float(np.max(v)), digits)}")  # fmt: skip
        label = _label(name) if name in CRITERIA else "J2 noise-free [%]"
        lines.append(_row(label, cells, 16))
    cells = []
    for n in cases:
        trials = c.select(kind, n, False)
        stopped = sum(r.stopped is not None for r in trials)
        cells.append(f"{stopped}/{len(trials)}")
    lines.append(_row("interlocks", cells, 16))
    cells = []
    for n in cases:
        trials = c.select(kind, n, False)
        peak = max((r.peak_force for r in trials), default=math.nan)
        over = sum(r.over_capacity for r in trials)
        cells.append(f"{_fmt(peak / 1e3)} ({over} >=8.9)")
    lines.append(_row("max|F_a| [kN]", cells, 16))
    return "\n".join(lines)


def worst_j2_table(c: Comparison) -> str:
    """Worst F4 J2 [%] (and worst noise-free J2) over the perturbed plants, kind x case.

    Parameters
    ----------
    c : rths.experiments.vrths.compare.Comparison
        The finished comparison (trials of every kind, case and plant).
    """
    cases = c.cases
    title = (
        f"worst J2 over {c.perturbed} perturbed plants [%] (F4 / noise-free); "
        "'*' = some runs interlocked"
    )
    lines = _head(title, cases, 18, width=12)
    for kind in c.kinds:
        cells = []
        for n in cases:
            j2 = c.criterion(kind, n, "J2", False)
            clean = c.criterion(kind, n, "j2_noise_free", False)
            mark = "*" if np.any(~np.isfinite(j2)) else ""
            worst = np.max(j2[np.isfinite(j2)]) if np.any(np.isfinite(j2)) else math.nan
            cells.append(f"{_fmt(worst)}{mark} / {_fmt(float(np.nanmax(clean)))}")
        lines.append(_row(kind, cells, 18, width=12))
    return "\n".join(lines)


def render(c: Comparison) -> str:
    """Every table of the comparison, then its wall time.

    Parameters
    ----------
    c : rths.experiments.vrths.compare.Comparison
        The finished comparison (trials of every kind, case and plant).
    """
    blocks = []
    for kind in c.kinds:
        blocks.append(nominal_table(c, kind))
        if c.perturbed:
            blocks.append(perturbed_table(c, kind))
    if c.perturbed:
        blocks.append(worst_j2_table(c))
    n = len(c.results)
    ran = n if c.stats is None else c.stats.ran
    done = f"{n} trials" if ran == n else f"{n} trials ({n - ran} from the table)"
    if ran:
        done += f", {ran} run in {c.wall:.0f} s wall time on {c.workers} worker(s)"
    blocks.append(f"{done}; capacity {ACTUATOR_CAPACITY / 1e3:g} kN")
    return "\n\n".join(blocks)


def plot_j2(c: Comparison, path: str | Path) -> Path:
    """Figure: J2 (F4, filled) and noise-free J2 (open) of every trial, one panel per case.

    Parameters
    ----------
    c : rths.experiments.vrths.compare.Comparison
        The finished comparison (trials of every kind, case and plant).
    path : str or pathlib.Path
        Image file to write (format from the suffix, e.g. ``.png``).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases, kinds = c.cases, c.kinds
    fig, axes = plt.subplots(1, len(cases), figsize=(3.2 * len(cases), 3.6), sharey=True,
                             squeeze=False)  # fmt: skip
    for ax, n in zip(axes[0], cases, strict=True):
        for i, kind in enumerate(kinds):
            for nominal, style in ((False, {"s": 10, "alpha": 0.6}), (True, {"s": 40})):
                j2 = c.criterion(kind, n, "J2", nominal)
                clean = c.criterion(kind, n, "j2_noise_free", nominal)
                x = np.full(j2.size, i) + (0.0 if nominal else 0.12)
                ax.scatter(x, j2, color="C0" if nominal else "C1", marker="o", **style)
                ax.scatter(x, clean, facecolors="none", edgecolors="C2", marker="o", **style)
        ax.axhline(1.0, color="grey", lw=0.8, ls="--")
        ax.set_yscale("log")
        ax.set_xticks(range(len(kinds)), kinds, rotation=60, fontsize=8)
        ax.set_title(f"Case {n}")
    axes[0][0].set_ylabel("J2 [%]  (filled: F4, open: noise-free)")
    fig.suptitle(f"J2 per case -- {c.ground} x {c.intensity:g}; large: nominal, small: perturbed")
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out
