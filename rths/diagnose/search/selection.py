"""Greedy selection of a channel's effects on held-out data.

For a channel, ``J_0`` is the held-out mean squared residual of the re-calibrated baseline and
``N_0`` its noise floor (a specimen channel's baseline holds the force's alignment to its drive
only when it buys itself: :func:`rths.diagnose.search.alignment.aligned_baseline`).  When the
baseline's held-out residual is not significant against the floor
(:func:`rths.diagnose.residuals.decompose`) the channel is at its noise floor: no effect.
Otherwise effects are added one at a time:

1. every candidate effect is identified jointly with the baseline (each of its model
   structures, the best on the identification data; one that frees a parameter NOMINAL.toml
   holds -- a damping a dissipation law may replace -- only when it buys it on held-out
   data);
2. the candidate that closes most of the remaining held-out gap ``J_S - N_S`` (and lowers the
   held-out residual ``J_S`` itself: a higher floor of its own is no closing; of those that
   close it to within :data:`NESTED_RESOLUTION`, the one with the lowest ``J_S``:
   :func:`rths.diagnose.search.pricing.strongest`) is added if it
   closes at least :data:`PRICE` per identified parameter (it "buys its parameters") of that
   gap, or of :data:`NESTED_RESOLUTION` of the channel's reducible gap when less remains
   (:func:`rths.diagnose.search.pricing.buys`), and its parameters are physical; a model
   whose residual lies far below its own noise floor is credited with the current set's
   floor instead, and no model's floor is credited higher above the current set's than the
   model lowers the held-out residual (:func:`rths.diagnose.search.floors.credited_floor`);
3. while the residual of the set is still significant, each remaining compatible candidate is
   identified *together* with the set (warm-started from the set's and its own single fit)
   and step 2 repeats.

Of two candidates one of which holds the other as a limit (:data:`rths.diagnose.effects.NESTS`:
a backlash with a closed clearance is a series spring) the general one is taken only when it
closes :data:`PRICE` per extra parameter of the gap the special one leaves; the special one is tried
after the general one and starts also from its fit (a series spring from a contact's fit whose
clearance closed: the two search spaces differ and either may find the element).  When a later
addition closes a chosen general effect's clearance (the backlash of the set has become a
series spring beside, say, amplitude-dependent damping: the contact had stood in for the
other effect), the set with the special effect in its place and the addition is tried too,
from that fit, priced by its net added parameters.

After the forward steps, an effect whose removal costs less than :data:`PRICE` per parameter
of the gap the rest leaves is dropped again (:func:`rths.diagnose.search.pruning.prune`).

Effects that only act together (friction behind a clearance: neither alone describes the
device) would stall step 2: when no single effect buys its parameters, every compatible pair
is identified and priced as one step (its parameters counted together).

The set's share of the channel's reducible gap is ``rho = (J_0 - J_S)/(J_0 - N_0)``.  When the
set is empty or closes less than :data:`MIN_CLOSED` of a significant gap, the channel's gap is
``unexplained`` -- except for the model-form allowance: when *no* candidate buys its
parameters and the reducible gap ``J_0 - N_0`` is at most the baseline model's resolution
``R`` (:meth:`rths.diagnose.effects.model.Model.resolution`; for the actuator the mean square a
one-sample shift of its motion leaves) -- or the effects chosen close less than
:data:`MIN_CLOSED` of such a gap -- the gap is the linear model's form (a servo-valve's
flow gain changing with load pressure beyond the first-order orifice term the baseline holds,
pole-by-pole calibration) and the channel's verdict is ``none`` (``model_form``).  The same
holds when no candidate buys its parameters and the channel's finer re-calibration of the
nominal's own parameters (:func:`rths.diagnose.effects.calibration_for`: the actuator's TF
calibrated root by root within the +/-10 % tolerance) closes at least :data:`MIN_CLOSED` of
the gap without taking on a sample of lag in all (poles slowed by more than that may hide a
delay): a nominal mis-calibrated differently at every pole, which the baseline's common
factors cannot follow.

A lightly damped contact rattles, and no replay -- the true model's included -- follows its
impacts sample by sample: when the force channel's gap stays ``unexplained``, the candidates
already identified are judged by the held-out spectrum instead
(:mod:`rths.diagnose.search.spectral`; ``evidence = "spectrum"``).

A significant specimen gap that the baseline re-calibrated on every record's time blocks
(cross-validated) closes to the floor is the identification records' coverage -- one tone
leaves the inertance against the stiffness undetermined -- not an effect: ``none``, before
any candidate is tried (:mod:`rths.diagnose.search.coverage`; ``evidence = "coverage"``).

A delay the common factors and the alignment absorbed to the noise floor -- or to within the
model-form allowance -- is judged against the root-by-root calibration by a paired test of
held-out predictions, which needs no floor
(:func:`rths.diagnose.search.calibrated.hidden_delay`; ``evidence = "paired"``).

The actuator's effects are also judged against the nominal calibrated root by root
(:mod:`rths.diagnose.search.calibrated`) when they close less than :data:`MIN_CLOSED` of
the gap, or when the common factors beside a delay or beside no effect took on more than
one sample of lag: a delay the common factors absorbed is named from that fit, and an effect
that buys nothing against it is calibration.

A channel left ``unexplained`` (or ``none`` by model form) whose baseline took every
calibration factor to within a sample of its lag bound names the delay identified with the
nominal's own poles when those factors do not buy their parameters against it, and a delay
named beside calibrated factors is reported with the nominal's poles unless the factors buy
themselves (:mod:`rths.diagnose.search.lag`; ``evidence = "lag bound"`` for the first).

Models of channels listed in :data:`CROSS_FIT` are scored by two-fold cross-validation over
time blocks of every record (:func:`rths.diagnose.search.crossval.cross_fit`).
"""

from __future__ import annotations

import functools

from rths.diagnose.channels.channel import Channel
from rths.diagnose.effects import (
    CHANNEL_EFFECTS,
    EFFECTS,
    NESTS,
    calibration_for,
    compatible,
    models_for,
)
from rths.diagnose.effects.model import Theta
from rths.diagnose.effects.specimen import clearance_resolved
from rths.diagnose.search.alignment import aligned_baseline
from rths.diagnose.search.calibrated import finer_calibration, hidden_delay, needs_finer
from rths.diagnose.search.coverage import covered
from rths.diagnose.search.crossval import cross_fit
from rths.diagnose.search.decomposed import decompose_fit
from rths.diagnose.search.floors import credited_floor, noise_floor
from rths.diagnose.search.identify import Fit, fit_model
from rths.diagnose.search.lag import delay_at_lag_bound, nominal_poles_preferred
from rths.diagnose.search.pricing import (
    NESTED_RESOLUTION,
    PRICE,
    best_structure,
    buys,
    held_out_gain,
    nested_preferred,
    strongest,
)
from rths.diagnose.search.pruning import prune, withdraw
from rths.diagnose.search.results import Candidate, ChannelResult, held_parts, held_runs
from rths.diagnose.search.spectral import SPECTRAL_CHANNELS, spectral_choice

__all__ = [
    "CROSS_FIT",
    "MIN_CLOSED",
    "NESTED_RESOLUTION",
    "PRICE",
    "Candidate",
    "ChannelResult",
    "held_parts",
    "held_runs",
    "select",
]

#: Smallest share of a significant reducible gap the selected effects must close together.
MIN_CLOSED: float = 0.5
#: Channels whose models are scored by two-fold cross-validation over time blocks (cheap
#: replays: the actuator's linear filter).
CROSS_FIT: tuple[str, ...] = ("measured",)


def _collapsed(channel: Channel, fit: Fit) -> tuple[str, ...]:
    """The general effects of ``fit`` (:data:`NESTS`) identified at their special case: a
    backlash whose clearance is below the displacement's resolution (a series spring)."""
    gap = fit.params.get("backlash", {}).get("gap")
    return ("backlash",) if gap is not None and not clearance_resolved(channel, gap) else ()


def select(
    channel: Channel,
    effects: tuple[str, ...],
    seed: int = 0,
    price: float = PRICE,
    hints: dict[str, Theta] | None = None,
) -> ChannelResult:
    """Identify the baseline and select the channel's effects (module docstring).

    Parameters
    ----------
    channel
        The channel.
    effects
        Candidate effect names of the channel's subsystem.
    seed
        Seed of the synthetic noise of the per-model floors.
    price
        :data:`PRICE`.
    hints
        Starting values of an effect's nonlinear parameters found another way (e.g. a series
        element's from the force-driven ``displacement`` channel), added to the global search
        of every model holding that effect.
    """
    fitter = cross_fit if channel.name in CROSS_FIT else fit_model
    base, n0 = aligned_baseline(channel, fitter, seed, price)

    @functools.cache
    def calibrated() -> Fit:
        """The root-by-root calibration alone (identified once per channel)."""
        check = calibration_for(channel.name)
        assert check is not None
        return fitter(check, channel, base.baseline)

    dec = decompose_fit(channel, base)
    excess0 = base.held_mse - n0
    candidates: list[Candidate] = []
    if not dec.significant or excess0 <= 0.0:
        hidden = hidden_delay(channel, fitter, base, effects, seed, price, calibrated)
        if hidden is None:
            return ChannelResult(channel, base, n0, dec, candidates, (), base, 0.0, "none")
        fit, floor, gain, _ = hidden  # a delay the calibration absorbed to the floor
        swap = nominal_poles_preferred(channel, fitter, base, fit, seed, price)
        if swap is not None:  # its poles at the nominal's (:mod:`...search.lag`)
            fit, floor = swap
        closed = (excess0 - (fit.held_mse - floor)) / excess0 if excess0 > 0.0 else gain
        candidates.append(Candidate(fit, floor, closed, gain, True, True))
        res = base.model.resolution(channel, base.prediction)
        args = (candidates, fit.effects, fit, closed, fit.effects[0], res, "paired")
        return ChannelResult(channel, base, n0, dec, *args)
    if covered(channel, base) is not None:
        # the identification records' coverage: calibrated on every record, no gap is left
        args = (candidates, (), base, 0.0, "none", 0.0, "coverage")
        return ChannelResult(channel, base, n0, dec, *args)
    names = [e for e in effects if e in CHANNEL_EFFECTS[channel.name]]
    # general effects first: a special case starts also from its general fit (NESTS)
    names.sort(key=lambda e: e not in NESTS)
    singles: dict[str, Fit] = {}
    current, current_floor = base, n0
    chosen: tuple[str, ...] = ()
    tried: set[tuple[str, ...]] = set()

    def trial(
        add: tuple[str, ...], drop: tuple[str, ...] = (), start: Theta | None = None
    ) -> tuple[float, Candidate] | None:
        """Identify ``chosen - drop + add`` jointly (warm-started, also from ``start``), score
        it, record the candidate; priced by the parameters it adds net of those it drops."""
        kept = tuple(e for e in chosen if e not in drop)
        starts = [dict(current.theta)] + ([{**current.theta, **start}] if start else [])
        for e in add:
            if hints and e in hints:
                starts.append({**current.theta, **hints[e]})
            for general, special in NESTS.items():
                if e == special and general in singles:  # its element, clearance dropped
                    starts.append({**current.theta, **singles[general].theta})
            if e in singles:
                starts.append({**singles[e].theta, **current.theta})
                starts.append({**current.theta, **singles[e].theta})
        models = [
            m
            for m in models_for(channel.name, (*kept, *add))
            if m.applicable(channel, base.baseline)
        ]
        if not models:
            return None
        tried.add(tuple(sorted((*kept, *add))))
        fits = [fitter(m, channel, base.baseline, starts) for m in models]
        fit = best_structure(fits, channel, current_floor, price)
        if not chosen and len(add) == 1:
            singles[add[0]] = fit
        floor = credited_floor(
            fit.held_mse, noise_floor(fit, channel, seed), (current.held_mse, current_floor)
        )
        remaining = max(current.held_mse - current_floor, 1e-300)
        gain = held_out_gain((current.held_mse, current_floor), (fit.held_mse, floor))
        closed = (excess0 - (fit.held_mse - floor)) / excess0
        ok = fit.model.physical(channel, fit.params)
        cand = Candidate(fit, floor, closed, gain, False, ok)
        candidates.append(cand)
        n_params = sum(EFFECTS[e].n_params for e in add) - sum(EFFECTS[e].n_params for e in drop)
        bought = buys(gain, remaining, excess0, max(n_params, 1), price)
        return (gain, cand) if ok and bought else None

    def step() -> list[tuple[float, Candidate]]:
        """Every compatible addition to ``chosen``; where an addition closes the clearance of
        a chosen general effect (the fit reached its special case: a backlash become a series
        spring), the set with the special one in its place and the addition, from that fit."""
        out = []
        for e in names:
            if e in chosen or not compatible((*chosen, e)):
                continue
            before = len(candidates)
            t = trial((e,))
            if t is not None:
                out.append(t)
                continue
            if len(candidates) == before:  # no model holds the set
                continue
            fit = candidates[-1].fit  # the trial's own fit
            for general in _collapsed(channel, fit):
                special = NESTS[general]
                swapped = tuple(x for x in chosen if x != general) + (special, e)
                if general in chosen and compatible(swapped):
                    if tuple(sorted(swapped)) not in tried:
                        t = trial((special, e), (general,), dict(fit.theta))
                        if t is not None:
                            out.append(t)
        return out

    while True:
        trials = step()
        if not trials and not chosen:
            # effects that act only together (a friction device's clearance, say): when no
            # single effect buys its parameters, every compatible pair is tried as one step
            pairs = [
                (a, b)
                for i, a in enumerate(names)
                for b in names[i + 1 :]
                if compatible((a, b)) and tuple(sorted((a, b))) not in tried
            ]
            trials = [t for pair in pairs for t in [trial(pair)] if t is not None]
        if not trials:
            break
        gain, cand = strongest(nested_preferred(trials, price))
        candidates[candidates.index(cand)] = Candidate(
            cand.fit, cand.floor, cand.closed, cand.gain, True, True
        )
        current, current_floor = cand.fit, cand.floor
        chosen = cand.fit.effects
        if not decompose_fit(channel, current, current_floor / max(n0, 1e-300)).significant:
            break
    current, current_floor, chosen = prune(
        channel,
        fitter,
        base,
        (current, current_floor),
        chosen,
        candidates,
        excess0,
        n0,
        seed,
        price,
    )
    closed = (excess0 - (current.held_mse - current_floor)) / excess0
    verdict = chosen[0] if chosen and closed >= MIN_CLOSED else "unexplained"
    resolution = base.model.resolution(channel, base.prediction)
    evidence = "replay"
    finer, lagged = None, False
    if needs_finer(channel, current, chosen, closed, MIN_CLOSED):
        finer = finer_calibration(
            channel,
            fitter,
            (base, current),
            (excess0, n0),
            effects,
            seed,
            price,
            MIN_CLOSED,
            calibrated,
        )
    if finer is not None:  # the nominal's own parameters, calibrated root by root
        refit, model_form, closes = finer
        lagged = refit is None and closes and not model_form and chosen == ("actuator_delay",)
        if refit is not None or (chosen and model_form) or lagged:  # the common set is replaced
            withdraw(candidates)
        if refit is not None:  # the effects hold on the finer calibration: named
            fit, floor, share, gain = refit
            candidates.append(Candidate(fit, floor, share, gain, True, True))
            current, current_floor, closed = fit, floor, share
            chosen = fit.effects
            verdict = chosen[0]
        elif (chosen and model_form) or lagged:
            # the finer calibration alone closes it: no effect -- or it closes it with a
            # sample of lag or more and the delay tested against it buys nothing, and the
            # paired test decides (below)
            chosen, current, current_floor, closed = (), base, n0, 0.0
            verdict = "none"
        elif not chosen and (excess0 <= resolution or model_form):
            verdict = "none"  # the model-form allowance (module docstring)
    elif not chosen and excess0 <= resolution:
        verdict = "none"  # the model-form allowance (module docstring)
    elif not chosen and verdict == "unexplained":
        check = calibration_for(channel.name)
        if check is not None:  # the nominal's own parameters, calibrated root by root
            cal = calibrated()
            closes = excess0 - (cal.held_mse - n0) >= MIN_CLOSED * excess0
            if closes and not check.lagging(channel, cal.theta):
                verdict = "none"
    if verdict == "unexplained" and excess0 <= resolution:
        # the model-form allowance (module docstring) also when the effects chosen close less
        # than MIN_CLOSED of a gap within the baseline's resolution: they explain none of it
        withdraw(candidates)
        chosen, current, current_floor, closed = (), base, n0, 0.0
        verdict = "none"
    if verdict == "none" and not chosen and dec.significant:
        # a significant gap put down to model form (or to the lagging finer calibration): a
        # delay the calibration absorbed is judged by the paired test, as at the floor
        hidden = hidden_delay(
            channel,
            fitter,
            base,
            effects,
            seed,
            price,
            calibrated,
            not lagged,
            excess0 if lagged else None,
        )
        if hidden is not None:
            fit, floor, gain, _ = hidden
            withdraw(candidates)
            closed = (excess0 - (fit.held_mse - floor)) / excess0
            candidates.append(Candidate(fit, floor, closed, gain, True, True))
            chosen, current, current_floor = fit.effects, fit, floor
            verdict, evidence = fit.effects[0], "paired"
    if not chosen and dec.significant and verdict in ("unexplained", "none"):
        bound = delay_at_lag_bound(channel, fitter, base, effects, seed, price)
        if bound is not None:  # the calibration took every factor to its lag bound
            fit, floor = bound
            withdraw(candidates)
            closed = (excess0 - (fit.held_mse - floor)) / excess0
            candidates.append(Candidate(fit, floor, closed, closed, True, True))
            chosen, current, current_floor = fit.effects, fit, floor
            verdict, evidence = fit.effects[0], "lag bound"
    elif "actuator_delay" in chosen:
        swap = nominal_poles_preferred(channel, fitter, base, current, seed, price)
        if swap is not None:  # the delay with the nominal's own poles
            fit, floor = swap
            withdraw(candidates)
            closed = (excess0 - (fit.held_mse - floor)) / excess0
            candidates.append(Candidate(fit, floor, closed, closed, True, True))
            current, current_floor = fit, floor
    if verdict == "unexplained" and channel.name in SPECTRAL_CHANNELS:
        pick = spectral_choice(channel, base, candidates, price, MIN_CLOSED)
        if pick is not None:  # a contact no replay follows: named by its spectrum
            cand, chosen, _ = pick
            withdraw(candidates)
            i = next(j for j, c in enumerate(candidates) if c.fit is cand.fit)
            candidates[i] = Candidate(cand.fit, cand.floor, cand.closed, cand.gain, True, True)
            current, current_floor, closed = cand.fit, cand.floor, max(cand.closed, 0.0)
            verdict, evidence = chosen[0], "spectrum"
    candidates.sort(key=lambda c: (not c.accepted, -c.closed))
    return ChannelResult(
        channel, base, n0, dec, candidates, chosen, current, closed, verdict, resolution, evidence
    )
