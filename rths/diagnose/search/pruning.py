"""Backward elimination after the greedy forward steps of
:func:`rths.diagnose.search.selection.select` (:func:`prune`), and the bookkeeping of a set
that was replaced (:func:`withdraw`)."""

from __future__ import annotations

from collections.abc import Callable

from rths.diagnose.channels.channel import Channel
from rths.diagnose.effects import EFFECTS, compatible, models_for
from rths.diagnose.search.decomposed import decompose_fit
from rths.diagnose.search.floors import noise_floor
from rths.diagnose.search.identify import Fit
from rths.diagnose.search.pricing import best_structure, buys
from rths.diagnose.search.results import Candidate

__all__ = ["prune", "withdraw"]


def withdraw(candidates: list[Candidate]) -> None:
    """Mark every accepted candidate as no longer accepted (its set was replaced).

    Parameters
    ----------
    candidates
        The channel's candidates, changed in place.
    """
    for i, c in enumerate(candidates):
        if c.accepted:
            candidates[i] = Candidate(c.fit, c.floor, c.closed, c.gain, False, True)


def prune(
    channel: Channel,
    fitter: Callable[..., Fit],
    base: Fit,
    state: tuple[Fit, float],
    chosen: tuple[str, ...],
    candidates: list[Candidate],
    excess0: float,
    n0: float,
    seed: int,
    price: float,
) -> tuple[Fit, float, tuple[str, ...]]:
    """Backward elimination after the forward steps: an effect of a set of two or more is
    dropped when the set without it, re-identified from the set's own parameters, leaves a
    gap the effect does not close :data:`PRICE` per parameter of.  A later step's joint
    search often refines an earlier effect's parameters (a contact law's exponent found only
    with a second effect in the search), and the second effect then took credit for that
    refinement, not for structure of its own.  An effect is also dropped when the set
    without it already reaches its noise floor (no significant residual): a gain measured
    against a remaining gap inside the floor's uncertainty is none.

    Parameters
    ----------
    channel, fitter
        The channel and its fitter (:func:`rths.diagnose.search.identify.fit_model` or the
        cross-validating one).
    base
        The re-calibrated baseline's fit.
    state
        ``(fit, floor)`` of the selected set.
    chosen
        Its effects.
    candidates
        Every candidate tried (an effect dropped marks its set's candidate withdrawn and adds
        the smaller set's), changed in place.
    excess0, n0
        The channel's reducible gap ``J_0 - N_0`` and the baseline's floor [unit^2].
    seed, price
        As for :func:`rths.diagnose.search.selection.select`.

    Returns
    -------
    tuple
        ``(fit, floor, effects)`` of the set that is kept.
    """
    current, current_floor = state
    while len(chosen) >= 2:
        dropped = False
        for e in chosen:
            rest = tuple(x for x in chosen if x != e)
            if not compatible(rest):
                continue
            models = [
                m for m in models_for(channel.name, rest) if m.applicable(channel, base.baseline)
            ]
            # the set's own structure without the effect (its contact law, where its friction
            # sits), when there is one: the question is the effect, not the structure
            same = [m for m in models if m.structure == current.model.structure]
            models = same or models
            if not models:
                continue
            fits = [fitter(m, channel, base.baseline, [dict(current.theta)]) for m in models]
            sub = best_structure(fits, channel, current_floor, price)
            if not sub.model.physical(channel, sub.params):
                continue
            floor = noise_floor(sub, channel, seed)
            left = max(sub.held_mse - floor, 1e-300)
            gain = (left - (current.held_mse - current_floor)) / left
            at_floor = not decompose_fit(channel, sub, floor / max(n0, 1e-300)).significant
            if at_floor or not buys(gain, left, excess0, EFFECTS[e].n_params, price):
                for i, c in enumerate(candidates):
                    if c.accepted and set(c.fit.effects) == set(chosen):
                        candidates[i] = Candidate(c.fit, c.floor, c.closed, c.gain, False, True)
                closed = (excess0 - left) / excess0
                candidates.append(Candidate(sub, floor, closed, -gain, True, True))
                current, current_floor, chosen = sub, floor, rest
                dropped = True
                break
        if not dropped:
            break
    return current, current_floor, chosen
