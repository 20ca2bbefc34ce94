"""Baseline compensators: no compensation and polynomial extrapolation with a fixed delay.

The adaptive time series (ATS) baseline lives in :mod:`controllers.ats`.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from controllers.base import Compensator
from rths.core.errors import ParameterError, check_nonnegative, check_positive_int
from rths.core.kinematics import Kinematics

__all__ = ["NoCompensation", "PolynomialExtrapolation", "extrapolation_weights"]


class NoCompensation(Compensator):
    """The command is the target: ``u_k = r_{k+1}`` (the reference every compensator must beat)."""

    kind = "none"

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

    kind = "polynomial"

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
