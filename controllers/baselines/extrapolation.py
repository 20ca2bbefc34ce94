"""Baseline compensators: no compensation and polynomial extrapolation with a fixed delay.

The adaptive time series (ATS) baseline lives in :mod:`controllers.baselines.ats`, the vRTHS
benchmark's sample controller in :mod:`controllers.baselines.pi_lead`.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from controllers._lti import inverse_taylor, siso_polynomials
from controllers.base import Compensator
from rths.core.errors import ParameterError, check_nonnegative, check_positive_int
from rths.core.kinematics import Kinematics
from rths.core.registry import COMPENSATORS, NoOptions

__all__ = [
    "NoCompensation",
    "PolynomialExtrapolation",
    "PolynomialOptions",
    "extrapolation_weights",
]


@COMPENSATORS.register("none")
class NoCompensation(Compensator):
    """The command is the target: ``u_k = r_{k+1}`` (the reference every compensator must beat).

    Parameters
    ----------
    dt : float
        Loop step [s], > 0.
    """

    @classmethod
    def from_options(cls, options: NoOptions, *, dt: float, **_: object) -> NoCompensation:
        """The ``none`` kind."""
        return cls(dt)

    def _reset_impl(self) -> None:
        """Nothing to reset."""

    def _step_impl(self, target: Kinematics, measured: float) -> float:
        return target.displacement


def extrapolation_weights(order: int, steps_ahead: float) -> np.ndarray:
    """Lagrange weights ``w_j`` with ``r(t_0 + h dt) ~ sum_j w_j r(t_0 - j dt)``, j = 0..order.

    The polynomial of degree ``order`` through the current and the ``order`` previous samples is
    evaluated ``h = steps_ahead`` samples ahead.  Exact for polynomials of that degree; for a
    sinusoid of angular frequency ``w`` the error is
    ``(w dt)^(order+1) * prod_j (h + j) / (order+1)!`` to leading order.

    Parameters
    ----------
    order : int
        Polynomial degree, >= 1 (the ``polynomial`` kind allows 1 to 4).
    steps_ahead : float
        Extrapolation horizon ``h`` [steps of dt], >= 0 (need not be an integer).

    Returns
    -------
    numpy.ndarray, shape (order + 1,)
        The weights ``w_0 .. w_order`` [-]; they sum to 1.
    """
    order = check_positive_int(order, "extrapolation order")
    h = check_nonnegative(steps_ahead, "extrapolation steps ahead")
    nodes = -np.arange(order + 1, dtype=float)
    w = np.ones(order + 1)
    for j in range(order + 1):
        for m in range(order + 1):
            if m != j:
                w[j] *= (h - nodes[m]) / (nodes[j] - nodes[m])
    return w


@dataclass(frozen=True)
class PolynomialOptions:
    """Options of the ``polynomial`` compensator kind.

    Parameters
    ----------
    horizon
        Delay to compensate [s], >= 0; default: the nominal model's low-frequency phase delay
        plus its transport delay.
    order
        Polynomial degree, 1 to 4.
    """

    horizon: float | None = None
    order: int = 3

    def __post_init__(self) -> None:
        if self.horizon is not None:
            check_nonnegative(self.horizon, "polynomial extrapolation horizon")
        if not 1 <= check_positive_int(self.order, "polynomial extrapolation order") <= 4:
            raise ParameterError(
                f"polynomial extrapolation order must be at most 4; got {self.order}"
            )


@COMPENSATORS.register("polynomial", PolynomialOptions)
class PolynomialExtrapolation(Compensator):
    """Command the target extrapolated a fixed delay ahead (Horiuchi et al. 1999).

    ``u_k = sum_j w_j r_{k+1-j}``: the polynomial of degree ``order`` through the latest
    ``order + 1`` targets, evaluated ``delay`` seconds after ``t_{k+1}``.  With an actuator that
    behaves as a pure delay ``delay``, the measured displacement then equals the target up to the
    extrapolation error, of order ``(w dt)^(order+1)``.

    Parameters
    ----------
    dt
        Loop time step [s].
    delay
        Actuator delay to compensate, ``tau`` [s] (fixed; estimate it from the nominal model's
        low-frequency phase delay or from a sine test).
    order
        Polynomial degree, 1 to 4 (Horiuchi et al. use 3; higher orders amplify noise).

    References
    ----------
    M. Horiuchi, M. Inoue, T. Konno, Y. Namita, "Real-time hybrid experimental system with
    actuator delay compensation and its application to a piping system with energy absorber",
    Earthquake Eng. Struct. Dyn. 28(10), 1121-1141, 1999.
    """

    @classmethod
    def from_options(
        cls,
        options: PolynomialOptions,
        *,
        dt: float,
        nominal: object = None,
        delay: float = 0.0,
        **_: object,
    ) -> PolynomialExtrapolation:
        """The ``polynomial`` kind; without ``horizon`` it needs the ``nominal`` model."""
        horizon = options.horizon
        if horizon is None:
            if nominal is None:
                raise ParameterError(
                    "compensator 'polynomial (without horizon)' needs a nominal model; got None"
                )
            num, den = siso_polynomials(nominal)
            c = inverse_taylor(num, den, 1, delay)
            horizon = c[1] / c[0]
        return cls(dt, horizon, options.order)

    def __init__(self, dt: float, delay: float, order: int = 3) -> None:
        super().__init__(dt)
        self.delay = check_nonnegative(delay, "polynomial extrapolation delay")
        order = check_positive_int(order, "polynomial extrapolation order")
        if order > 4:
            raise ParameterError(f"polynomial extrapolation order must be at most 4; got {order}")
        self.order = order
        self.weights = extrapolation_weights(order, self.delay / self.dt)
        self.reset()

    def _reset_impl(self) -> None:
        """Return to rest: the target history is zero."""
        self._history: deque[float] = deque([0.0] * (self.order + 1), maxlen=self.order + 1)

    def _step_impl(self, target: Kinematics, measured: float) -> float:
        self._history.appendleft(target.displacement)
        u = 0.0
        for w, r in zip(self.weights, self._history):
            u += w * r
        return u

    def state(self) -> dict[str, float]:
        """The fixed compensated ``delay`` [s]."""
        return {"delay": self.delay}
