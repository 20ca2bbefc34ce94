"""A channel's effects judged against the finest calibration of the nominal's own parameters.

The actuator's baseline re-calibrates NOMINAL.toml's transfer function by *common* factors
(one on every root frequency, one on every complex pole's damping ratio; design.md section
7).  Two things follow that the selection (:mod:`rths.diagnose.search.selection`) must not
take for structure or for its absence:

* a nominal mis-calibrated differently at every root within the +/-10 % tolerance leaves a
  gap the common factors cannot follow, which is no effect;
* the common factors absorb part of a delay's lag (a slower pole), and leave a gap under one
  sample of the motion (put down to model form) or an effect that closes less than half of
  the gap (``unexplained``).

A delay is a phase lag growing with frequency at unit magnitude; a pole's lag saturates and
costs magnitude.  With every root free within the tolerance
(:class:`rths.diagnose.effects.calibration.RootwiseActuator`) the two separate under broadband
excitation, so the selected set -- or, when none was selected, each effect of
:data:`HIDDEN_BY_CALIBRATION` -- is identified again together with the root-by-root
calibration and judged against that calibration alone (:func:`finer_calibration`).
:func:`needs_finer` says when this can change the answer (its fits cost a few seconds).

The common factors and the one-sample alignment can absorb a delay of a few samples so well
that the baseline reaches its noise floor: its residual is then no evidence either way, and
the selection would stop at ``none``.  A fit whose alignment sits at its lag bound wanted more
lag than the contract calls calibration; :func:`hidden_delay` then identifies the delay with
the root-by-root calibration and names it when it predicts the held-out blocks better than
that calibration alone beyond chance (:func:`rths.diagnose.search.crossval.paired_gain`, a
paired test that needs no floor) and buys its parameter (the selection's price, of the gap
the calibration leaves).  On generator cases whose delay of 1.9-3 samples the baseline
absorbed, the delay improved the held-out prediction by 2-4 % of the noise floor's mean
square; a 1.5-sample delay at 4096 Hz by 0.04 % (not found); spurious delays of cases
without one by at most 0.04 %, though significantly: the price, not the test, rejects those.
"""

from __future__ import annotations

from collections.abc import Callable

from rths.diagnose.channels.channel import Channel
from rths.diagnose.effects import EFFECTS, absorbed_lag, calibration_for
from rths.diagnose.effects.actuator import CALIBRATION_TOLERANCE
from rths.diagnose.effects.calibration import drive_band
from rths.diagnose.effects.model import Model
from rths.diagnose.search.crossval import paired_gain
from rths.diagnose.search.floors import noise_floor
from rths.diagnose.search.identify import Fit
from rths.diagnose.search.pricing import buys

__all__ = [
    "AT_LAG_BOUND",
    "HIDDEN_BY_CALIBRATION",
    "PAIRED_Z",
    "PINNED",
    "calibration_lag",
    "finer_calibration",
    "hidden_delay",
    "needs_finer",
    "pinned",
]

#: Effects a calibration of the nominal's own parameters can mimic in part (a pole's lag: up
#: to the tolerance's share of its group delay), so that the common re-calibration can hide
#: them.
HIDDEN_BY_CALIBRATION: tuple[str, ...] = ("actuator_delay",)

#: Name prefixes of the root-by-root calibration's factors.
_ROOTS: tuple[str, ...] = ("zero", "pole", "damping")
#: Alignment [samples] from which the common re-calibration counts as at its lag bound (one
#: sample): the budgeted bounded search stops within a few hundredths of a sample of a bound.
AT_LAG_BOUND: float = 0.95
#: Paired test's z (:func:`rths.diagnose.search.crossval.paired_gain`) a delay at the noise
#: floor must reach: one-sided p = 0.00135 (one test per channel; the decomposition's 5
#: covers ~100 bands).
PAIRED_Z: float = 3.0
#: The common re-calibration's factors.
_SCALES: tuple[str, str] = ("frequency_scale", "damping_scale")
#: Share of the tolerance within which a common factor counts as at its bound (the bounded
#: search stops within a few thousandths of a bound).
PINNED: float = 0.01


def calibration_lag(channel: Channel, baseline: dict[str, float]) -> float | None:
    """The lag [s] the common re-calibration took on (slower poles, more damping, the
    alignment: :func:`rths.diagnose.effects.calibration.absorbed_lag`); None for a channel
    without a calibrated transfer function.  Beyond one sample it is the largest delay the
    records cannot tell from calibration when the baseline reached its floor: at one
    frequency a delay and a pole's phase lag are the same thing.

    Parameters
    ----------
    channel
        The channel.
    baseline
        Its common re-calibration (``frequency_scale``, ``damping_scale``, ``alignment`` [s]).
    """
    if calibration_for(channel.name) is None:
        return None
    act = channel.nominal.actuator
    return absorbed_lag(act.num, act.den, baseline, drive_band(channel))


def needs_finer(
    channel: Channel, current: Fit, chosen: tuple[str, ...], closed: float, min_closed: float
) -> bool:
    """Whether the root-by-root calibration can change a channel's answer: the channel has one,
    and either its selected effects close less than ``min_closed`` of the gap, or they hold a
    delay (a delay trades with the common factors in either direction: faster poles beside a
    longer delay mimic poles that are off by different factors), or the common factors beside
    no effect sit at a bound of their tolerance (:func:`pinned`) or took on more than one
    sample of lag
    (:func:`rths.diagnose.effects.calibration.absorbed_lag`: a delay, or part of one, may
    hide in them).

    Parameters
    ----------
    channel
        The channel.
    current, chosen
        The selected set's fit (the baseline's when none) and its effects.
    closed
        The set's share of the reducible gap [-].
    min_closed
        :data:`rths.diagnose.search.selection.MIN_CLOSED`.
    """
    if calibration_for(channel.name) is None:
        return False
    if chosen and closed < min_closed:
        return True
    if any(e in HIDDEN_BY_CALIBRATION for e in chosen):
        return True  # a delay is named only against the finest calibration of the nominal
    if chosen:
        return False
    if pinned(current.baseline):
        return True  # the common factors wanted more than the tolerance: rootwise may not
    lag = calibration_lag(channel, current.baseline)
    return lag is not None and lag > channel.dt


def pinned(baseline: dict[str, float]) -> bool:
    """Whether a common re-calibration sits at a bound of its tolerance (a factor within
    :data:`PINNED` of ``1 +/- CALIBRATION_TOLERANCE``): the nominal is off by more than the
    common factors can follow -- a pole-zero pair mis-set apart (an integral controller's slow
    dipole, 16 % de-cancelled by +/-10 % errors on each) pinned all three factors of an
    independent generator's case, and its 7-sample delay was put down to model form.

    Parameters
    ----------
    baseline
        The common re-calibration (``gain`` and :data:`_SCALES`).
    """
    lo, hi = 1.0 - CALIBRATION_TOLERANCE, 1.0 + CALIBRATION_TOLERANCE
    factors = [baseline[k] for k in _SCALES if k in baseline]
    return any(min(f - lo, hi - f) < PINNED * CALIBRATION_TOLERANCE for f in factors)


def finer_calibration(
    channel: Channel,
    fitter: Callable[..., Fit],
    fits: tuple[Fit, Fit],
    gap: tuple[float, float],
    effects: tuple[str, ...],
    seed: int,
    price: float,
    min_closed: float,
    calibrated: Callable[[], Fit],
) -> tuple[tuple[Fit, float, float, float] | None, bool, bool] | None:
    """The channel's effects judged against the root-by-root calibration (module docstring).

    The set is identified together with the root-by-root calibration, warm-started from the
    common fit (every root at the common factors: the finer model holds it) and from the
    root-by-root calibration alone.

    Parameters
    ----------
    channel, fitter
        The channel and its fitter (:func:`rths.diagnose.search.crossval.cross_fit` for the
        actuator).
    fits
        ``(base, current)``: the common re-calibration's fit and the selected set's fit (the
        set: ``current.effects``; none selected: ``current`` is ``base``).
    gap
        ``(J_0 - N_0, N_0)``: the channel's reducible held-out gap and the baseline's floor.
    effects
        The candidate effects of the diagnosis.
    seed, price
        As for :func:`rths.diagnose.search.selection.select`.
    min_closed
        :data:`rths.diagnose.search.selection.MIN_CLOSED`.
    calibrated
        Returns the root-by-root calibration alone's fit (the caller's memo: it is shared
        with :func:`hidden_delay`).

    Returns
    -------
    tuple or None
        None when the channel has no finer calibration; else ``(refit, model_form,
        closes)``.
        ``refit = (fit, floor, closed, gain)`` when the set with the root-by-root calibration
        is physical, closes ``min_closed`` of the gap and buys its parameters against that
        calibration alone (``price`` per parameter of the gap it leaves; an effect the
        common factors did not select must close ``min_closed`` of it), else None.
        ``closes``: the root-by-root calibration alone closes ``min_closed`` of the gap;
        ``model_form``: it does so without taking on a sample of lag in all
        (:meth:`rths.diagnose.effects.calibration.RootwiseActuator.lagging`: a hidden delay).
    """
    alone = calibration_for(channel.name)
    if alone is None:
        return None
    base, current = fits
    chosen = current.effects
    excess0, n0 = gap
    cal0 = calibrated()
    closes = excess0 - (cal0.held_mse - n0) >= min_closed * excess0
    model_form = closes and not alone.lagging(channel, cal0.theta)
    left0 = max(cal0.held_mse - noise_floor(cal0, channel, seed), 1e-300)
    sets = [chosen] if chosen else [(e,) for e in HIDDEN_BY_CALIBRATION if e in effects]
    best: tuple[Fit, float, float, float] | None = None
    for effect_set in sets:
        check = calibration_for(channel.name, effect_set)
        assert check is not None
        starts = _rootwise_starts(check, channel, base, cal0, current)
        if "actuator_delay" in chosen:
            own = {k: v for k, v in current.theta.items() if k not in _SCALES}
            starts.append({**cal0.theta, **own})
        fit = fitter(check, channel, base.baseline, starts)
        if not fit.model.physical(channel, fit.params):
            continue
        floor = noise_floor(fit, channel, seed)
        closed = (excess0 - (fit.held_mse - floor)) / excess0
        gain = (left0 - (fit.held_mse - floor)) / left0
        n_params = sum(EFFECTS[e].n_params for e in effect_set)
        # the selection's price (:func:`rths.diagnose.search.pricing.buys`): of what the
        # calibration leaves, or of NESTED_RESOLUTION of the channel's gap when less is left
        # (a 1.04-sample delay beside poles at their bounds bought 10 % of a remainder that
        # was 0.06 % of the gap, within the floor's uncertainty)
        bought = buys(gain, left0, excess0, n_params, price)
        if not chosen:
            bought = bought and gain >= min_closed
        if closed >= min_closed and bought and (best is None or closed > best[2]):
            best = (fit, floor, closed, gain)
    return best, model_form, closes


def _rootwise_starts(
    check: Model, channel: Channel, base: Fit, alone_fit: Fit, current: Fit
) -> list[dict[str, float]]:
    """Starts of ``check``, a root-by-root fit with effects (prepared here on ``base``'s
    re-calibration): every root at the common factors of ``current`` (the finer model holds
    that fit) with its own effect parameters, and the root-by-root calibration alone's roots
    with those parameters."""
    check.prepare(channel, base.baseline)
    roots = [p.name for p in check.space(channel) if p.name.split("_")[0] in _ROOTS]
    common = {
        r: current.theta.get(_SCALES[1] if r.startswith("damping") else _SCALES[0], 1.0)
        for r in roots
    }
    own = {k: v for k, v in current.theta.items() if k not in _SCALES}
    return [
        {**common, **own},
        {**alone_fit.theta, **{k: v for k, v in own.items() if k != "shift"}},
    ]


def hidden_delay(
    channel: Channel,
    fitter: Callable[..., Fit],
    base: Fit,
    effects: tuple[str, ...],
    seed: int,
    price: float,
    calibrated: Callable[[], Fit],
    at_bound: bool = True,
    excess0: float | None = None,
) -> tuple[Fit, float, float, float] | None:
    """A delay the common re-calibration absorbed to the noise floor (module docstring).

    Tried only when the channel has a root-by-root calibration, ``actuator_delay`` is a
    candidate and (``at_bound``) the baseline's alignment reached its lag bound (one sample).
    Without ``at_bound``: a delay the common factors named, which the root-by-root
    calibration absorbs while taking on a sample of lag, is judged by the same paired test.

    Parameters
    ----------
    channel, fitter
        The channel and its fitter (:func:`rths.diagnose.search.crossval.cross_fit`: the
        paired test reads its cross-validated predictions).
    base
        The common re-calibration's fit (at its noise floor).
    effects
        The candidate effects of the diagnosis.
    seed, price
        As for :func:`rths.diagnose.search.selection.select`.
    calibrated
        As for :func:`finer_calibration`.
    at_bound
        Ask for the baseline's alignment at its lag bound.
    excess0
        The channel's reducible gap [m^2] when it is significant (the price is then also
        :data:`rths.diagnose.search.pricing.NESTED_RESOLUTION` of it); None: at the floor,
        the calibration's own remainder prices the delay.

    Returns
    -------
    tuple or None
        ``(fit, floor, gain, z)``: the delay with the root-by-root calibration, its floor
        [m^2], the share of the calibration's own gap it closes and the paired test's z;
        None when no delay is found.
    """
    alone = calibration_for(channel.name)
    if alone is None or "actuator_delay" not in effects:
        return None
    if at_bound and float(base.theta.get("shift", 0.0)) < AT_LAG_BOUND:
        return None  # the alignment did not reach its lag bound: no lag wanted beyond it
    cal0 = calibrated()
    check = calibration_for(channel.name, ("actuator_delay",))
    assert check is not None
    fit = fitter(check, channel, base.baseline, _rootwise_starts(check, channel, base, cal0, base))
    if not fit.model.physical(channel, fit.params):
        return None
    left0 = max(cal0.held_mse - noise_floor(cal0, channel, seed), 1e-300)
    floor = noise_floor(fit, channel, seed)
    gain = (left0 - (fit.held_mse - floor)) / left0
    _, z = paired_gain(channel, cal0, fit)
    gap = left0 if excess0 is None else excess0
    if z < PAIRED_Z or not buys(gain, left0, gap, EFFECTS["actuator_delay"].n_params, price):
        return None
    return fit, floor, gain, z
