"""Signal-path effects of a transfer system: a pure delay and a velocity (flow) limit.

Both exist as a stepping object (used inside the actuators, one sample per call) and as a function
on a whole record (for identification and diagnosis), with identical semantics.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from rths.core.errors import ParameterError, check_nonnegative, check_positive

__all__ = ["DelayLine", "RateLimiter", "delayed", "rate_limited"]


def _split_delay(delay: float, dt: float) -> tuple[int, float]:
    """``delay/dt = whole + fraction`` with ``0 <= fraction < 1`` (snapped to integers)."""
    q = delay / dt
    nearest = round(q)
    if abs(q - nearest) <= 1e-9 * max(1.0, q):
        return int(nearest), 0.0
    whole = math.floor(q)
    return whole, q - whole


class DelayLine:
    """Pure delay of ``delay`` [s] on a signal sampled every ``dt`` [s].

    A FIFO of past samples; a delay that is not a whole number of samples is read by linear
    interpolation between the two neighbouring samples:

    .. math::

        y_k = (1 - f)\\, x_{k-n} + f\\, x_{k-n-1},
        \\qquad \\tau / \\Delta t = n + f,\\; 0 \\le f < 1,

    with ``x_j = 0`` for ``j < 0`` (the line starts at rest).  For a signal with bounded second
    derivative the interpolation error is at most ``f (1 - f) dt^2 max|x''| / 2 <=
    dt^2 max|x''| / 8``.

    Parameters
    ----------
    delay
        Delay ``tau`` [s], >= 0.
    dt
        Sample period [s], > 0.
    """

    def __init__(self, delay: float, dt: float) -> None:
        self.delay: float = check_nonnegative(delay, "delay")
        self.dt: float = check_positive(dt, "time step dt")
        self._whole, self._fraction = _split_delay(self.delay, self.dt)
        self._buffer = np.zeros(self._whole + 2)
        self._head = 0

    def reset(self) -> None:
        """Empty the line (all past samples zero)."""
        self._buffer[:] = 0.0
        self._head = 0

    def step(self, sample: float) -> float:
        """Push the newest sample and return the delayed value at the same instant."""
        buffer, size = self._buffer, self._buffer.size
        self._head = (self._head + 1) % size
        buffer[self._head] = sample
        newer = buffer[(self._head - self._whole) % size]
        if self._fraction == 0.0:
            return float(newer)
        older = buffer[(self._head - self._whole - 1) % size]
        return float((1.0 - self._fraction) * newer + self._fraction * older)


def delayed(signal: ArrayLike, delay: float, dt: float) -> NDArray[np.float64]:
    """A whole record delayed as :class:`DelayLine` would: zero history, linear interpolation.

    Parameters
    ----------
    signal
        Samples at uniform spacing ``dt`` [s], shape ``(n,)``.
    delay
        Delay [s], >= 0.
    dt
        Sample period [s], > 0.

    Returns
    -------
    numpy.ndarray
        The delayed record, shape ``(n,)``.
    """
    delay = check_nonnegative(delay, "delay")
    dt = check_positive(dt, "time step dt")
    x = np.asarray(signal, dtype=float)
    if x.ndim != 1:
        raise ParameterError(f"signal must be 1-D; got shape {x.shape}")
    whole, fraction = _split_delay(delay, dt)
    padded = np.concatenate([np.zeros(whole + 1), x])
    newer = padded[1 : 1 + x.size]
    older = padded[: x.size]
    return (1.0 - fraction) * newer + fraction * older


@njit(cache=True)
def _rate_limit_kernel(x: NDArray[np.float64], max_change: float, initial: float) -> NDArray:
    y = np.empty_like(x)
    previous = initial
    for i in range(x.size):
        change = x[i] - previous
        if change > max_change:
            previous = previous + max_change
        elif change < -max_change:
            previous = previous - max_change
        else:
            previous = x[i]
        y[i] = previous
    return y


class RateLimiter:
    """Symmetric rate limiter with Simulink *Rate Limiter* semantics, ``|slope| <= v_max``.

    With ``x_k`` the input and ``y_{k-1}`` the previous output, sampled every ``dt`` [s]::

        rate = (x_k - y_{k-1}) / dt
        y_k  = y_{k-1} + v_max*dt   if rate >  v_max     (limited, rising)
        y_k  = y_{k-1} - v_max*dt   if rate < -v_max     (limited, falling)
        y_k  = x_k                  otherwise            (tracking)

    The output starts from ``y_{-1} = 0`` (rest).  While limited the output is a ramp of slope
    ``+/- v_max`` that rejoins the input as soon as the input is within reach; below the limit
    the output equals the input exactly.  Used on the actuator displacement it models a
    servo-valve flow limit ``v_max = Q_max / A_piston``; :meth:`clip` gives the matching drive
    velocity and acceleration.

    Parameters
    ----------
    velocity_limit
        ``v_max`` [m/s], > 0.
    dt
        Sample period [s], > 0.
    """

    def __init__(self, velocity_limit: float, dt: float) -> None:
        self.velocity_limit: float = check_positive(velocity_limit, "velocity_limit")
        self.dt: float = check_positive(dt, "time step dt")
        self._max_change = self.velocity_limit * self.dt
        self.output: float = 0.0
        #: ``+1`` / ``-1`` when the last sample was limited rising / falling, else ``0``.
        self.limiting: int = 0

    def reset(self) -> None:
        """Back to rest: output 0, not limiting."""
        self.output = 0.0
        self.limiting = 0

    def step(self, sample: float) -> float:
        """Limit one sample; return the output (also kept in :attr:`output`)."""
        change = sample - self.output
        if change > self._max_change:
            self.output += self._max_change
            self.limiting = 1
        elif change < -self._max_change:
            self.output -= self._max_change
            self.limiting = -1
        else:
            self.output = sample
            self.limiting = 0
        return self.output

    def clip(self, velocity: float, acceleration: float) -> tuple[float, float]:
        """Drive velocity [m/s] and acceleration [m/s^2] consistent with the last :meth:`step`.

        While limiting: ``(+/- v_max, 0)`` (the ramp).  Otherwise the given velocity clipped
        to ``+/- v_max``, with zero acceleration when clipped (a flow-limited piston cannot
        move faster, even on the sample where the output rejoins a fast input).
        """
        v_max = self.velocity_limit
        if self.limiting:
            return self.limiting * v_max, 0.0
        if velocity > v_max:
            return v_max, 0.0
        if velocity < -v_max:
            return -v_max, 0.0
        return velocity, acceleration


def rate_limited(
    signal: ArrayLike, velocity_limit: float, dt: float, initial: float = 0.0
) -> NDArray[np.float64]:
    """A whole record through :class:`RateLimiter` (same semantics, numba kernel).

    Parameters
    ----------
    signal
        Samples at uniform spacing ``dt`` [s], shape ``(n,)``.
    velocity_limit
        ``v_max`` [m/s] (signal units per second), > 0.
    dt
        Sample period [s], > 0.
    initial
        Output before the first sample (``y_{-1}``); 0 (rest) as in :class:`RateLimiter`.

    Returns
    -------
    numpy.ndarray
        The limited record, shape ``(n,)``.
    """
    v_max = check_positive(velocity_limit, "velocity_limit")
    dt = check_positive(dt, "time step dt")
    x = np.ascontiguousarray(signal, dtype=float)
    if x.ndim != 1:
        raise ParameterError(f"signal must be 1-D; got shape {x.shape}")
    return _rate_limit_kernel(x, v_max * dt, float(initial))
