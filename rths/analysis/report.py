"""``rths report``: metrics and the seed paper's figures from an MCAP log.

Written to the output directory:

``metrics.json``        tracking metrics (rths.metrics.summarize), timing and recording counts,
                        and the RTHS-vs-mock comparison of the structure's response;
``time_history.png``    target, command and measured displacement (S0 Fig.32);
``sync_subspace.png``   measured vs. target with the perfect-tracking line (S0 Fig.33);
``rths_vs_mock.png``    damper hysteresis and cable displacement, RTHS vs. fully numerical mock
                        runs with the ``[model]`` device and its simplified version (S0 Fig.34);
``benchmark_floors.png`` on the vRTHS benchmark frame instead of the mock: the floors of the RTHS
                        against the unpartitioned reference frame, and ``metrics.json`` gets
                        ``benchmark``: F4's J1-J9 and the peak hydraulic force against its
                        8.9 kN capacity (:func:`benchmark_section`).

The mock runs are rebuilt from the scenario text stored in the log's metadata, so a log alone is
enough.  The steady-state window for the figures is the last ``--cycles`` cycles of the load.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from rths.config import build
from rths.config.kinds import registry
from rths.core.errors import ConfigError, DataError, RTHSWarning
from rths.log.reader import read_loop, read_metadata, read_topic
from rths.metrics import normalised_rms_error, summarize
from rths.metrics.vrths import ACTUATOR_CAPACITY
from rths.session.outcome import benchmark_scores

__all__ = ["benchmark_section", "write_report"]


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
    """Write the report files for ``log`` into ``out``; return the metrics document.

    Parameters
    ----------
    log
        MCAP log written by ``rths run`` (at least 16 ``rths/loop`` samples).
    out
        Output directory, created if missing; existing report files in it are overwritten.
    cycles
        Number of load periods [-] at the end of the record shown in the time-history figure
        (S0 Fig.32) and the mock comparison (S0 Fig.34); the period is the substructure's
        ``excitation_period`` [s] if it has one, else 1 s.
    mock
        Re-run the fully numerical mock variants and draw S0 Fig.34 (``rths_vs_mock.png``);
        ignored for a vRTHS benchmark-frame log, which is compared with its reference frame.

    Returns
    -------
    dict
        The ``metrics.json`` document (also written to ``out``).

    Raises
    ------
    DataError
        If the log is unreadable, breaks the log contract or has fewer than 16 samples.
    """
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

    # vRTHS benchmark: F4's J1-J9 against the reference frame; else S0 Fig.34 -----------------
    reference = None if scn is None else _reference(scn)
    if reference is not None:
        doc["benchmark"] = benchmark_section(plt, log, loop, reference, dt, out)
    elif mock and scn is not None:
        doc["mock"] = _mock_figure(plt, scn, loop, w, out)
    (out / "metrics.json").write_text(json.dumps(doc, indent=2, default=float))
    return doc


def _reference(scn: Any) -> Any:
    """The substructure's ``reference_response`` (the vRTHS frame has one), or None."""
    target = registry("substructure").get(scn.substructure.kind).target
    if not hasattr(target, "reference_response"):
        return None
    return getattr(build.substructure(scn), "reference_response")


def benchmark_section(
    plt: Any, log: Path, loop: dict[str, np.ndarray], reference: Any, dt: float, out: Path
) -> dict[str, Any]:
    """F4's J1-J9 of a vRTHS benchmark log, the peak hydraulic force and the floors figure.

    Parameters
    ----------
    plt
        ``matplotlib.pyplot`` (already set to a non-interactive backend).
    log
        The MCAP log (named in errors; its ``rths/specimen`` topic gives the hydraulic force).
    loop
        Its ``rths/loop`` topic (:func:`~rths.log.reader.read_loop`): ``t`` [s], ``measured``
        [m] and the floors ``sub_x1`` .. ``sub_x3`` [m].
    reference
        The substructure's ``reference_response(n)``: floor displacements [m] of the
        unpartitioned frame at ``t_k = k dt``, shape ``(n, 3)``.
    dt
        Loop step [s].
    out
        Directory where ``benchmark_floors.png`` is written.

    Returns
    -------
    dict
        J1-J9 (:class:`~rths.metrics.vrths.BenchmarkScores`), and when the log has the
        hydraulic force: ``peak_actuator_force`` [N], ``capacity`` [N] (8.9 kN) and
        ``capacity_exceeded``.

    Raises
    ------
    DataError
        If ``loop`` lacks a floor field (not a benchmark-frame log).
    """
    for key in ("sub_x1", "sub_x2", "sub_x3"):
        if key not in loop:
            raise DataError(f"'{log}': rths/loop has no field {key!r}; not a benchmark-frame log")
    floors = np.column_stack([loop["sub_x1"], loop["sub_x2"], loop["sub_x3"]])
    scores = benchmark_scores(reference, loop["measured"], floors, dt)
    section: dict[str, Any] = scores.to_dict()
    specimen = read_topic(log, "rths/specimen")
    force = specimen.get("actuator.hydraulic_force")
    if force is not None and force.size:
        peak = float(np.max(np.abs(force)))
        section |= {"peak_actuator_force": peak, "capacity": ACTUATOR_CAPACITY,
                    "capacity_exceeded": peak >= ACTUATOR_CAPACITY}  # fmt: skip
    ref = reference(floors.shape[0] + 1)[1:]
    t = loop["t"]
    fig, axes = plt.subplots(3, 1, figsize=(8, 6.4), sharex=True)
    for i, ax in enumerate(axes[::-1]):
        ax.plot(t, 1e3 * ref[:, i], lw=1.4, label="reference model")
        ax.plot(t, 1e3 * floors[:, i], ":", lw=1.2, label="RTHS")
        ax.set_ylabel(f"x{i + 1} [mm]")
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("time [s]")
    fig.suptitle("vRTHS benchmark: floors of the RTHS vs the reference frame (cf. F3)")
    fig.tight_layout()
    fig.savefig(out / "benchmark_floors.png", dpi=130)
    plt.close(fig)
    return section


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
