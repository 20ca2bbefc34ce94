"""Rank the candidate effects, pick the verdict and measure how far it shrinks the gap.

For each channel ``J_0`` is the held-out mean squared residual of the re-calibrated nominal
(baseline) and ``N_0`` its noise floor; for each candidate ``J_c`` and ``N_c`` likewise (the floor
is per model: :func:`rths.diagnose.identify.noise_floor`).  The fraction of the reducible gap a
candidate closes is

.. math:: \\rho_c = \\frac{(J_0 - N_0) - (J_c - N_c)}{J_0 - N_0}

(0 when the channel's residual is not significant), its score ``rho_c - PENALTY * n_c`` with
``n_c`` effect parameters (the complexity penalty: a nested model must buy its extra parameter
with more than :data:`PENALTY` of the gap).  A candidate is eligible when its channel is
significant, its parameters are physical and ``rho_c >= MIN_CLOSED``; the verdict is the
eligible candidate with the best score, else ``none``.  The shrink is ``rho`` of the verdict and
the gap ``before``/``after`` the held-out NRMSE of the baseline and of the verdict.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from rths.core.errors import ParameterError, check_positive, format_choices
from rths.diagnose.channels import (
    DEFAULT_CUTOFF,
    Channel,
    actuator_channel,
    specimen_channel,
)
from rths.diagnose.data import Record
from rths.diagnose.effects import EFFECTS, baseline_for
from rths.diagnose.identify import Fit, fit_model, noise_floor
from rths.diagnose.nominal import NominalModel
from rths.diagnose.residuals import FLOOR_MARGIN, Decomposition, decompose
from rths.diagnose.structure import StructureGap, structure_gap

__all__ = [
    "DRIVES",
    "MIN_CLOSED",
    "PENALTY",
    "Candidate",
    "ChannelResult",
    "Diagnosis",
    "Options",
    "diagnose",
    "held_runs",
]

#: Complexity penalty per effect parameter [fraction of the reducible gap].
PENALTY: float = 0.05
#: Smallest fraction of the reducible gap an eligible candidate must close.
MIN_CLOSED: float = 0.5
#: Choices of :attr:`Options.drive`.
DRIVES: tuple[str, ...] = ("auto", "measured")


@dataclass(frozen=True)
class Options:
    """Diagnosis settings.

    Attributes
    ----------
    cutoff
        Specimen-channel smoother cutoff [Hz].
    effects
        Candidate effect names to try (default: all of :data:`rths.diagnose.effects.EFFECTS`).
    penalty, min_closed
        See the module docstring.
    seed
        Seed of the synthetic noise used for the per-model floors.
    drive
        Drive of the specimen channel: ``"auto"`` (the transfer model's replay of the command
        when it explains the measured displacement to its noise floor, else the measured
        displacement) or ``"measured"`` (always the measured displacement).
    """

    cutoff: float = DEFAULT_CUTOFF
    effects: tuple[str, ...] = tuple(EFFECTS)
    penalty: float = PENALTY
    min_closed: float = MIN_CLOSED
    seed: int = 0
    drive: str = "auto"

    def __post_init__(self) -> None:
        check_positive(self.cutoff, "specimen smoothing cutoff [Hz]")
        if self.drive not in DRIVES:
            raise ParameterError(
                f"drive must be one of {format_choices(DRIVES)}; got {self.drive!r}"
            )
        if not self.effects:
            raise ParameterError(
                f"effects: give at least one; choose among {format_choices(sorted(EFFECTS))}"
            )
        unknown = [e for e in self.effects if e not in EFFECTS]
        if unknown:
            raise ParameterError(
                f"unknown effect {unknown[0]!r}; choose among {format_choices(sorted(EFFECTS))}"
            )


@dataclass(frozen=True)
class ChannelResult:
    """One channel's decomposition with its nominal and baseline fits."""

    channel: Channel = field(repr=False)
    baseline: Fit = field(repr=False)
    nominal_nrmse: float
    baseline_nrmse: float
    floor_nrmse: float
    baseline_mse: float
    floor_mse: float
    decomposition: Decomposition

    @property
    def excess(self) -> float:
        """``J_0 - N_0`` (held-out)."""
        return self.baseline_mse - self.floor_mse


@dataclass(frozen=True)
class Candidate:
    """A candidate effect identified and scored on held-out data."""

    fit: Fit = field(repr=False)
    subsystem: str
    channel: str
    held_nrmse: float
    floor_nrmse: float
    closed: float
    score: float
    eligible: bool

    @property
    def name(self) -> str:
        """Effect name."""
        return self.fit.name

    def to_dict(self) -> dict[str, object]:
        """JSON form."""
        return {
            "name": self.name,
            "subsystem": self.subsystem,
            "channel": self.channel,
            "params": self.fit.params,
            "baseline": self.fit.baseline,
            "held_out_nrmse": self.held_nrmse,
            "floor_nrmse": self.floor_nrmse,
            "closed": self.closed,
            "score": self.score,
            "eligible": self.eligible,
        }


@dataclass(frozen=True)
class Diagnosis:
    """The answer: where the gap is, which effect explains it, how far it shrinks."""

    verdict: str
    subsystem: str
    band_hz: tuple[float, float]
    phase: str
    params: dict[str, float]
    gap_channel: str
    before: float
    after: float
    shrink: float
    candidates: list[Candidate]
    channels: dict[str, ChannelResult] = field(repr=False)
    identification: list[str] = field(default_factory=list)
    held_out: list[str] = field(default_factory=list)
    structure: StructureGap | None = None

    def to_dict(self) -> dict[str, object]:
        """The JSON document of design.md section 7 (plus details)."""
        channels = {
            name: {
                "subsystem": c.channel.subsystem,
                "nominal_nrmse": c.nominal_nrmse,
                "baseline_nrmse": c.baseline_nrmse,
                "floor_nrmse": c.floor_nrmse,
                "significant": c.decomposition.significant,
                "ratio": list(c.decomposition.ratio),
                "band_hz": list(c.decomposition.band_hz),
                "peak_hz": c.decomposition.peak_hz,
                "phase": c.decomposition.phase,
                "windows": [list(w) for w in c.decomposition.windows],
                "baseline": c.baseline.baseline,
                "noise_rms": dict(c.channel.noise),
                "drive": "replay" if c.channel.noise.get("drive", 1.0) == 0.0 else "measured",
            }
            for name, c in self.channels.items()
        }
        return {
            "verdict": self.verdict,
            "where": {
                "subsystem": self.subsystem,
                "band_hz": list(self.band_hz),
                "phase": self.phase,
            },
            "params": dict(self.params),
            "gap": {"channel": self.gap_channel, "before": self.before, "after": self.after},
            "shrink": self.shrink,
            "candidates": [c.to_dict() for c in self.candidates],
            "channels": channels,
            "files": {"identification": self.identification, "held_out": self.held_out},
            "structure": None if self.structure is None else self.structure.to_dict(),
        }


def held_runs(mask: np.ndarray) -> list[slice]:
    """Contiguous runs of a boolean mask as slices."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    return [slice(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def _held(channel: Channel, arrays: list[np.ndarray]) -> list[np.ndarray]:
    """The held-out samples of per-record arrays, one part per contiguous run."""
    return [
        a[run] for s, a in zip(channel.segments, arrays, strict=True) for run in held_runs(s.held)
    ]


def _nrmse(channel: Channel, mse: float) -> float:
    obs = np.concatenate(_held(channel, [s.observed for s in channel.segments]))
    return math.sqrt(max(mse, 0.0) / float(np.mean(obs**2)))


def _nominal_mse(channel: Channel, base: Fit) -> float:
    beta = base.model.prior(channel)  # the nominal values of the baseline's parameters
    sq, n = 0.0, 0
    for s in channel.segments:
        cols, fixed = base.model.columns(channel, s, base.theta)
        r = (s.observed - cols @ beta - fixed)[s.held]
        sq, n = sq + float(np.sum(r * r)), n + r.size
    return sq / max(n, 1)


def _channel_result(channel: Channel) -> ChannelResult:
    base = fit_model(baseline_for(channel.subsystem), channel)
    if channel.subsystem == "specimen":
        b = base.baseline
        linear = (b["inertance"], b["damping"], b["stiffness"])
        drive = [s.signals["x"] for s in channel.segments]
        f_max = 1.5 * float(channel.cutoff or 0.0)
    else:
        linear = None
        drive = [s.observed for s in channel.segments]
        f_max = 0.45 / channel.dt
    floor = channel.floor_psd(linear)
    floor_mse = channel.floor_variance(linear)
    times = [np.arange(s.observed.size) * s.dt for s in channel.segments]
    dec = decompose(
        _held(channel, base.residuals(channel)),
        _held(channel, [s.observed for s in channel.segments]),
        _held(channel, drive),
        _held(channel, times),
        channel.dt,
        floor,
        f_max,
    )
    return ChannelResult(
        channel,
        base,
        _nrmse(channel, _nominal_mse(channel, base)),
        _nrmse(channel, base.held_mse),
        _nrmse(channel, floor_mse),
        base.held_mse,
        floor_mse,
        dec,
    )


def _candidate(name: str, result: ChannelResult, options: Options) -> Candidate:
    model = EFFECTS[name]()
    channel = result.channel
    fit = fit_model(model, channel, result.baseline.baseline)
    floor = noise_floor(fit, channel, options.seed)
    significant = result.decomposition.significant and result.excess > 0.0
    closed = (result.excess - (fit.held_mse - floor)) / result.excess if significant else 0.0
    score = closed - options.penalty * model.n_effect
    eligible = significant and model.physical(channel, fit.params) and closed >= options.min_closed
    return Candidate(
        fit,
        model.subsystem,
        channel.name,
        _nrmse(channel, fit.held_mse),
        _nrmse(channel, floor),
        closed,
        score,
        eligible,
    )


def _replayed_drive(transfer: ChannelResult, candidates: list[Candidate]) -> list | None:
    """The transfer model's replay of the command, if it explains the measured displacement.

    The best actuator model (the best eligible actuator candidate, else the baseline) is used
    when its held-out residual lies within ``1 + FLOOR_MARGIN`` of its noise floor: it is then a
    noise-free estimate of the specimen's drive, and the specimen channel is spared the
    measured displacement's noise differentiated twice.  Otherwise None (measured drive).
    """
    eligible = [c for c in candidates if c.eligible]
    best = max(eligible, key=lambda c: c.score).fit if eligible else transfer.baseline
    floor = transfer.floor_mse
    if best.held_mse <= (1.0 + FLOOR_MARGIN) * floor:
        return list(best.prediction)
    return None


def diagnose(
    records: list[Record], nominal: NominalModel, options: Options | None = None
) -> Diagnosis:
    """Decompose, attribute and shrink the sim-to-real gap of ``records`` (design.md section 7).

    Parameters
    ----------
    records
        One or more records (the first half identify, the rest are held out; one record is
        split in time, :mod:`rths.diagnose.channels`).
    nominal
        What the simulation believes.
    options
        Settings (defaults: :class:`Options`).
    """
    options = options or Options()
    transfer = _channel_result(actuator_channel(records, nominal, options.cutoff))
    candidates = [
        _candidate(n, transfer, options)
        for n in options.effects
        if EFFECTS[n].subsystem == "actuator"
    ]
    drive = _replayed_drive(transfer, candidates) if options.drive == "auto" else None
    specimen = _channel_result(specimen_channel(records, nominal, options.cutoff, drive))
    candidates += [
        _candidate(n, specimen, options)
        for n in options.effects
        if EFFECTS[n].subsystem == "specimen"
    ]
    channels = {"measured": transfer, "force": specimen}
    candidates.sort(key=lambda c: (not c.eligible, -c.score))
    best = candidates[0] if candidates and candidates[0].eligible else None
    where: ChannelResult | None
    if best is not None:
        where = channels[best.channel]
    else:
        significant = [c for c in channels.values() if c.decomposition.significant]
        where = max(
            significant,
            key=lambda c: c.decomposition.ratio[0] / c.decomposition.ratio[1],
            default=None,
        )
    split = channels["measured"].channel.segments
    ident = [s.name for s in split if np.any(s.ident)]
    held = [s.name for s in split if np.any(s.held)]
    gap_channel = where or max(channels.values(), key=lambda c: c.excess / max(c.floor_mse, 1e-300))
    structure = structure_gap(records) if any(r.target is not None for r in records) else None
    return Diagnosis(
        verdict=best.name if best else "none",
        subsystem=where.channel.subsystem if where else "none",
        band_hz=where.decomposition.band_hz if where else (0.0, 0.0),
        phase=where.decomposition.phase if where else "none",
        params=dict(best.fit.params) if best else {},
        gap_channel=gap_channel.channel.name,
        before=gap_channel.baseline_nrmse,
        after=best.held_nrmse if best else gap_channel.baseline_nrmse,
        shrink=best.closed if best else 0.0,
        candidates=candidates,
        channels=channels,
        identification=ident,
        held_out=held,
        structure=structure,
    )
