"""Noise floors: the held-out mean squared residual a fitted model would leave if it were exact.

Actuator channel: the analytic floor (:meth:`rths.diagnose.channels.channel.Channel.
floor_variance`: displacement noise plus command noise through the nominal TF).

Specimen channel: the smoothed force noise, plus -- when the drive is the measured (noisy)
displacement -- the noise the model propagates from its drive: the model is driven a second
time with a synthetic copy of the estimated displacement noise added (white at the estimated
RMS, given the colour read at the records' rest where they hold one --
:mod:`rths.diagnose.channels.rest` -- and smoothed like the record) and the change of its
output is that noise.  A resonant model
(internal stiffness) propagates far more than a rigid one, which is why the floor is per model.
``repeats`` independent copies are drawn (seeded: the diagnosis is reproducible) and the
median of their mean squares is the floor: through a bouncing contact a copy now and then
shifts an impact by a sample and doubles its mean square (a 300 um clearance of the unit
tests: the mean of two copies, over six seeds, 123-164 and once 320, which refuted the true
model), and the floor is the noise a typical copy leaves, not a mean a rare divergence
dominates.
A model whose held-out residual lies far below its own floor has its noise path refuted
(:func:`consistent`): it is credited with no more floor than the set it would join
(:func:`credited_floor`) and judged by how far it lowers the held-out residual itself.
"""

from __future__ import annotations

import numpy as np

from rths.diagnose.channels.channel import Channel, Segment
from rths.diagnose.channels.signals import derivatives, smooth
from rths.diagnose.residuals import FLOOR_MARGIN
from rths.diagnose.search.identify import Fit

__all__ = ["consistent", "credited_floor", "noise_floor"]


def noise_floor(fit: Fit, channel: Channel, seed: int = 0, repeats: int = 3) -> float:
    """Held-out noise floor [unit^2] of ``fit`` on ``channel`` (module docstring).

    Parameters
    ----------
    fit
        The fitted model.
    channel
        Its channel.
    seed
        Seed of the synthetic drive noise.
    repeats
        Independent noise copies (their median mean square is taken).
    """
    if channel.name != "force":
        return channel.floor_variance()
    rng = np.random.default_rng(seed)
    sigma_x = channel.noise["drive"]
    copies = []
    for _ in range(repeats if sigma_x > 0.0 else 0):
        acc, count = 0.0, 0
        for s, p in zip(channel.segments, fit.prediction, strict=True):
            if not np.any(s.held):
                continue
            sos = channel.drive_sos if channel.drive_sos is not None else s.sos
            assert sos is not None
            white = sigma_x * rng.standard_normal(s.observed.size)
            x = s.signals["x"] + smooth(channel.coloured("measured", white), sos)
            v, a = derivatives(x, s.dt)
            twin = Segment(
                s.name, s.index, s.dt, s.observed, {"x": x, "v": v, "a": a}, s.ident, s.held, s.sos
            )
            cols, fixed = fit.model.columns(channel, twin, fit.theta)
            d = (cols @ fit.beta + fixed + fit.offsets[s.index] - p)[s.held]
            acc += float(np.sum(d * d))
            count += d.size
        copies.append(acc / max(count, 1))
    return (float(np.median(copies)) if copies else 0.0) + channel.force_noise_variance()


def consistent(held_mse: float, floor: float) -> bool:
    """Whether a fitted model's held-out mean square ``held_mse`` is consistent with its own
    noise floor ``floor`` (both [unit^2]): a model is a candidate truth only if the data do not
    fall below the noise it would propagate (a stiff contact turning micrometres of drive noise
    into newtons) by more than the floor's uncertainty, ``1 + FLOOR_MARGIN``.  A residual far
    below its floor refutes the model's noise path, and the floor's size must not be credited
    as a closed gap (a stiff element that fits worse than the baseline would otherwise "close"
    many times the gap): :func:`credited_floor`.

    Parameters
    ----------
    held_mse
        The model's held-out mean squared residual.
    floor
        Its held-out noise floor (:func:`rths.diagnose.search.floors.noise_floor`).
    """
    return held_mse * (1.0 + FLOOR_MARGIN) >= floor


def credited_floor(held_mse: float, floor: float, current: tuple[float, float]) -> float:
    """The noise floor [unit^2] a fitted model is credited with in the selection: its own
    ``floor`` when its held-out mean square ``held_mse`` is :func:`consistent` with it, else
    no more than the floor of the set it would join; and in either case no more above that
    floor than the model lowers the held-out residual itself.

    The propagated part of a resonant model's floor (drive noise through a series spring) is
    an upper bound: displacement "noise" may partly be motion the specimen feels.  A model
    whose residual lies below it has that noise path refuted, not its structure -- on the
    independent generator the only candidates ever refuted this way were the true series
    springs (fitted to 0.1 % of the truth, 1325x below the baseline's residual).  Credited
    with the current floor, such a model is judged by how far it lowers the held-out residual
    itself; a stiff element fitting worse than the baseline still closes nothing
    (:func:`rths.diagnose.search.pricing.held_out_gain`), and one fitting barely better closes
    only that.

    A consistent floor is an estimate too, and a model whose reading of the drive is noisy (a
    load amplitude read between reversals) has a high one: credited in full, a model that
    barely lowers the residual would "close" the gap by declaring it noise (on the real MTS
    record such a law closed 0.3 % of the held-out NRMSE and was credited with 82 % of the
    gap, where friction lowered it from 33 to 18 %).  So the rise of the floor over the
    current set's is credited up to the drop of the held-out residual: an effect shows at
    least half of what it closes as prediction.  An exact model leaving propagated noise
    ``p`` where it removes a model error ``e`` is credited with all of ``e`` while
    ``p <= e/2``, and with ``2 (e - p)`` above.

    Parameters
    ----------
    held_mse
        The model's held-out mean square.
    floor
        Its held-out noise floor (:func:`noise_floor`).
    current
        ``(held-out mean square, credited floor)`` of the set it would join (the baseline's,
        at the first step).
    """
    current_mse, current_floor = current
    credited = floor if consistent(held_mse, floor) else min(floor, current_floor)
    return min(credited, current_floor + max(current_mse - held_mse, 0.0))
