"""A delay against the lag the calibration of the nominal's poles can mimic.

The actuator's baseline scales every pole frequency of NOMINAL.toml's transfer function by a
common factor and every complex pole's damping ratio by another, within the contract's
+/-10 % (:data:`rths.diagnose.effects.actuator.CALIBRATION_TOLERANCE`), besides a one-sample
alignment.  Slower, more damped poles lag: within the tolerance they mimic up to a tenth of
the poles' own group delay, several samples on a fast DAQ.  When the records hold a delay, the
least-squares calibration takes every factor as far as the tolerance lets it towards that lag,
and what it leaves is the nominal's model form (a reduced-order fit of the loop), which a delay
beside those factors does not close either: the channel came out ``unexplained`` although a
delay, and nothing else, was there.

Two rules, both the selection's price (:func:`rths.diagnose.search.pricing.buys`) applied to
the calibration's own factors where they trade with a delay:

* **A delay at the lag bound** (:func:`delay_at_lag_bound`).  The baseline took on all but
  one sample (:data:`LAG_SLACK`, the alignment the contract calls calibration) of the largest
  lag its factors can give (:func:`lag_headroom`), so the records want at least as much lag as
  calibration can supply.  The delay identified with the nominal's own poles
  (:class:`rths.diagnose.effects.actuator.ActuatorModel` with ``nominal_poles``) is named
  when it is a delay beyond one sample and the baseline's factors do not buy their
  parameters against it on held-out data: the delay explains the records as well with fewer
  parameters, and with a nominal that needs no calibration at its bounds -- but never a
  delay that predicts the held-out records worse than the calibration it replaces: lag the
  records want from a loop the nominal's form does not hold (a slow pole-zero pair mis-set
  root by root, a load the actuator yields to) is not a delay.  On a tenth outside generator
  (48 cases) the rule had named three delays in cases without one, each with a held-out
  NRMSE 2-4 % above the calibration's.  ``evidence = "lag bound"``.  A nominal
  mis-calibrated within the tolerance does not reach the bound, and lag its factors take on
  short of it stays calibration: on the ninth outside generator's 48 cases, every delay
  case but one took the factors to within 0.01 sample of the bound, every case without a
  delay stayed 1.6 samples or more short of it (a rate-limit case apart, whose limit the
  selection names first); the tenth's cases reach it without a delay.
* **A named delay's poles** (:func:`nominal_poles_preferred`).  A delay identified beside
  calibrated factors (common or root by root) is reported with the nominal's own poles when
  those factors do not lower the held-out mean square by the price per factor of what that
  fit leaves above its floor -- or of the channel's one-sample resolution when less (another
  effect's model form, a flow limit's shape, may dominate the remainder): along the ridge
  where a slower pole trades with a shorter delay the data do not choose, and the
  calibration's expected value is the nominal (its error is symmetric).  On that generator the
  delays named beside factors at their lag bounds were 1-42 % off the truth (five of seven
  beyond 10 %); with this rule 1-23 % (three of seven).

The lag-bound rule prices the baseline's factors against the remainder alone: they sit at the
edge of the tolerance, a boundary solution the records push beyond, and a share of a sample's
shift bought there is no evidence that the nominal's poles are off.
"""

from __future__ import annotations

from collections.abc import Callable

from rths.diagnose.channels.channel import Channel
from rths.diagnose.effects.actuator import CALIBRATION_TOLERANCE, ActuatorModel
from rths.diagnose.effects.model import Theta
from rths.diagnose.search.calibrated import calibration_lag
from rths.diagnose.search.floors import noise_floor
from rths.diagnose.search.identify import Fit

__all__ = [
    "LAG_SLACK",
    "calibration_factors",
    "delay_at_lag_bound",
    "lag_headroom",
    "nominal_poles_fit",
    "nominal_poles_preferred",
]

#: Samples of lag short of the calibration's largest within which the baseline is at its lag
#: bound: the one-sample alignment the contract counts as calibration.
LAG_SLACK: float = 1.0
#: Name prefixes and names of the calibration's factors in a fit's ``theta``.
_FACTOR_PREFIXES: tuple[str, ...] = ("zero_", "pole_", "damping_")
_FACTOR_NAMES: tuple[str, ...] = ("frequency_scale", "damping_scale")


def lag_headroom(channel: Channel, baseline: dict[str, float]) -> float | None:
    """How much more lag [s] the calibration could take on than ``baseline`` did: the lag of
    every factor at its lag bound (poles 10 % slower, damping 10 % higher, a sample of
    alignment) less the baseline's own (:func:`rths.diagnose.search.calibrated.calibration_lag`,
    both read where the command holds power); None for a channel without a calibrated
    transfer function.

    Parameters
    ----------
    channel
        The actuator channel.
    baseline
        Its common re-calibration (``frequency_scale``, ``damping_scale``, ``alignment`` [s]).
    """
    most = {
        "frequency_scale": 1.0 - CALIBRATION_TOLERANCE,
        "damping_scale": 1.0 + CALIBRATION_TOLERANCE,
        "alignment": channel.dt,
    }
    top, taken = calibration_lag(channel, most), calibration_lag(channel, baseline)
    return None if top is None or taken is None else top - taken


def calibration_factors(fit: Fit, channel: Channel) -> int:
    """The number of calibration factors (common or root by root) ``fit``'s model frees.

    Parameters
    ----------
    fit
        An actuator channel's fit.
    channel
        Its channel.
    """
    names = [p.name for p in fit.model.space(channel)]
    return sum(n in _FACTOR_NAMES or n.startswith(_FACTOR_PREFIXES) for n in names)


def nominal_poles_fit(
    channel: Channel, fitter: Callable[..., Fit], base: Fit, like: Fit, effects: tuple[str, ...]
) -> Fit:
    """``effects`` (holding ``actuator_delay``) identified with the nominal's own poles,
    warm-started from ``like``'s effect parameters with its whole lag as the delay (the
    delay's global grid runs besides).

    Parameters
    ----------
    channel, fitter
        The actuator channel and its fitter.
    base
        The common re-calibration's fit (its gain and offsets prepare the model).
    like
        The fit whose lag and effect parameters start the search (the baseline, or a fit of
        the same set with calibrated factors).
    effects
        The effect set.
    """
    limiter = getattr(like.model, "limiter", "output")
    model = ActuatorModel(effects, limiter if "rate_limit" in effects else "output", True)
    lag = calibration_lag(channel, like.baseline) or 0.0
    own: Theta = {
        k: v
        for k, v in like.theta.items()
        if k not in _FACTOR_NAMES and not k.startswith(_FACTOR_PREFIXES) and k != "shift"
    }
    shift = float(like.theta.get("shift", 0.0)) + lag / channel.dt
    return fitter(model, channel, base.baseline, [{**own, "shift": shift}])


def nominal_poles_preferred(
    channel: Channel,
    fitter: Callable[..., Fit],
    base: Fit,
    fit: Fit,
    seed: int,
    price: float,
) -> tuple[Fit, float] | None:
    """``fit``'s effects with the nominal's own poles when ``fit``'s calibration factors do not
    buy their parameters against that fit (module docstring), with its held-out floor; None
    when they do, when ``fit`` holds no delay or frees no factor, or when the refit is not
    physical.

    Parameters
    ----------
    channel, fitter
        The actuator channel and its fitter.
    base
        The common re-calibration's fit.
    fit
        The selected set's fit.
    seed, price
        As for :func:`rths.diagnose.search.selection.select`.
    """
    if "actuator_delay" not in fit.effects or not isinstance(fit.model, ActuatorModel):
        return None
    n_factors = calibration_factors(fit, channel)
    if n_factors == 0:
        return None
    refit = nominal_poles_fit(channel, fitter, base, fit, fit.effects)
    if not refit.model.physical(channel, refit.params):
        return None
    floor = noise_floor(refit, channel, seed)
    resolution = base.model.resolution(channel, base.prediction)
    if _factors_buy(refit, floor, fit, n_factors, price, resolution):
        return None
    return refit, floor


def _factors_buy(
    refit: Fit, floor: float, fit: Fit, n_factors: int, price: float, resolution: float | None
) -> bool:
    """Whether ``fit``'s ``n_factors`` calibration factors close ``price`` per factor of what
    ``refit`` (the same effects with the nominal's poles) leaves above its ``floor`` on
    held-out data (:func:`rths.diagnose.search.pricing.buys` of that remainder itself: a
    delay named at a few per cent of the channel's first gap leaves a remainder that is no
    longer the gap's resolution but the poles' own error, which the factors must follow) --
    or, with a ``resolution`` [m^2] (the mean square a one-sample shift of the motion
    leaves), of that resolution when less: where another effect's model form dominates the
    remainder (a flow limit's shape), factors that move the prediction by a good share of a
    sample's shift are resolved whatever that remainder (a delay beside a rate limit had
    moved from 3.8 to 5.2 ms without them)."""
    remaining = max(refit.held_mse - floor, 1e-300)
    scale = remaining if resolution is None else min(remaining, resolution)
    return refit.held_mse - fit.held_mse >= price * n_factors * scale


def delay_at_lag_bound(
    channel: Channel,
    fitter: Callable[..., Fit],
    base: Fit,
    effects: tuple[str, ...],
    seed: int,
    price: float,
) -> tuple[Fit, float] | None:
    """A delay the baseline's calibration absorbed up to its lag bound (module docstring):
    the delay with the nominal's own poles and its floor, or None.

    Parameters
    ----------
    channel, fitter
        The actuator channel and its fitter.
    base
        The common re-calibration's fit.
    effects
        The candidate effects of the diagnosis.
    seed, price
        As for :func:`rths.diagnose.search.selection.select`.
    """
    if "actuator_delay" not in effects or not isinstance(base.model, ActuatorModel):
        return None
    room = lag_headroom(channel, base.baseline)
    taken = calibration_lag(channel, base.baseline)
    if room is None or taken is None or room > LAG_SLACK * channel.dt or taken <= channel.dt:
        return None
    refit = nominal_poles_fit(channel, fitter, base, base, ("actuator_delay",))
    if not refit.model.physical(channel, refit.params):
        return None
    if refit.held_mse > base.held_mse:  # it predicts the held-out records worse: no delay
        return None
    floor = noise_floor(refit, channel, seed)
    if _factors_buy(refit, floor, base, calibration_factors(base, channel), price, None):
        return None
    return refit, floor
