"""Build a compensator by kind: ``make_compensator(kind, dt, nominal, **options)``.

Every compensator module registers its kind with :data:`rths.core.registry.COMPENSATORS` and the
frozen dataclass of its options; this module imports them all (so the registry is full) and
turns keyword options into that dataclass.  Kinds shipped (``rths kinds compensator`` lists their
options):

========== =================================================================================
kind       what
========== =================================================================================
none       the target as command
polynomial polynomial extrapolation over the nominal model's delay (Horiuchi et al. 1999)
ats        adaptive time series (Chae et al. 2013)
ff         inverse of a low-order nominal model (Phillips & Spencer 2013)
lqg        LQG feedback on the nominal model with an integral of the tracking error
ff_lqg     ff + lqg (Phillips & Spencer 2013; S0 §5.2)
pi_lead    the vRTHS benchmark's sample controller: PI + phase lead (Silva et al. 2020)
========== =================================================================================

``nominal`` is the continuous-time command->measured model (python-control
``TransferFunction``/``StateSpace``), ``delay`` [s] a transport delay of it given separately.
An all-pole nominal model of degree <= ``order`` is inverted exactly; any other is first reduced
by :func:`~controllers.model_based.feedforward.fit_low_order` (Phillips & Spencer invert a
3rd-order model:
each order above 3 needs one more difference of the target acceleration, amplifying its
noise by 2/dt).
"""

from __future__ import annotations

import dataclasses
import importlib
import pkgutil
from typing import Any

import controllers
from controllers.base import Compensator
from rths.core.errors import ParameterError, check_nonnegative, format_choices
from rths.core.registry import COMPENSATORS

__all__ = ["kinds", "make_compensator"]


def kinds() -> tuple[str, ...]:
    """Every registered compensator kind (importing every module of :mod:`controllers`)."""
    for info in pkgutil.walk_packages(controllers.__path__, prefix="controllers."):
        importlib.import_module(info.name)
    return COMPENSATORS.names()


def make_compensator(
    kind: str, dt: float, nominal: object = None, *, delay: float = 0.0, **options: Any
) -> Compensator:
    """Build a compensator by registry name.

    Parameters
    ----------
    kind
        One of :func:`kinds`, e.g. ``"none"``, ``"polynomial"``, ``"ats"``, ``"ff"``, ``"lqg"``,
        ``"ff_lqg"``.
    dt
        Loop time step [s].
    nominal
        Continuous-time SISO python-control model, command [m] -> measured displacement [m];
        required by ``ff``, ``lqg``, ``ff_lqg`` and by ``polynomial`` without ``horizon``.
    delay
        Transport delay of the nominal model [s].
    **options
        Fields of the kind's options dataclass (``rths kinds compensator``).

    Raises
    ------
    ParameterError
        Unknown kind or option, missing nominal model, or any invalid value.
    """
    kinds()
    entry = COMPENSATORS.get(kind)
    allowed = tuple(f.name for f in dataclasses.fields(entry.options))
    unknown = sorted(set(options) - set(allowed))
    if unknown:
        raise ParameterError(
            f"unknown option(s) {format_choices(unknown)} for compensator {kind!r}; "
            f"valid: {format_choices(allowed) or 'none'}"
        )
    delay = check_nonnegative(delay, "nominal delay")
    try:
        opts = entry.options(**options)
    except TypeError as exc:
        raise ParameterError(f"compensator {kind!r}: {exc}") from None
    compensator: Compensator = entry.build(opts, dt=dt, nominal=nominal, delay=delay)
    return compensator
