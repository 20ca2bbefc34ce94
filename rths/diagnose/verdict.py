"""Diagnose records against a nominal model: per-channel effects, the verdict, the shrink.

Order of work:

1. the ``measured`` (actuator) channel: baseline and greedy effects
   (:func:`rths.diagnose.search.selection.select`);
2. the specimen channel's drive: the actuator model's replay of the command when it explains
   the measured displacement to its noise floor (a noise-free drive), else the measured
   displacement (``Options.drive``);
3. the ``force`` (specimen) channel: baseline and greedy effects, beside the force-driven
   ``displacement`` view where the nominal has an inertance and no friction and the force
   is live (:data:`MIN_VIEW_SAMPLES`) in both the identification and held-out records;
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

from dataclasses import dataclass

import numpy as np
from threadpoolctl import threadpool_limits

from rths.core.errors import ParameterError, check_positive, format_choices
from rths.diagnose.answer import Diagnosis, magnitude
from rths.diagnose.channels.build import (
    actuator_channel,
    displacement_channel,
    specimen_channel,
)
from rths.diagnose.channels.channel import DEFAULT_CUTOFF
from rths.diagnose.channels.signals import smoother
from rths.diagnose.data.nominal import NominalModel
from rths.diagnose.data.records import Record
from rths.diagnose.effects import EFFECTS
from rths.diagnose.residuals import FLOOR_MARGIN
from rths.diagnose.search.selection import ChannelResult, select
from rths.diagnose.structure import structure_gap

__all__ = [
    "DRIVES",
    "MIN_VIEW_SAMPLES",
    "REPLAY_CUTOFF",
    "Diagnosis",
    "Options",
    "diagnose",
    "gap_channels",
]

#: Choices of :attr:`Options.drive`.
DRIVES: tuple[str, ...] = ("auto", "measured")
#: Cutoff of the specimen smoother with a replayed (noise-free) drive, as a fraction of the
#: sampling rate (below the anti-alias band of a DAQ).
REPLAY_CUTOFF: float = 0.15
#: Least live samples per role (identification, held out) for the ``displacement`` view: a
#: spectrum of its residual needs one 64-sample segment (a specimen force buried in the
#: conditioner's noise leaves the held-out records none: the view is then left out).
MIN_VIEW_SAMPLES: int = 64


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
    if options.cutoff is not None:  # a bad cutoff is refused before any identification
        for dt in {r.dt for r in records}:
            smoother(options.cutoff, dt)
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
        by_force = displacement_channel(records, nominal, held)
        n_ident = sum(int(np.sum(s.ident)) for s in by_force.segments)
        n_held = sum(int(np.sum(s.held)) for s in by_force.segments)
        if min(n_ident, n_held) >= MIN_VIEW_SAMPLES:
            compliance = select(by_force, options.effects, options.seed)
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
    where = max(significant, key=lambda c: magnitude(c, channels), default=None)
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
        shrink=max(where.closed, 0.0),
        channels=channels,
        identification=ident,
        held_out=held_names,
        structure=structure,
        views=views,
    )
