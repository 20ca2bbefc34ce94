"""Registry of compensators: ``make_compensator(kind, dt, nominal, **options)``.

Kinds and their options (all SI):

========== =================================================================================
kind       options
========== =================================================================================
none       --
polynomial ``horizon`` [s] (default: the nominal model's low-frequency phase delay + ``delay``),
           ``order`` (3)
ats        fields of :class:`~controllers.ats.ATSSettings`; ``initial`` defaults to the Taylor
           coefficients of the nominal inverse when a nominal model is given
ff         ``order`` (3), ``band_hz`` ((0, 20)), ``hold_correction`` (True)
lqg        fields of :class:`~controllers.lqg.LQGWeights`
ff_lqg     the options of ``ff`` and ``lqg``
========== =================================================================================

``nominal`` is the continuous-time command->measured model (python-control
``TransferFunction``/``StateSpace``), ``delay`` [s] a transport delay of it given separately.
An all-pole nominal model of degree <= ``order`` is inverted exactly; any other is first reduced
by :func:`~controllers.feedforward.fit_low_order` (Phillips & Spencer invert a 3rd-order model:
each order above 3 needs one more difference of the target acceleration, amplifying its
noise by 2/dt).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import fields
from typing import Any

import numpy as np

from controllers._lti import inverse_taylor, siso_polynomials
from controllers.ats import AdaptiveTimeSeries, ATSSettings
from controllers.base import Compensator
from controllers.baselines import NoCompensation, PolynomialExtrapolation
from controllers.feedforward import (
    FeedforwardCompensator,
    LowOrderModel,
    fit_low_order,
    low_order_from_nominal,
)
from controllers.ff_lqg import FFLQGCompensator
from controllers.lqg import LQGCompensator, LQGWeights, design_lqg
from rths.core.errors import ParameterError, check_nonnegative, format_choices

__all__ = ["KINDS", "make_compensator"]

_FF_OPTIONS = ("order", "band_hz", "hold_correction")
_LQG_OPTIONS = tuple(f.name for f in fields(LQGWeights))
_ATS_OPTIONS = tuple(f.name for f in fields(ATSSettings))


def _require(nominal: object, kind: str) -> object:
    if nominal is None:
        raise ParameterError(f"compensator {kind!r} needs a nominal model; got None")
    return nominal


def _low_order(nominal: object, delay: float, options: dict[str, Any]) -> LowOrderModel:
    order = options.get("order", 3)
    if isinstance(order, bool) or not isinstance(order, int):
        raise ParameterError(f"feedforward order must be an integer; got {order!r}")
    exact = low_order_from_nominal(nominal, delay)
    if exact is not None and exact.order <= order:
        return exact
    return fit_low_order(nominal, order, options.get("band_hz", (0.0, 20.0)), delay).model


def _feedforward(
    dt: float, nominal: object, delay: float, options: dict[str, Any]
) -> FeedforwardCompensator:
    model = _low_order(_require(nominal, "ff"), delay, options)
    return FeedforwardCompensator(dt, model, options.get("hold_correction", True))


def _weights(options: dict[str, Any]) -> LQGWeights:
    return LQGWeights(**{k: v for k, v in options.items() if k in _LQG_OPTIONS})


def _make_none(
    dt: float, nominal: object, delay: float, options: dict[str, Any]
) -> Compensator:
    return NoCompensation(dt)


def _make_polynomial(
    dt: float, nominal: object, delay: float, options: dict[str, Any]
) -> Compensator:
    if "horizon" in options:
        horizon = options["horizon"]
    else:
        num, den = siso_polynomials(_require(nominal, "polynomial (without horizon)"))
        c = inverse_taylor(num, den, 1, delay)
        horizon = c[1] / c[0]
    return PolynomialExtrapolation(dt, horizon, options.get("order", 3))


def _make_ats(
    dt: float, nominal: object, delay: float, options: dict[str, Any]
) -> Compensator:
    opts = dict(options)
    if "initial" not in opts and nominal is not None:
        num, den = siso_polynomials(nominal)
        bounds = opts.get("bounds", ATSSettings().bounds)
        c = inverse_taylor(num, den, 2, delay)
        opts["initial"] = tuple(float(np.clip(c[i], *bounds[i])) for i in range(3))
    return AdaptiveTimeSeries(dt, ATSSettings(**opts))


def _make_ff(
    dt: float, nominal: object, delay: float, options: dict[str, Any]
) -> Compensator:
    return _feedforward(dt, nominal, delay, options)


def _make_lqg(
    dt: float, nominal: object, delay: float, options: dict[str, Any]
) -> Compensator:
    design = design_lqg(_require(nominal, "lqg"), dt, _weights(options), delay)
    return LQGCompensator(dt, design)


def _make_ff_lqg(
    dt: float, nominal: object, delay: float, options: dict[str, Any]
) -> Compensator:
    ff = _feedforward(dt, _require(nominal, "ff_lqg"), delay, options)
    design = design_lqg(nominal, dt, _weights(options), delay)
    return FFLQGCompensator(dt, design, ff)


_Builder = Callable[[float, object, float, dict[str, Any]], Compensator]

_REGISTRY: dict[str, tuple[_Builder, tuple[str, ...]]] = {
    "none": (_make_none, ()),
    "polynomial": (_make_polynomial, ("horizon", "order")),
    "ats": (_make_ats, _ATS_OPTIONS),
    "ff": (_make_ff, _FF_OPTIONS),
    "lqg": (_make_lqg, _LQG_OPTIONS),
    "ff_lqg": (_make_ff_lqg, _FF_OPTIONS + _LQG_OPTIONS),
}

#: Registered compensator kinds, in the order of increasing sophistication.
KINDS: tuple[str, ...] = tuple(_REGISTRY)


def make_compensator(
    kind: str, dt: float, nominal: object = None, *, delay: float = 0.0, **options: Any
) -> Compensator:
    """Build a compensator by registry name.

    Parameters
    ----------
    kind
        One of :data:`KINDS`: ``"none"``, ``"polynomial"``, ``"ats"``, ``"ff"``, ``"lqg"``,
        ``"ff_lqg"``.
    dt
        Loop time step [s].
    nominal
        Continuous-time SISO python-control model, command [m] -> measured displacement [m];
        required by ``ff``, ``lqg``, ``ff_lqg`` and by ``polynomial`` without ``horizon``.
    delay
        Transport delay of the nominal model [s].
    **options
        Kind-specific options (module docstring).

    Raises
    ------
    ParameterError
        Unknown kind or option, missing nominal model, or any invalid value.
    """
    if kind not in _REGISTRY:
        raise ParameterError(
            f"unknown compensator kind {kind!r}; choose one of {format_choices(KINDS)}"
        )
    builder, allowed = _REGISTRY[kind]
    unknown = sorted(set(options) - set(allowed))
    if unknown:
        raise ParameterError(
            f"unknown option(s) {format_choices(unknown)} for compensator {kind!r}; "
            f"valid: {format_choices(allowed) or 'none'}"
        )
    delay = check_nonnegative(delay, "nominal delay")
    return builder(dt, nominal, delay, options)
