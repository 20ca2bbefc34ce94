"""Report of an S1 shake-table sweep: the numbers S1 quotes and plots like S1 Fig.5/10/12/17/18.

Numbers (:func:`summarise`), per PGA and sweep direction:

* resonance frequencies: ``f0`` = peak of ``Ĥ_uI`` of the uncontrolled PS; ``f1`` = peak of
  ``Ĥ_uI`` with the TMDI; ``f2`` = most prominent peak of the PS total acceleration
  ``Ĥ_{ü_I^(tot)}`` above ``f1`` (S1 §3.1-3.2: f2 "is mostly evident in the acceleration
  response");
* the change of the peak PS displacement FRF with the TMDI, ``max Ĥ_uI(TMDI) / max Ĥ_uI(PS) - 1``
  (S1 §3.1: -37 % at 0.05 g, -25 % at 0.15 g);
* the NRMSE of every S1 Eq.7 FRF of the ideal-inerter model against the rack-and-pinion
  ("experiment-like") model, over the whole grid and near ``f1`` (``±15 %``), S1 §4.2;
* next to them, what S1 reports at that PGA (:data:`S1_REPORTED`).

Figures (:func:`write_figures`, PNG via matplotlib's Agg backend):

``frf_<pga>g.png``        the 9 S1 Eq.7 FRFs, rack-and-pinion vs ideal inerter, up and down sweeps
                          overlaid, uncontrolled PS on the PS row (layout of S1 Fig.17/18);
``ps_displacement.png``   ``Ĥ_uI`` up vs down for the PS and the TMDI at each PGA (S1 Fig.5), with
                          S1's uncontrolled-PS numbers (peak, ``f0``) where S1 gives them;
``loops_<pga>g.png``      ``F_I-u_I``, ``F_T-u_TI``, ``F_B-u_T``, ``F_B-ü_T`` over the last cycle at
                          ``f1``, ``f0``, ``f2`` (S1 Fig.9/10/12), down sweep.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Final

import numpy as np

from rths.core.errors import ParameterError
from rths.experiments.s1_shake_table.frf import (
    FRF,
    frf_nrmse,
    resonance,
    second_resonance,
)
from rths.experiments.s1_shake_table.sweep import (
    STANDARD_GRAVITY,
    SweepResult,
    SweepRun,
)

__all__ = [
    "FRF_UNITS",
    "NEAR_F1",
    "S1_REPORTED",
    "frf_figure",
    "frf_records",
    "frf_table",
    "loops_figure",
    "ps_displacement_figure",
    "summarise",
    "write_figures",
]

#: Half-width of the band around ``f1`` in which the ideal-inerter model is compared [-].
NEAR_F1: Final[float] = 0.15

#: What S1 reports about the campaign, per PGA [g] (keys as in :func:`summarise`): absolute
#: peak ``u_I`` [m] of the uncontrolled PS (S1 §3.1), its resonance ``f0`` [Hz] (S1 Fig.12
#: caption) and the change of the peak PS displacement with the IM-IF TMDI [-] (S1 §3.1).
S1_REPORTED: Final[dict[str, dict[str, float]]] = {
    "0.05": {"ps_peak_u_I": 0.005, "ps_peak_change": -0.37},
    "0.1": {"f0": 2.25},
    "0.15": {"ps_peak_u_I": 0.038, "ps_peak_change": -0.25},
}

_TMDI_MODELS: Final[tuple[str, ...]] = ("rack_pinion", "ideal")
_PANELS: Final[tuple[tuple[str, str], ...]] = (
    ("u_I", "(a) PS displacement $u_I$ [s²]"),
    ("a_I_tot", "(b) PS acceleration $\\ddot u_I^{(tot)}$ [-]"),
    ("F_I", "(c) primary isolator force $F_I$ [kg]"),
    ("u_TI", "(d) TMDI stroke $u_{TI}$ [s²]"),
    ("a_T_tot", "(e) secondary mass acceleration $\\ddot u_T^{(tot)}$ [-]"),
    ("F_T", "(f) secondary isolator force $F_T$ [kg]"),
    ("u_T", "(g) secondary mass displacement $u_T$ [s²]"),
    ("a_T", "(h) inerter relative acceleration $\\ddot u_T$ [-]"),
    ("F_B", "(i) inerter force $F_B$ [kg]"),
)
_LABELS: Final[dict[str, str]] = {
    "uncontrolled": "uncontrolled PS",
    "rack_pinion": "TMDI, rack-and-pinion",
    "ideal": "TMDI, ideal inerter",
}


#: Unit of the normalised FRF (S1 Eq.7) of each quantity.
FRF_UNITS: Final[dict[str, str]] = {
    "u_I": "s^2",
    "a_I_tot": "-",
    "F_I": "kg",
    "u_TI": "s^2",
    "a_T_tot": "-",
    "F_T": "kg",
    "u_T": "s^2",
    "a_T": "-",
    "F_B": "kg",
}


def frf_table(result: SweepResult) -> tuple[list[str], list[list[str]]]:
    """The FRFs of every run of ``result`` as CSV rows: header and rows of text.

    Columns: ``pga [g]``, ``model``, ``direction``, ``frequency [Hz]``, ``a_G [m/s^2]`` (the
    measured table amplitude ``H_üG``) and the normalised FRF ``Ĥ_p`` of each S1 Eq.7 quantity
    (unit in the header; empty for quantities a model lacks).

    Parameters
    ----------
    result : SweepResult
        The sweep (:func:`rths.experiments.s1_shake_table.sweep.run_sweep`).
    """
    header = ["pga [g]", "model", "direction", "frequency [Hz]", "a_G [m/s^2]"]
    header += [f"{name} [{unit}]" for name, unit in FRF_UNITS.items()]
    rows = []
    for run in result.runs:
        frf = run.frf
        values = {n: frf.normalised(n) for n in FRF_UNITS if n in frf.response}
        for i, f in enumerate(frf.frequency):
            row = [f"{run.pga:g}", run.model, run.direction, f"{f:.6g}", f"{frf.excitation[i]:.9g}"]
            row += [f"{values[n][i]:.9g}" if n in values else "" for n in FRF_UNITS]
            rows.append(row)
    return header, rows


def frf_records(result: SweepResult) -> dict[str, Any]:
    """The FRFs of every run of ``result`` as a JSON-ready dict.

    ``{"units": FRF_UNITS, "runs": [{"pga", "model", "direction", "frequency_hz", "a_G",
    "frf": {quantity: [Ĥ_p ...]}}]}``: frequencies [Hz], measured table amplitude ``H_üG``
    [m/s²] and the normalised FRFs (S1 Eq.7) in the units of :data:`FRF_UNITS`.

    Parameters
    ----------
    result : SweepResult
        The sweep (:func:`rths.experiments.s1_shake_table.sweep.run_sweep`).
    """
    runs = []
    for run in result.runs:
        frf = run.frf
        runs.append(
            {
                "pga": run.pga,
                "model": run.model,
                "direction": run.direction,
                "frequency_hz": frf.frequency.tolist(),
                "a_G": frf.excitation.tolist(),
                "frf": {n: frf.normalised(n).tolist() for n in FRF_UNITS if n in frf.response},
            }
        )
    return {"units": dict(FRF_UNITS), "runs": runs}


def _resonances(run: SweepRun) -> dict[str, float | None]:
    first = resonance(run.frf, "u_I")
    out: dict[str, float | None] = {
        "peak_H_u_I": first.value,
        "peak_u_I": float(np.max(run.frf.response["u_I"])),
    }
    if run.model == "uncontrolled":
        out["f0"] = first.frequency
        return out
    out["f1"] = first.frequency
    second = second_resonance(run.frf, first.frequency, "a_I_tot")
    out["f2"] = None if second is None else second.frequency
    return out


def _has(result: SweepResult, model: str, direction: str, pga: float) -> bool:
    return any(r.model == model and r.direction == direction and r.pga == pga for r in result.runs)


def summarise(result: SweepResult) -> dict[str, Any]:
    """The report's numbers for ``result`` as a JSON-ready dict (module docstring; SI, PGA in g).

    Layout: ``{"scenario", "wall_time_s", "grid_hz", "pga": {"<pga>": {"resonances":
    {model: {direction: {...}}}, "ps_peak_change": {model: {direction: x}},
    "nrmse_ideal_vs_rack_pinion": {direction: {channel: {"full": x, "near_f1": x}}},
    "s1": {...}}}}`` with ``"s1"`` the :data:`S1_REPORTED` numbers at that PGA (empty if none).

    Parameters
    ----------
    result : SweepResult
        The sweep (:func:`rths.experiments.s1_shake_table.sweep.run_sweep`).
    """
    cfg = result.config
    per_pga: dict[str, Any] = {}
    for pga in result.pgas:
        entry: dict[str, Any] = {
            "resonances": {},
            "ps_peak_change": {},
            "nrmse_ideal_vs_rack_pinion": {},
            "s1": dict(S1_REPORTED.get(f"{pga:g}", {})),
        }
        for model in cfg.models:
            entry["resonances"][model] = {
                d: _resonances(result.get(model, d, pga)) for d in cfg.directions
            }
        if "uncontrolled" in cfg.models:
            for model in _TMDI_MODELS:
                if model not in cfg.models:
                    continue
                entry["ps_peak_change"][model] = {
                    d: resonance(result.get(model, d, pga).frf).value
                    / resonance(result.get("uncontrolled", d, pga).frf).value
                    - 1.0
                    for d in cfg.directions
                }
        for d in cfg.directions:
            if not (_has(result, "rack_pinion", d, pga) and _has(result, "ideal", d, pga)):
                break
            rack, ideal = result.get("rack_pinion", d, pga).frf, result.get("ideal", d, pga).frf
            f1 = resonance(rack).frequency
            band = ((1.0 - NEAR_F1) * f1, (1.0 + NEAR_F1) * f1)
            entry["nrmse_ideal_vs_rack_pinion"][d] = {
                ch: {
                    "full": frf_nrmse(rack, ideal, ch),
                    "near_f1": frf_nrmse(rack, ideal, ch, band),
                }
                for ch in rack.channels
            }
        per_pga[f"{pga:g}"] = entry
    return {
        "scenario": cfg.name,
        "wall_time_s": result.wall_time,
        "grid_hz": [float(f) for f in result.grid],
        "pga": per_pga,
    }


# --- figures ------------------------------------------------------------------------------------
def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


_STYLE: Final[dict[tuple[str, str], dict[str, Any]]] = {
    ("rack_pinion", "up"): {"color": "C0", "ls": "-"},
    ("rack_pinion", "down"): {"color": "C0", "ls": "--"},
    ("ideal", "up"): {"color": "C3", "ls": "-"},
    ("ideal", "down"): {"color": "C3", "ls": "--"},
    ("uncontrolled", "up"): {"color": "0.45", "ls": "-"},
    ("uncontrolled", "down"): {"color": "0.45", "ls": "--"},
}


def _plot_frf(ax: Any, frf: FRF, channel: str, model: str, direction: str) -> None:
    ax.plot(
        frf.frequency,
        frf.normalised(channel),
        lw=1.1,
        label=f"{_LABELS[model]}, {direction}",
        **_STYLE[(model, direction)],
    )


def frf_figure(result: SweepResult, pga: float) -> Any:
    """The 3x3 S1 Eq.7 FRFs of ``result`` at ``pga`` [g] (S1 Fig.17/18 layout); returns the
    matplotlib Figure.

    Parameters
    ----------
    result : SweepResult
        The sweep (:func:`rths.experiments.s1_shake_table.sweep.run_sweep`).
    pga : float
        PGA [g] of the runs shown; must equal a run's PGA exactly (one of ``result.pgas``),
        otherwise the panels are empty.
    """
    plt = _pyplot()
    fig, axes = plt.subplots(3, 3, figsize=(13, 10), sharex=True, constrained_layout=True)
    for ax, (channel, title) in zip(axes.flat, _PANELS):
        for run in result.runs:
            if run.pga == pga and channel in run.frf.response:
                _plot_frf(ax, run.frf, channel, run.model, run.direction)
        ax.set_title(title, fontsize=9)
        ax.grid(alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel("frequency [Hz]")
    axes[0, 0].legend(fontsize=7)
    fig.suptitle(f"{result.config.name}: normalised FRFs (S1 Eq.7), PGA = {pga:g} g")
    return fig


def _mark_s1(ax: Any, pga: float) -> None:
    """S1's uncontrolled-PS numbers at ``pga`` [g] on an ``Ĥ_uI`` panel (peak / PGA g, f0)."""
    reported = S1_REPORTED.get(f"{pga:g}", {})
    if "ps_peak_u_I" in reported:
        level = reported["ps_peak_u_I"] / (pga * STANDARD_GRAVITY)
        ax.axhline(
            level,
            color="k",
            ls=":",
            lw=0.9,
            label=f"S1 §3.1: peak {1e3 * reported['ps_peak_u_I']:g} mm",
        )
    if "f0" in reported:
        ax.axvline(
            reported["f0"],
            color="k",
            ls=":",
            lw=0.9,
            label=f"S1 Fig.12: f0 = {reported['f0']:g} Hz",
        )


def ps_displacement_figure(result: SweepResult) -> Any:
    """``Ĥ_uI`` of ``result``, up vs down, per PGA and model (S1 Fig.5); returns the Figure.

    Parameters
    ----------
    result : SweepResult
        The sweep (:func:`rths.experiments.s1_shake_table.sweep.run_sweep`).
    """
    plt = _pyplot()
    models = [m for m in result.config.models]
    pgas = result.pgas
    fig, axes = plt.subplots(
        len(models),
        len(pgas),
        figsize=(4 * len(pgas), 3 * len(models)),
        squeeze=False,
        constrained_layout=True,
    )
    for i, model in enumerate(models):
        for j, pga in enumerate(pgas):
            ax = axes[i, j]
            for d in result.config.directions:
                run = result.get(model, d, pga)
                _plot_frf(ax, run.frf, "u_I", model, d)
                peak = resonance(run.frf)
                ax.annotate(
                    f"{d}: {peak.frequency:.2f} Hz",
                    (peak.frequency, peak.value),
                    fontsize=7,
                    xytext=(8, -12 if d == "down" else -2),
                    textcoords="offset points",
                )
            if model == "uncontrolled":  # zoom on the single peak and its up/down fold
                _mark_s1(ax, pga)
                ax.set_xlim(result.grid[0], min(result.grid[-1], 4.0))
            ax.set_title(f"{_LABELS[model]}, PGA = {pga:g} g", fontsize=9)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7, loc="lower center" if model == "uncontrolled" else "best")
            ax.set_ylabel("$\\hat H_{u_I}$ [s²]")
    for ax in axes.flat:
        ax.set_xlabel("frequency [Hz]")
    return fig


_LOOPS: Final[tuple[tuple[str, str, str], ...]] = (
    ("u_I", "F_I", "primary isolator $F_I$-$u_I$"),
    ("u_TI", "F_T", "secondary isolator $F_T$-$u_{TI}$"),
    ("u_T", "F_B", "inerter $F_B$-$u_T$"),
    ("a_T", "F_B", "inerter $F_B$-$\\ddot u_T$"),
)


def loops_figure(result: SweepResult, pga: float, direction: str = "down") -> Any:
    """Last-cycle force-deformation loops at ``f1``, ``f0``, ``f2`` (S1 Fig.9/10/12).

    Parameters
    ----------
    result
        A sweep with at least one TMDI model (``f0`` needs the uncontrolled PS too).
    pga
        PGA [g] of the runs shown.
    direction
        Sweep direction of the runs shown (S1 Fig.8-10 use the down sweep).
    """
    plt = _pyplot()
    models = [m for m in _TMDI_MODELS if m in result.config.models]
    if not models:
        raise ParameterError("force-deformation loops need a TMDI model in the sweep")
    fig, axes = plt.subplots(
        len(models),
        len(_LOOPS),
        figsize=(15, 3.6 * len(models)),
        squeeze=False,
        constrained_layout=True,
    )
    for i, model in enumerate(models):
        run = result.get(model, direction, pga)
        res = _resonances(run)
        marks = {"f1": res["f1"], "f2": res["f2"]}
        if "uncontrolled" in result.config.models:
            marks["f0"] = _resonances(result.get("uncontrolled", direction, pga))["f0"]
        for name in ("f1", "f0", "f2"):
            mark = marks.get(name)
            if mark is None:
                continue
            freq, cycle = run.cycle_at(mark)
            for ax, (x, y, title) in zip(axes[i], _LOOPS):
                scale = 1e3 if x.startswith("u") else 1.0
                ax.plot(scale * cycle[x], cycle[y], lw=1.0, label=f"{name} = {freq:.2f} Hz")
                ax.set_title(f"{_LABELS[model]}: {title}", fontsize=9)
                ax.set_xlabel(f"{x} [{'mm' if scale > 1 else 'm/s²'}]")
                ax.set_ylabel(f"{y} [N]")
                ax.grid(alpha=0.3)
        axes[i, 0].legend(fontsize=7)
    fig.suptitle(f"last-cycle loops, PGA = {pga:g} g, {direction} sweep")
    return fig


def write_figures(result: SweepResult, out_dir: str | Path) -> list[Path]:
    """Write every figure of the module docstring for ``result`` into the directory ``out_dir``
    (created if needed); returns their paths.

    Parameters
    ----------
    result : SweepResult
        The sweep (:func:`rths.experiments.s1_shake_table.sweep.run_sweep`).
    out_dir : str or pathlib.Path
        Directory for the PNG files (created with its parents if needed; files of the same
        name are overwritten).
    """
    plt = _pyplot()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []

    def save(fig: Any, name: str) -> None:
        path = out / name
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)

    for pga in result.pgas:
        save(frf_figure(result, pga), f"frf_{pga:g}g.png")
        if any(m in result.config.models for m in _TMDI_MODELS):
            direction = "down" if "down" in result.config.directions else "up"
            save(loops_figure(result, pga, direction), f"loops_{pga:g}g.png")
    save(ps_displacement_figure(result), "ps_displacement.png")
    return paths
