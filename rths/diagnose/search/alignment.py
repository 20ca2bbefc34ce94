"""Whether a specimen channel's force/displacement alignment buys itself.

The baseline of the ``force`` and ``displacement`` channels may re-calibrate a shift of up to
one sample between force and displacement (:func:`rths.diagnose.effects.alignment.
alignment_column`: conditioners of different group delay).  Like every freedom beyond a
nominal's own parameters, it is kept only when it pays on held-out data: the baseline is
identified with and without it, and the alignment stays on -- for every model of the channel
-- when the aligned baseline closes at least ``price`` (:data:`rths.diagnose.search.pricing.
PRICE`, one parameter's) of the held-out gap the plain one leaves
(:func:`rths.diagnose.search.pricing.held_out_gain`).  A lag that is there takes a no-effect
record to its floor (an outside generator's LVDT demodulator: 1.95x the floor NRMSE to 0.88x);
one that is not there trades with the damping and the friction: on the real MTS record it
went to its bound, closed 1 % of the baseline's gap and took the friction fit's held-out
NRMSE from 18 to 25 %.
"""

from __future__ import annotations

from collections.abc import Callable

from rths.diagnose.channels.channel import Channel
from rths.diagnose.effects import baseline_for
from rths.diagnose.effects.model import Model
from rths.diagnose.search.floors import noise_floor
from rths.diagnose.search.identify import Fit
from rths.diagnose.search.pricing import held_out_gain

__all__ = ["ALIGNED_CHANNELS", "aligned_baseline"]

#: The channels whose models hold the alignment.
ALIGNED_CHANNELS: tuple[str, ...] = ("force", "displacement")


def aligned_baseline(
    channel: Channel, fitter: Callable[[Model, Channel], Fit], seed: int, price: float
) -> tuple[Fit, float]:
    """The channel's re-calibrated baseline, with the alignment when it buys itself (module
    docstring), and its held-out noise floor [unit^2]
    (:func:`rths.diagnose.search.floors.noise_floor`); sets
    :attr:`rths.diagnose.channels.channel.Channel.alignment` accordingly.

    Parameters
    ----------
    channel
        The channel.
    fitter
        Identifies a model on the channel (the selection's).
    seed
        Seed of the noise floors' synthetic drive noise.
    price
        Share of the plain baseline's held-out gap the alignment must close.
    """
    channel.alignment = True
    aligned = fitter(baseline_for(channel.name), channel)
    if channel.name not in ALIGNED_CHANNELS or aligned.baseline.get("alignment", 0.0) == 0.0:
        return aligned, noise_floor(aligned, channel, seed)
    channel.alignment = False
    plain = fitter(baseline_for(channel.name), channel)
    floor = noise_floor(plain, channel, seed)
    if plain.held_mse <= floor:
        return plain, floor  # at its floor without it: nothing to buy
    aligned_floor = noise_floor(aligned, channel, seed)
    if held_out_gain((plain.held_mse, floor), (aligned.held_mse, aligned_floor)) >= price:
        channel.alignment = True
        return aligned, aligned_floor
    return plain, floor
