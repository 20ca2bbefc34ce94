"""Human output of a diagnosis: a short terminal table and four figures (matplotlib, Agg).

Figures (``write_figures``):

``residual_time.png``
    Held-out residual of the re-calibrated nominal (and of the verdict) on the located channel,
    with the windows where its power concentrates shaded (:class:`Decomposition` ``windows``).
``residual_spectrum.png``
    Welch PSD of those residuals against the noise floor (+ modelling tolerance), the located
    band shaded.
``ranking.png``
    Fraction of the reducible gap each candidate closes on held-out data, and its score.
``overlay.png``
    Observed signal against the baseline and the verdict, and both residuals, over about six
    periods of the residual's peak frequency around the largest window: before/after.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from rths.diagnose.answer import Diagnosis, flat_params, nominal_mse
from rths.diagnose.search.calibrated import calibration_lag
from rths.diagnose.search.selection import ChannelResult, held_runs

__all__ = ["table", "write_figures"]

_UNITS = {
    "stiffness": "N/m",
    "gap": "m",
    "friction": "N",
    "delay": "s",
    "velocity_limit": "m/s",
    "frequency": "Hz",
}

#: How the text names a channel's evidence (:attr:`ChannelResult.evidence`).
_EVIDENCE: dict[str, str] = {
    "spectrum": "spectrum",
    "paired": "paired test",
    "lag bound": "lag at the calibration's bound",
    "coverage": "calibration on every record",
}


def _params(params: dict[str, float]) -> str:
    return ", ".join(f"{k}={v:.4g} {_UNITS.get(k, '')}".rstrip() for k, v in params.items())


def _pct(x: float) -> str:
    return f"{100.0 * x:.3g} %"


def table(d: Diagnosis) -> str:
    """The terminal summary: channels, ranked candidates, effects, verdict and shrink.

    Parameters
    ----------
    d
        The diagnosis.
    """
    lines = [
        f"identification: {', '.join(d.identification)}   held out: {', '.join(d.held_out)}"
        + ("   (time split)" if d.identification == d.held_out else ""),
        "",
        f"{'channel':12} {'subsystem':9} {'nominal':>9} {'baseline':>9} {'after':>9} "
        f"{'floor':>9}  {'significant':11} {'band [Hz]':>13}  {'phase':14} effects",
    ]
    for name, c in d.channels.items():
        dec = c.decomposition
        band = f"{dec.band_hz[0]:.3g}-{dec.band_hz[1]:.3g}" if dec.significant else "-"
        effects = " + ".join(c.effects) if c.effects else c.verdict
        if c.model_form:  # a significant gap within the baseline's model-form resolution
            effects += " (model form)"
        if c.evidence != "replay":
            effects += f" (by the {_EVIDENCE.get(c.evidence, c.evidence)})"
        lines.append(
            f"{name:12} {c.channel.subsystem:9} {_pct(c.nrmse(nominal_mse(c))):>9} "
            f"{_pct(c.nrmse(c.baseline.held_mse)):>9} {_pct(c.nrmse(c.final.held_mse)):>9} "
            f"{_pct(c.nrmse(c.floor_mse)):>9}  {'yes' if dec.significant else 'no':11} "
            f"{band:>13}  {dec.phase:14} {effects}"
        )
    lines += [
        "",
        f"{'candidate':36} {'channel':12} {'held-out':>9} {'closed':>8} {'gain':>6}  parameters",
    ]
    for cand, res in d.candidates:
        mark = "*" if cand.accepted else " "
        lines.append(
            f"{mark}{cand.name:35} {res.channel.name:12} {_pct(res.nrmse(cand.fit.held_mse)):>9} "
            f"{100 * cand.closed:7.1f}% {cand.gain:6.2f}  {_params(flat_params(cand.fit.params))}"
        )
    lines.append("")
    if d.verdict in ("none", "unexplained") and d.subsystem == "none":
        lines.append(f"verdict: {d.verdict}")
        form = [name for name, c in d.channels.items() if c.model_form]
        if d.verdict == "none" and form:
            lines.append(
                f"  significant gap left to the nominal's model form in: {', '.join(form)} "
                "(no candidate buys its parameters; see 'model_form' in the JSON)"
            )
    elif d.verdict == "unexplained":
        lines.append(
            f"verdict: unexplained gap in the {d.subsystem} ({d.gap_channel} channel, "
            f"{d.band_hz[0]:.3g}-{d.band_hz[1]:.3g} Hz, {d.phase})"
        )
    else:
        lines.append(
            f"verdict: {d.verdict} ({d.subsystem}, {d.band_hz[0]:.3g}-{d.band_hz[1]:.3g} Hz, "
            f"{d.phase}): {_params(d.params)}"
        )
    for e, ch, p in d.effects:
        lines.append(f"  effect {e:20} ({ch}): {_params(p)}")
    lines.append(
        f"gap ({d.gap_channel}, held out): {_pct(d.before)} -> {_pct(d.after)}, closes "
        f"{100 * d.shrink:.1f} % of the reducible gap"
    )
    if d.gap_channel in d.channels and d.channels[d.gap_channel].evidence == "spectrum":
        lines.append(
            "note: named by the held-out spectrum -- no replay follows this contact's impacts "
            "sample by sample, so the time-domain gap stays open"
        )
    for name, c in d.channels.items():
        if c.evidence == "coverage":
            lines.append(
                f"note: the {name} channel's held-out gap is calibration: the baseline "
                f"re-calibrated on every record's time blocks (cross-validated) reaches its "
                f"noise floor -- the identification records did not cover the held-out ones"
            )
        if c.evidence == "paired":
            lines.append(
                f"note: the {name} channel's baseline reached its noise floor or model-form "
                f"allowance by absorbing this delay (alignment at its one-sample bound); named "
                f"because it predicts the held-out blocks better than the root-by-root "
                f"calibration (paired test)"
            )
        if c.evidence == "lag bound":
            lines.append(
                f"note: the {name} channel's baseline took every calibration factor to within "
                f"a sample of its lag bound; the delay with the nominal's own poles predicts "
                f"the held-out records as well without them (the factors do not buy their "
                f"parameters against it)"
            )
    for name, c in d.channels.items():
        lag = calibration_lag(c.channel, c.baseline.baseline)
        if not c.effects and lag is not None and lag > c.channel.dt:
            lines.append(
                f"note: the {name} channel's re-calibration took on {1e3 * lag:.3g} ms of lag "
                f"(slower poles and the one-sample alignment): a delay of up to that cannot be "
                f"told from calibration on these records"
            )
    return "\n".join(lines)


def _held_part(c: ChannelResult, arrays: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Record time [s] and values of the first contiguous held-out part."""
    for s, a in zip(c.channel.segments, arrays, strict=True):
        runs = held_runs(s.held)
        if runs:
            return np.arange(a.size)[runs[0]] * s.dt, a[runs[0]]
    raise ValueError("no held-out samples")  # pragma: no cover - split guarantees some


def write_figures(d: Diagnosis, directory: str | os.PathLike[str]) -> list[Path]:
    """Write the four figures (module docstring) into ``directory``; return their paths.

    Parameters
    ----------
    d
        The diagnosis.
    directory
        Folder for the PNG files (created if missing).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from scipy import signal

    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    c = d.channels[d.gap_channel]
    unit = "m" if c.channel.name == "measured" else "N"
    verdict = c.final if c.effects and d.verdict != "unexplained" else None
    label = " + ".join(c.effects)
    t, r0 = _held_part(c, c.baseline.residuals(c.channel))
    r1 = _held_part(c, verdict.residuals(c.channel))[1] if verdict else None
    paths = []

    fig, ax = plt.subplots(figsize=(9, 3.5))
    ax.plot(t, r0, lw=0.6, label="re-calibrated nominal")
    if r1 is not None:
        ax.plot(t, r1, lw=0.6, label=f"+ {label}")
    for a, b in c.decomposition.windows:
        ax.axvspan(a, b, color="tab:red", alpha=0.15, lw=0)
    ax.set(
        xlabel="time [s]",
        ylabel=f"residual [{unit}]",
        title=f"{c.channel.name} channel, held out (shaded: where the gap concentrates)",
    )
    ax.legend(loc="upper right")
    paths.append(out / "residual_time.png")

    fig2, ax2 = plt.subplots(figsize=(7, 4))
    dec = c.decomposition
    ax2.loglog(dec.frequency[1:], dec.residual_psd[1:], lw=0.8, label="re-calibrated nominal")
    if r1 is not None:
        f, p = signal.welch(
            r1, fs=1.0 / c.channel.dt, nperseg=min(r1.size, dec.frequency.size * 2 - 2)
        )
        ax2.loglog(f[1:], p[1:], lw=0.8, label=f"+ {label}")
    ax2.loglog(dec.frequency[1:], dec.floor_psd[1:], "k--", lw=0.8, label="noise floor + tol.")
    if dec.significant:
        ax2.axvspan(*dec.band_hz, color="tab:red", alpha=0.15, lw=0)
    ax2.set(xlabel="frequency [Hz]", ylabel=f"PSD [{unit}$^2$/Hz]", title="residual spectrum")
    ax2.legend()
    paths.append(out / "residual_spectrum.png")

    fig3, ax3 = plt.subplots(figsize=(7, 3.5))
    names = [f"{k.name} ({r.channel.name})" for k, r in d.candidates]
    closed = [100.0 * k.closed for k, _ in d.candidates]
    colors = ["tab:green" if k.accepted else "tab:gray" for k, _ in d.candidates]
    ax3.barh(names[::-1], closed[::-1], color=colors[::-1])
    ax3.axvline(100.0 * 0.5, color="k", lw=0.6, ls=":")
    ax3.set(xlabel="held-out reducible gap closed [%]", title=f"verdict: {d.verdict}")
    paths.append(out / "ranking.png")

    fig4, (ax4, ax5) = plt.subplots(
        2, 1, figsize=(9, 5), sharex=True, gridspec_kw={"height_ratios": (2, 1)}
    )
    tt, obs = _held_part(c, [s.observed for s in c.channel.segments])
    center = np.mean(dec.windows[0]) if dec.windows else tt[tt.size // 2]
    half = float(np.clip(3.0 / max(dec.peak_hz, 0.5), 0.15, 1.0))  # ~6 periods of the peak
    sel = np.abs(tt - center) <= half
    before = _held_part(c, c.baseline.prediction)[1]
    ax4.plot(tt[sel], obs[sel], "k", lw=1.0, label="observed")
    ax4.plot(tt[sel], before[sel], lw=0.8, label="re-calibrated nominal")
    ax5.plot(tt[sel], (obs - before)[sel], lw=0.8)
    if verdict:
        after = _held_part(c, verdict.prediction)[1]
        ax4.plot(tt[sel], after[sel], "--", lw=0.8, label=f"+ {label}")
        ax5.plot(tt[sel], (obs - after)[sel], "--", lw=0.8)
    ax4.set(ylabel=f"{c.channel.name} [{unit}]", title="before / after")
    ax4.legend(loc="upper right")
    ax5.set(xlabel="time [s]", ylabel=f"residual [{unit}]")
    paths.append(out / "overlay.png")

    for figure, path in zip((fig, fig2, fig3, fig4), paths, strict=True):
        figure.tight_layout()
        figure.savefig(path, dpi=110)
        plt.close(figure)
    return paths
