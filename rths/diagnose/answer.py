"""The diagnosis's answer (:class:`Diagnosis`) and its JSON document (design.md section 7).

:func:`rths.diagnose.verdict.diagnose` builds the answer from the channels' results
(:class:`rths.diagnose.search.selection.ChannelResult`); this module holds what it is made of
and how it is written out: the verdict and where it lies, the effects of the counted views
(the largest gap's channel first), every candidate tried and every channel's figures.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rths.diagnose.effects import EFFECTS
from rths.diagnose.search.calibrated import calibration_lag
from rths.diagnose.search.identify import Fit
from rths.diagnose.search.selection import Candidate, ChannelResult
from rths.diagnose.structure import StructureGap

__all__ = ["Diagnosis", "flat_params", "magnitude", "nominal_mse"]


def flat_params(params: dict[str, dict[str, float]]) -> dict[str, float]:
    """Every effect's parameters in one mapping (parameter names are unique across effects).

    Parameters
    ----------
    params
        Parameters by effect (SI).
    """
    out: dict[str, float] = {}
    for p in params.values():
        out.update(p)
    return out


def _candidate_dict(c: Candidate, result: ChannelResult) -> dict[str, object]:
    return {
        "name": c.name,
        "effects": {k: dict(v) for k, v in c.fit.params.items()},
        "subsystem": result.channel.subsystem,
        "channel": result.channel.name,
        "structure": c.fit.model.structure,
        "params": flat_params(c.fit.params),
        "baseline": c.fit.baseline,
        "held_out_nrmse": result.nrmse(c.fit.held_mse),
        "floor_nrmse": result.nrmse(c.floor),
        "closed": c.closed,
        "gain": c.gain,
        "score": c.gain,
        "eligible": c.accepted,
        "physical": c.physical,
    }


def nominal_mse(result: ChannelResult) -> float:
    """Held-out mean squared residual of the nominal model as written (offsets calibrated).

    Parameters
    ----------
    result
        A channel's result.
    """
    base = result.baseline
    model, channel = base.model, result.channel
    theta = {p.name: (p.start if p.start is not None else 0.0) for p in model.space(channel)}
    theta = {k: (1.0 if k.endswith("_scale") else v) for k, v in theta.items()}
    theta["shift"] = 0.0
    beta = model.prior(channel)
    sq, n = 0.0, 0
    for s in channel.segments:
        if not np.any(s.held):
            continue
        try:
            x, f = model.columns(channel, s, theta)
        except KeyError:
            x, f = model.columns(channel, s, base.theta)
        r = (s.observed - x @ beta - f)[s.held]
        r = r - np.mean(r)
        sq, n = sq + float(np.sum(r * r)), n + r.size
    return sq / max(n, 1)


def _channel_dict(result: ChannelResult) -> dict[str, object]:
    c, dec = result, result.decomposition
    return {
        "subsystem": c.channel.subsystem,
        "verdict": c.verdict,
        "effects": [{"name": e, "params": dict(c.final.params.get(e, {}))} for e in c.effects],
        "closed": c.closed,
        "evidence": c.evidence,
        "nominal_nrmse": c.nrmse(nominal_mse(c)),
        "baseline_nrmse": c.nrmse(c.baseline.held_mse),
        "after_nrmse": c.nrmse(c.final.held_mse),
        "floor_nrmse": c.nrmse(c.floor_mse),
        "resolution_nrmse": c.nrmse(c.resolution_mse),
        "model_form": c.model_form,
        "significant": dec.significant,
        "ratio": list(dec.ratio),
        "band_hz": list(dec.band_hz),
        "peak_hz": dec.peak_hz,
        "phase": dec.phase,
        "windows": [list(w) for w in dec.windows],
        "baseline": c.baseline.baseline,
        "calibration_lag_s": calibration_lag(c.channel, c.baseline.baseline),
        "noise_rms": dict(c.channel.noise),
        "drive": "replay" if c.channel.noise.get("drive", 1.0) == 0.0 else "measured",
        "cutoff_hz": c.channel.cutoff,
    }


@dataclass(frozen=True)
class Diagnosis:
    """The answer: where the gap is, which effects explain it, how far they shrink it.

    Attributes
    ----------
    verdict
        The first effect of the channel with the largest reducible gap, ``none`` or
        ``unexplained``.
    subsystem
        ``actuator`` or ``specimen``: where the verdict's gap lies.
    band_hz
        Frequency band [Hz] holding most of the residual.
    phase
        Phase of the cycle where it lies: ``reversals``, ``zero_crossings`` or ``broadband``.
    params
        Identified parameters of the verdict's effect (SI).
    gap_channel
        The channel of the verdict.
    before, after
        Held-out NRMSE [-] of that channel's baseline and of its final model.
    shrink
        Share of the reducible gap closed [-].
    channels
        Every channel's result by name.
    identification, held_out
        Names of the identification and held-out records.
    structure
        The structure channel of ``rths run`` logs, or None.
    views
        The channels that count for ``effects`` (the actuator's and the specimen's chosen view).
    """

    verdict: str
    subsystem: str
    band_hz: tuple[float, float]
    phase: str
    params: dict[str, float]
    gap_channel: str
    before: float
    after: float
    shrink: float
    channels: dict[str, ChannelResult] = field(repr=False)
    identification: list[str] = field(default_factory=list)
    held_out: list[str] = field(default_factory=list)
    structure: StructureGap | None = None
    views: tuple[str, ...] = ("measured", "force")

    @property
    def effects(self) -> list[tuple[str, str, dict[str, float]]]:
        """``(effect, channel, params)`` over the channels that count (the actuator's and the
        specimen's chosen view), the largest gap's channel first."""
        counted = [self.channels[v] for v in self.views]
        order = sorted(counted, key=lambda c: -magnitude(c, self.channels))
        return [
            (e, c.channel.name, dict(c.final.params.get(e, {})))
            for c in order
            if c.verdict != "unexplained"
            for e in c.effects
        ]

    @property
    def candidates(self) -> list[tuple[Candidate, ChannelResult]]:
        """Every model tried, accepted ones first, then by the share of the gap closed."""
        pairs = [(k, c) for c in self.channels.values() for k in c.candidates]
        return sorted(pairs, key=lambda p: (not p[0].accepted, -p[0].closed))

    def fit(self, channel: str) -> Fit:
        """The final model of a channel."""
        return self.channels[channel].final

    def to_dict(self) -> dict[str, object]:
        """The JSON document of design.md section 7 (plus details)."""
        return {
            "verdict": self.verdict,
            "where": {
                "subsystem": self.subsystem,
                "band_hz": list(self.band_hz),
                "phase": self.phase,
            },
            "params": dict(self.params),
            "effects": [
                {
                    "name": e,
                    "channel": ch,
                    "subsystem": EFFECTS[e].subsystem,
                    "params": p,
                }
                for e, ch, p in self.effects
            ],
            "gap": {"channel": self.gap_channel, "before": self.before, "after": self.after},
            "shrink": self.shrink,
            "evidence": (
                self.channels[self.gap_channel].evidence
                if self.verdict in EFFECTS and self.gap_channel in self.channels
                else None
            ),
            "candidates": [_candidate_dict(k, c) for k, c in self.candidates],
            "channels": {name: _channel_dict(c) for name, c in self.channels.items()},
            "files": {"identification": self.identification, "held_out": self.held_out},
            "specimen_channel": self.views[-1],
            "structure": None if self.structure is None else self.structure.to_dict(),
        }


def magnitude(result: ChannelResult, channels: dict[str, ChannelResult]) -> float:
    """A channel's reducible gap relative to its observation (the specimen's in force units
    whichever view explains it).

    Parameters
    ----------
    result
        The channel's result.
    channels
        Every channel's result by name.
    """
    if result.channel.subsystem == "specimen":
        return channels["force"].relative_gap
    return result.relative_gap
