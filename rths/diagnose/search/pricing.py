"""The price an effect pays for its parameters in the greedy selection
(:mod:`rths.diagnose.search.selection`): the share of the remaining held-out gap it closes
(:func:`held_out_gain`), whether that buys its parameters (:func:`buys`), and the rule that a
general effect holding a special one as a limit (a backlash whose clearance closes is a series
spring) must buy its extra parameters against the special one (:func:`nested_preferred`),
and which of a set's model structures is taken (:func:`best_structure`: one that frees a
parameter NOMINAL.toml holds must buy it).
"""

from __future__ import annotations

from rths.diagnose.channels.channel import Channel
from rths.diagnose.effects import EFFECTS, NESTS
from rths.diagnose.search.identify import Fit
from rths.diagnose.search.results import Candidate

__all__ = [
    "NESTED_RESOLUTION",
    "PRICE",
    "best_structure",
    "buys",
    "held_out_gain",
    "nested_preferred",
    "strongest",
]

#: Fraction of the remaining reducible gap an added effect must close per identified parameter.
PRICE: float = 0.1
#: Share of the reducible gap below which what a set leaves is at the resolution of the
#: floor (what a special case of a nested pair leaves -- a series spring for a backlash --
#: or what the effects already chosen leave): an effect added then must still close
#: :data:`PRICE` per (extra) parameter of this share, not of a remainder that is noise and
#: model form (:func:`buys`).
NESTED_RESOLUTION: float = 0.05


def held_out_gain(current: tuple[float, float], trial: tuple[float, float]) -> float:
    """Share of the current set's remaining gap ``J_S - N_S`` a trial ``(J, N)`` (held-out
    mean square, its own floor) closes; at most 0 when it does not lower ``J`` itself -- a model
    that predicts the held-out data worse has closed nothing, however much higher its own
    noise floor (a stiff contact propagates more noise) is.

    Parameters
    ----------
    current, trial
        ``(held-out mean square, noise floor)`` [unit^2] of the current set and of the trial.
    """
    (j_s, n_s), (j, n) = current, trial
    gain = ((j_s - n_s) - (j - n)) / max(j_s - n_s, 1e-300)
    return gain if j < j_s else min(gain, 0.0)


def buys(gain: float, remaining: float, excess0: float, n_params: int, price: float) -> bool:
    """Whether an effect closing the share ``gain`` of the ``remaining`` gap buys its
    ``n_params`` parameters: it closes ``price`` per parameter of the remaining gap, or of
    :data:`NESTED_RESOLUTION` of the channel's reducible gap ``excess0`` when less remains.
    Once a set has closed all but a few per cent of the gap, what is left is within the noise
    floor's uncertainty and the model form of the effects already chosen (a friction law's
    shape at reversals, say); a further effect that reshapes it by a share of that remainder
    has shown no structure of its own.

    Parameters
    ----------
    gain
        Share [-] of the remaining gap the effect closes (:func:`held_out_gain`).
    remaining, excess0
        The current set's remaining gap and the channel's reducible gap [unit^2].
    n_params
        Parameters the effect adds.
    price
        :data:`PRICE` (or the caller's).
    """
    return gain * remaining >= price * n_params * max(remaining, NESTED_RESOLUTION * excess0)


def nested_preferred(
    trials: list[tuple[float, Candidate]], price: float
) -> list[tuple[float, Candidate]]:
    """Drop every trial whose general effect (:data:`rths.diagnose.effects.NESTS`, e.g.
    backlash) does not close ``price`` per extra parameter of what the same set with its
    special case (internal stiffness) leaves: gains ``g`` are shares of the current remaining
    gap, so the general one must reach ``g - g_s >= price * extra * (1 - g_s)``.

    Parameters
    ----------
    trials
        ``(gain, candidate)`` of every trial of one step.
    price
        :data:`PRICE` (or the caller's).
    """
    by_set = {frozenset(c.fit.effects): g for g, c in trials}
    out = []
    for g, c in trials:
        names = frozenset(c.fit.effects)
        dominated = False
        for general, special in NESTS.items():
            if general in names and special not in names:
                other = by_set.get((names - {general}) | {special})
                extra = EFFECTS[general].n_params - EFFECTS[special].n_params
                left = 1.0 - other if other is not None else 0.0  # at the floor: nothing
                # a gap the special one leaves within NESTED_RESOLUTION of its floor is none
                need = price * max(extra, 1) * max(left, NESTED_RESOLUTION)
                if other is not None and (left <= 0.0 or g - other < need):
                    dominated = True
        if not dominated:
            out.append((g, c))
    return out or trials


def strongest(trials: list[tuple[float, Candidate]]) -> tuple[float, Candidate]:
    """The trial a forward step adds: the largest gain -- but among trials that close the
    remaining gap to within :data:`NESTED_RESOLUTION` of it, the one with the lowest held-out
    residual itself.

    At the floor's resolution the credited gains no longer tell trials apart: a model that
    propagates much drive noise (a series spring tuned to a few hertz) is credited with a
    high floor of its own, and a residual at that floor closed "113 %" of an outside
    generator's amplitude-law gap (held-out NRMSE 12.2 -> 6.4 %, floor 7.8 %) where the
    amplitude law itself closed 99.99 % by prediction (12.2 -> 0.11 %, floor 0.02 %).  What
    a model predicts is the evidence; its credited floor only says no better was possible.

    Parameters
    ----------
    trials
        ``(gain, candidate)`` of the step's trials (after :func:`nested_preferred`).
    """
    at_floor = [t for t in trials if t[0] >= 1.0 - NESTED_RESOLUTION]
    if len(at_floor) > 1:
        return min(at_floor, key=lambda t: t[1].fit.held_mse)
    return max(trials, key=lambda t: t[0])


def best_structure(fits: list[Fit], channel: Channel, floor: float, price: float = PRICE) -> Fit:
    """The structure that fits the identification data best -- among those whose parameters
    are physical, when any is (a structure that fits better with a clearance below the
    resolution must not hide one that names a resolved clearance).  A structure that frees
    NOMINAL.toml's own parameters (:attr:`rths.diagnose.effects.model.Model.freedoms`: a
    damping a dissipation law may replace) always fits the identification data at least as
    well as the one holding them, so it is taken only when it buys them on held-out data: it
    closes ``price`` per freed parameter of the gap above ``floor`` [unit^2] (the current
    set's noise floor) that the held structure leaves.

    Parameters
    ----------
    fits
        One fit per model structure of a set of effects.
    channel
        Their channel.
    floor
        The current set's noise floor [unit^2].
    price
        :data:`PRICE` (or the caller's).
    """
    ok = [f for f in fits if f.model.physical(channel, f.params)]
    fits = ok or fits
    held = [f for f in fits if f.model.freedoms == 0]
    freed = [f for f in fits if f.model.freedoms > 0]
    if not held or not freed:
        return min(fits, key=lambda f: f.ident_mse)
    best = min(held, key=lambda f: f.ident_mse)
    rich = min(freed, key=lambda f: f.ident_mse)
    left = max(best.held_mse - floor, 1e-300)
    return rich if best.held_mse - rich.held_mse >= price * rich.model.freedoms * left else best
