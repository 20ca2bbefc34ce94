"""``rths report``: metrics and the seed paper's figures from an MCAP log.

Written to the output directory:

``metrics.json``        tracking metrics (rths.metrics.summarize), timing and recording counts,
                        and the RTHS-vs-mock comparison of the structure's response;
``time_history.png``    target, command and measured displacement (S0 Fig.32);
``sync_subspace.png``   measured vs. target with the perfect-tracking line (S0 Fig.33);
``rths_vs_mock.png``    damper hysteresis and cable displacement, RTHS vs. fully numerical mock
                        runs with the ``[model]`` device and its simplified version (S0 Fig.34).

The mock runs are rebuilt from the scenario text stored in the log's metadata, so a log alone is
enough.  The steady-state window for the figures is the last ``--cycles`` cycles of the load.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from rths.core.errors import ConfigError, DataError, RTHSWarning
from rths.log.reader import read_loop, read_metadata
from rths.metrics import normalised_rms_error, summarize

__all__ = ["write_report"]


def _window(t: np.ndarray, period: float, cycles: float) -> np.ndarray:
    """Boolean mask of the last ``cycles`` periods of ``t``."""
    return t >= t[-1] - cycles * period


def _scenario(meta: dict[str, dict[str, str]], log: Path) -> Any:
    """The scenario stored in the log, or None (with a warning when it no longer parses)."""
    from rths.config.scenario import parse_scenario

    text = meta.get("scenario", {}).get("text")
    if not text:
        return None
    try:
        return parse_scenario(text, meta["scenario"].get("path", "<log>"))
    except ConfigError as exc:
        warnings.warn(
            RTHSWarning(
                f"the scenario stored in '{log}' cannot be rebuilt ({exc}): no window from its "
                "load period and no RTHS-vs-mock figure"
            ),
            stacklevel=2,
        )
        return None


def _load_period(scn: Any) -> float:
    if scn is None:
        return 1.0
    # a substructure kind's options may say which period its excitation has
    period = getattr(scn.substructure.options, "excitation_period", None)
    return 1.0 if period is None else float(period)


def write_report(log: Path, out: Path, cycles: float = 3.0, mock: bool = True) -> dict[str, Any]:
    """Write the report files for ``log`` into ``out``; return the metrics document."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    loop = read_loop(log)
    meta = read_metadata(log)
    scn = _scenario(meta, log)
    names = ("t", "target", "command", "measured", "force")
    t, target, command, measured, force = (loop[k] for k in names)
    if t.size < 16:
        raise DataError(f"'{log}': only {t.size} loop samples; nothing to report")
    dt = float(np.median(np.diff(t)))
    doc: dict[str, Any] = {"log": str(log), "samples": int(t.size), "dt": dt}
    try:
        tracking = summarize(target, measured, force, dt, max_delay=min(0.1, 0.25 * t.size * dt))
    except DataError as exc:
        raise DataError(f"'{log}': {exc}") from None
    doc["tracking"] = tracking.to_dict()
    out.mkdir(parents=True, exist_ok=True)
    doc["summary"] = meta.get("rths.summary", {})
    doc["recording"] = meta.get("rths.recording", {})
    doc["scaling"] = meta.get("scaling", {})
    period = _load_period(scn)
    w = _window(t, period, cycles)

    # S0 Fig.32 ------------------------------------------------------------------------------
    fig, ax = plt.subplots(figsize=(8, 3.6))
    ax.plot(t[w], 1e3 * target[w], label="target", lw=1.6)
    ax.plot(t[w], 1e3 * command[w], label="command", lw=1.0)
    ax.plot(t[w], 1e3 * measured[w], "--", label="measured", lw=1.0)
    ax.set(
        xlabel="time [s]",
        ylabel="displacement [mm]",
        title="Target, command and measured displacement (cf. S0 Fig.32)",
    )
    ax.legend(loc="upper right")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "time_history.png", dpi=130)
    plt.close(fig)

    # S0 Fig.33 ------------------------------------------------------------------------------
    rmse = doc["tracking"]["sync_rmse"]
    fig, ax = plt.subplots(figsize=(4.6, 4.6))
    lim = 1.05e3 * float(np.max(np.abs(target)))
    ax.plot(1e3 * target, 1e3 * measured, ".", ms=1.0, alpha=0.5, label="test data")
    ax.plot([-lim, lim], [-lim, lim], "k--", lw=1.0, label="perfect tracking")
    ax.set(
        xlim=(-lim, lim),
        ylim=(-lim, lim),
        xlabel="target [mm]",
        ylabel="measured [mm]",
        title=f"Synchronisation subspace (S0 Fig.33)\nRMSE {100 * rmse:.3f} %",
    )
    ax.set_aspect("equal")
    ax.legend(loc="upper left")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "sync_subspace.png", dpi=130)
    plt.close(fig)

    # S0 Fig.34 ------------------------------------------------------------------------------
    if mock and scn is not None:
        doc["mock"] = _mock_figure(plt, scn, loop, w, out)
    (out / "metrics.json").write_text(json.dumps(doc, indent=2, default=float))
    return doc


def _mock_figure(plt: Any, scn: Any, loop: dict[str, np.ndarray], w: np.ndarray, out: Path) -> dict:
    from rths.session.mock import numerical_run, variants

    n = loop["t"].size
    runs = {v: numerical_run(scn, v, steps=n) for v in variants(scn)}
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2))
    ax1.plot(1e3 * loop["measured"][w], loop["force"][w], lw=1.4, label="RTHS (measured)")
    labels = {
        "model": "mock: [model] device",
        "simplified": "mock: simplified (S0 Eq.1)",
        "monolithic": "monolithic S1 model, [specimen] inside",
    }
    for v, r in runs.items():
        ax1.plot(1e3 * r["target"][w], r["force"][w], "--", lw=1.0, label=labels[v])
    ax1.set(
        xlabel="damper displacement [mm]",
        ylabel="damper force [N]",
        title="Damper hysteresis (specimen scale)",
    )
    ax1.legend(fontsize=8)
    ax1.grid(alpha=0.3)
    comparison: dict[str, Any] = {}
    name, what = (
        ("u_I", "primary structure displacement")
        if "sub_u_I" in loop
        else ("midspan_displacement", "midspan displacement")
    )
    key = "sub_" + name
    if key in loop:
        rths_mid = loop[key]
        ax2.plot(loop["t"][w], 1e3 * rths_mid[w], lw=1.4, label="RTHS")
        for v, r in runs.items():
            ax2.plot(r["t"][w], 1e3 * r[name][w], "--", lw=1.0, label=labels[v])
            comparison[v] = {
                "response_nrmse": normalised_rms_error(r[name][w], rths_mid[w]),
                "peak_force_ratio": float(
                    np.max(np.abs(loop["force"][w])) / np.max(np.abs(r["force"][w]))
                ),
            }
        ax2.set(
            xlabel="time [s]", ylabel=f"{what} [mm]", title="Structure response (prototype scale)"
        )
        ax2.legend(fontsize=8)
        ax2.grid(alpha=0.3)
    fig.suptitle("RTHS vs. fully numerical mock runs (cf. S0 Fig.34)")
    fig.tight_layout()
    fig.savefig(out / "rths_vs_mock.png", dpi=130)
    plt.close(fig)
    return comparison
