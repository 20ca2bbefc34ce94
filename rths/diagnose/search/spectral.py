"""Spectral evidence: a contact whose impacts no replay follows sample by sample.

A lightly damped contact rattles.  Which impact lands when turns on micrometres of the body's
motion, so the replay of any model -- the true one included -- falls out of step with the
record after a few impacts: its held-out residual is about as large as the observation and no
candidate closes half of the time-domain gap (``unexplained`` by
:mod:`rths.diagnose.search.selection` although the device holds a clearance).  What survives
the chaos is the spectrum: how much force the impacts put into every band.

For a fit, the held-out spectral distance is

``D = mean_b ln((P_model,b + P_floor,b) / P_obs,b)^2``

over the 1/6-octave bands ``b`` of the tested band (:func:`rths.diagnose.residuals.decompose`'s
bands), ``P`` the Welch power of the held-out model output, of the noise floor (the noise the
observation holds and a model output lacks) and of the observation.  A model that puts the
right power into every band has ``D`` near 0 whatever the phase of its impacts; the rigid
baseline, which puts none above the drive's band, has a large one.

When the force channel's gap stays ``unexplained``, :func:`spectral_choice` takes the physical
single candidate that lowers ``D`` most when it closes at least ``min_closed`` of the
baseline's ``D_0`` and :data:`rths.diagnose.search.pricing.PRICE` per parameter; a candidate
that holds it and one more effect is added when it closes ``PRICE`` per added parameter of the
``D`` left.  The channel then names these effects with ``evidence = "spectrum"``; its shrink
stays the time-domain share (it tells how far a replay predicts the record: not far).  The
candidates are those the selection already identified: the parameters are the replay's, which
a chaotic contact leaves coarse (three seen generator cases: clearances 23, 35 and 85 % off).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from rths.diagnose.channels.channel import Channel
from rths.diagnose.effects import EFFECTS
from rths.diagnose.residuals import spectral_bands, welch
from rths.diagnose.search.decomposed import floor_psd
from rths.diagnose.search.identify import Fit
from rths.diagnose.search.results import Candidate, held_parts

__all__ = ["SPECTRAL_CHANNELS", "band_distance", "spectral_choice", "spectral_distance"]

#: Channels whose unexplained gap is judged by the spectrum too (a contact's force).
SPECTRAL_CHANNELS: tuple[str, ...] = ("force",)


def band_distance(
    observed: list[NDArray[np.float64]],
    model: list[NDArray[np.float64]],
    dt: float,
    floor: tuple[NDArray[np.float64], NDArray[np.float64]],
    f_hi: float,
) -> float:
    """``D = mean_b ln((P_model,b + P_floor,b) / P_obs,b)^2`` [-] over the 1/6-octave bands
    ``b`` from the lowest resolved frequency to ``f_hi`` (module docstring).

    Parameters
    ----------
    observed, model
        Parts of the observation and of the model output (the same samples), in one unit.
    dt
        Sample period [s].
    floor
        ``(frequency [Hz], one-sided PSD [unit^2/Hz])`` of the noise the observation holds.
    f_hi
        Highest frequency tested [Hz].
    """
    f, p_obs, _ = welch(observed, dt)
    _, p_model, _ = welch(model, dt)
    p_floor = np.interp(f, floor[0], floor[1])
    f_lo = max(2.0 * (f[1] - f[0]), 0.1)
    terms = []
    for b in spectral_bands(f, f_lo, min(f_hi, float(f[-1]))):
        obs = float(np.sum(p_obs[b]))
        if obs > 0.0:
            terms.append(math.log((float(np.sum(p_model[b] + p_floor[b])) + 1e-300) / obs) ** 2)
    return float(np.mean(terms)) if terms else 0.0


def spectral_distance(
    channel: Channel, fit: Fit, floor: tuple[NDArray[np.float64], NDArray[np.float64]]
) -> float:
    """Held-out spectral distance ``D`` [-] of a fit on a specimen channel, tested up to 1.5
    times the channel's smoother cutoff (:func:`band_distance`).

    Parameters
    ----------
    channel
        The channel.
    fit
        The fitted model (its whole-record predictions).
    floor
        ``(frequency [Hz], one-sided PSD)`` of the channel's noise floor.
    """
    observed = held_parts(channel, [s.observed for s in channel.segments])
    model = held_parts(channel, list(fit.prediction))
    return band_distance(observed, model, channel.dt, floor, 1.5 * float(channel.cutoff or 0.0))


def _params(effects: tuple[str, ...]) -> int:
    return sum(EFFECTS[e].n_params for e in effects)


def spectral_choice(
    channel: Channel,
    base: Fit,
    candidates: list[Candidate],
    price: float,
    min_closed: float,
) -> tuple[Candidate, tuple[str, ...], float] | None:
    """The candidate the held-out spectrum names, its effects in order and its share of
    ``D_0`` (module docstring); None when no physical single candidate closes ``min_closed``
    of the baseline's spectral distance.

    Parameters
    ----------
    channel
        The channel.
    base
        The re-calibrated baseline's fit.
    candidates
        Every candidate the selection identified on the channel.
    price
        :data:`rths.diagnose.search.pricing.PRICE`.
    min_closed
        :data:`rths.diagnose.search.selection.MIN_CLOSED`.
    """
    floor = floor_psd(channel, base)
    d0 = spectral_distance(channel, base, floor)
    if d0 <= 0.0:
        return None
    scored = [(spectral_distance(channel, c.fit, floor), c) for c in candidates if c.physical]
    singles = [(d, c) for d, c in scored if len(c.fit.effects) == 1]
    if not singles:
        return None
    d, chosen = min(singles, key=lambda t: t[0])
    share = (d0 - d) / d0
    if share < max(min_closed, price * _params(chosen.fit.effects)):
        return None
    order = chosen.fit.effects
    while True:
        larger = [
            (dd, c)
            for dd, c in scored
            if len(c.fit.effects) == len(order) + 1 and set(order) < set(c.fit.effects)
        ]
        if not larger:
            break
        dd, c = min(larger, key=lambda t: t[0])
        added = tuple(e for e in c.fit.effects if e not in order)
        if d - dd < price * _params(added) * d:
            break
        d, chosen, order = dd, c, order + added
    return chosen, order, (d0 - d) / d0
