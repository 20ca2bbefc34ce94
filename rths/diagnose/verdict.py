"""Diagnose records against a nominal model: per-channel effects, the verdict, the shrink.

Order of work:

1. the ``measured`` (actuator) channel: baseline and greedy effects
   (:func:`rths.diagnose.search.selection.select`);
2. the specimen channel's drive: the actuator model's replay of the command when it explains
   the measured displacement to its noise floor (a noise-free drive), else the measured
   displacement (``Options.drive``);
3. the ``force`` (specimen) channel: baseline and greedy effects;
4. the structure channel of ``rths run`` logs (:mod:`rths.diagnose.structure`).

The verdict is the first effect of the channel with the largest reducible gap (relative to its
observation's mean square); ``unexplained`` when that channel's effects close less than half of
its significant gap; ``none`` when no counted channel's baseline residual is significant
against its noise floor or beyond the model-form allowance of its baseline
(:mod:`rths.diagnose.search.selection`) and no other view holds a gap an effect closes
(:func:`gap_channels`).  The shrink is the selected set's share ``rho`` of
that channel's reducible gap and ``gap.before``/``gap.after`` the held-out NRMSE of the
baseline and of the set.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from threadpoolctl import threadpool_limits

from rths.core.errors import ParameterError, check_positive, format_choices
from rths.diagnose.channels.channel import (
    DEFAULT_CUTOFF,
    actuator_channel,
    displacement_channel,
    specimen_channel,
)
from rths.diagnose.data.nominal import NominalModel
from rths.diagnose.data.records import Record
from rths.diagnose.effects import EFFECTS
from rths.diagnose.residuals import FLOOR_MARGIN
from rths.diagnose.search.identify import Fit
from rths.diagnose.search.selection import Candidate, ChannelResult, select
from rths.diagnose.structure import StructureGap, structure_gap

__all__ = ["DRIVES", "REPLAY_CUTOFF", "Diagnosis", "Options", "diagnose", "gap_channels"]

#: Choices of :attr:`Options.drive`.
DRIVES: tuple[str, ...] = ("auto", "measured")
#: Cutoff of the specimen smoother with a replayed (noise-free) drive, as a fraction of the
#: sampling rate (below the anti-alias band of a DAQ).
REPLAY_CUTOFF: float = 0.15


@dataclass(frozen=True)
class Options:
    """Diagnosis settings.

    Attributes
    ----------
    cutoff
        Specimen-channel smoother cutoff [Hz]; None: :data:`REPLAY_CUTOFF` of the sampling
        rate with a replayed drive, :data:`rths.diagnose.channels.channel.DEFAULT_CUTOFF` with
        the measured one.
    effects
        Candidate effect names to try (default: all of :data:`rths.diagnose.effects.EFFECTS`).
    seed
        Seed of the synthetic noise used for the per-model floors.
    drive
        ``"auto"`` (the actuator model's replay when it explains the measured displacement to
        its noise floor, else the measured displacement) or ``"measured"``.
    held_out
        Names of the records to hold out (the rest identify); None: the default split.
    """

    cutoff: float | None = None
    effects: tuple[str, ...] = tuple(EFFECTS)
    seed: int = 0
    drive: str = "measured"
    held_out: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        if self.cutoff is not None:
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


def _flat(params: dict[str, dict[str, float]]) -> dict[str, float]:
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
        "params": _flat(c.fit.params),
        "baseline": c.fit.baseline,
        "held_out_nrmse": result.nrmse(c.fit.held_mse),
        "floor_nrmse": result.nrmse(c.floor),
        "closed": c.closed,
        "gain": c.gain,
        "score": c.gain,
        "eligible": c.accepted,
        "physical": c.physical,
    }


def _nominal_mse(result: ChannelResult) -> float:
    """Held-out mean squared residual of the nominal model as written (offsets calibrated)."""
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
        "nominal_nrmse": c.nrmse(_nominal_mse(c)),
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
        order = sorted(counted, key=lambda c: -_magnitude(c, self.channels))
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
            "candidates": [_candidate_dict(k, c) for k, c in self.candidates],
            "channels": {name: _channel_dict(c) for name, c in self.channels.items()},
            "files": {"identification": self.identification, "held_out": self.held_out},
            "specimen_channel": self.views[-1],
            "structure": None if self.structure is None else self.structure.to_dict(),
        }


def _specimen_view(channels: dict[str, ChannelResult]) -> ChannelResult:
    """The specimen's result: the ``force`` channel, or the ``displacement`` channel (the
    specimen seen from the force) when its effects close a larger share of its gap."""
    force = channels["force"]
    other = channels.get("displacement")
    if other is None or not other.effects or other.verdict == "unexplained":
        return force
    if not force.effects or force.verdict == "unexplained" or other.closed > force.closed:
        return other
    return force


def _magnitude(result: ChannelResult, channels: dict[str, ChannelResult]) -> float:
    """A channel's reducible gap relative to its observation (the specimen's in force units
    whichever view explains it)."""
    if result.channel.subsystem == "specimen":
        return channels["force"].relative_gap
    return result.relative_gap


def gap_channels(channels: dict[str, ChannelResult], views: tuple[str, ...]) -> list[ChannelResult]:
    """The channels whose gap the verdict speaks for: the counted ``views`` (the actuator and
    the specimen's view) whose gap is significant, or holds effects, and is not the
    baseline's model form; when none is, the other views of the specimen whose gap an
    effect closes (e.g. the force-driven displacement of a series element that the rigid
    force channel absorbs into its calibration: no ``none``, by the contract).  A gap of such
    a view that no candidate closes even :data:`rths.diagnose.search.selection.PRICE` per
    parameter of is that view's own model form (a double integration of the force through
    the nominal body: a rod mass, a sensor's dynamics), not evidence of an effect the counted
    views do not show.

    Parameters
    ----------
    channels
        Every channel's result by name.
    views
        The names of the counted views.
    """
    counted = [
        channels[name]
        for name in views
        if (channels[name].decomposition.significant or channels[name].effects)
        and channels[name].verdict != "none"  # model form
    ]
    if counted:
        return counted
    return [c for name, c in channels.items() if name not in views and c.effects]


def element_hints(result: ChannelResult | None) -> dict[str, dict[str, float]]:
    """Starting values for the ``force`` channel's series chain from the force-driven
    ``displacement`` channel's single-element fits (linear in compliance and clearance: a
    global least-squares answer that no chaotic contact upsets): the element's frequency
    ``sqrt(k_e/m)/2 pi`` and damping ratio ``c_e/(2 sqrt(k_e m))`` on the identified
    inertance, and the clearance.

    Parameters
    ----------
    result
        The ``displacement`` channel's result (None: no hints).
    """
    hints: dict[str, dict[str, float]] = {}
    if result is None:
        return hints
    for cand in result.candidates:
        (name,) = cand.fit.effects if len(cand.fit.effects) == 1 else (None,)
        if name not in ("backlash", "internal_stiffness") or not cand.physical or name in hints:
            continue
        p = cand.fit.params[name]
        m = cand.fit.baseline.get("inertance", 0.0)
        k, c = p["stiffness"], p.get("contact_damping", p.get("series_damping", 0.0))
        if not (0.0 < m < np.inf and 0.0 < k < np.inf):
            continue
        w = float(np.sqrt(k / m))
        hint = {"frequency": w / (2.0 * np.pi), "zeta": max(c, 0.0) / (2.0 * w * m)}
        if name == "backlash":
            hint["gap"] = p["gap"]
        hints[name] = hint
    return hints


def _replayed_drive(result: ChannelResult) -> list | None:
    """The actuator model's replay of the command, if it explains the measured displacement
    to within ``1 + FLOOR_MARGIN`` of its noise floor (else None: the measured drive)."""
    if result.final.held_mse <= (1.0 + FLOOR_MARGIN) * result.floor_mse:
        return list(result.final.prediction)
    return None


def diagnose(
    records: list[Record], nominal: NominalModel, options: Options | None = None
) -> Diagnosis:
    """Decompose, attribute and shrink the sim-to-real gap of ``records`` (module docstring).

    Parameters
    ----------
    records
        One or more records (several: the first half identify unless ``options.held_out``
        names the held-out ones; one record is split in time).
    nominal
        What the simulation believes.
    options
        Settings (defaults: :class:`Options`).
    """
    options = options or Options()
    with threadpool_limits(1):  # one core: tiny matrices, BLAS threads only cost
        return _diagnose(records, nominal, options)


def _diagnose(records: list[Record], nominal: NominalModel, options: Options) -> Diagnosis:
    cutoff0 = options.cutoff or DEFAULT_CUTOFF
    held = options.held_out
    transfer = select(
        actuator_channel(records, nominal, cutoff0, held), options.effects, options.seed
    )
    drive = _replayed_drive(transfer) if options.drive == "auto" else None
    cutoff = options.cutoff or (
        REPLAY_CUTOFF / records[0].dt if drive is not None else DEFAULT_CUTOFF
    )
    compliance = None
    if nominal.specimen.inertance > 0.0 and nominal.specimen.friction == 0.0:
        compliance = select(
            displacement_channel(records, nominal, held), options.effects, options.seed
        )
    specimen = select(
        specimen_channel(records, nominal, cutoff, drive, held),
        options.effects,
        options.seed,
        hints=element_hints(compliance),
    )
    channels = {"measured": transfer, "force": specimen}
    if compliance is not None:
        channels["displacement"] = compliance
    view = _specimen_view(channels)
    views = ("measured", view.channel.name)
    significant = gap_channels(channels, views)
    where = max(significant, key=lambda c: _magnitude(c, channels), default=None)
    split = transfer.channel.segments
    ident = [s.name for s in split if np.any(s.ident)]
    held_names = [s.name for s in split if np.any(s.held)]
    structure = structure_gap(records) if any(r.target is not None for r in records) else None
    if where is None:
        gap = max(channels.values(), key=lambda c: c.excess / max(c.floor_mse, 1e-300))
        return Diagnosis(
            "none",
            "none",
            (0.0, 0.0),
            "none",
            {},
            gap.channel.name,
            gap.nrmse(gap.baseline.held_mse),
            gap.nrmse(gap.baseline.held_mse),
            0.0,
            channels,
            ident,
            held_names,
            structure,
            views,
        )
    verdict = where.verdict
    params = dict(where.final.params.get(verdict, {})) if verdict in EFFECTS else {}
    explained = verdict != "unexplained"
    return Diagnosis(
        verdict=verdict,
        subsystem=where.channel.subsystem,
        band_hz=where.decomposition.band_hz,
        phase=where.decomposition.phase,
        params=params,
        gap_channel=where.channel.name,
        before=where.nrmse(where.baseline.held_mse),
        after=where.nrmse(where.final.held_mse if explained else where.baseline.held_mse),
        shrink=max(where.closed, 0.0) if explained else max(where.closed, 0.0),
        channels=channels,
        identification=ident,
        held_out=held_names,
        structure=structure,
        views=views,
    )
