"""Adaptive time series (ATS) compensator (Chae, Kazemibidokhti & Ricles 2013).

The command is a linear combination of the target and its derivatives,

.. math:: u_k = a_0\\, r_{k+1} + a_1\\, \\dot r_{k+1} + a_2\\, \\ddot r_{k+1},

whose coefficients are identified online.  If the actuator behaves as a gain ``A`` and a delay
``tau``, ``y(t) = A u(t - tau)``, then ``u(t) = y(t + tau)/A`` and the second-order Taylor series
gives ``a0 = 1/A`` (amplitude factor), ``a1 = tau/A`` and ``a2 = tau^2/(2A)``; ``a1/a0`` estimates
the delay.  Every ``update_every`` steps the coefficients are re-identified by least squares over
a moving window of past commands and measurements,

.. math:: \\mathbf a = (X_m^T X_m)^{-1} X_m^T U_c, \\qquad
          X_m = [\\,y_m \\;\\; \\dot y_m \\;\\; \\ddot y_m\\,],

with each command paired with the measurement it aimed at (``u_{k-1}`` with ``y_k``).  Measured
velocity and acceleration are central differences of the low-pass filtered measurement; the
command passes through the *same* filter, so the filter's phase lag cancels from the regression
(LTI operators commute).  Safeguards of the published method: no update while the measured
amplitude in the window is below ``threshold``; each update changes ``a_i`` by at most
``max_rate_i * update_every * dt``; coefficients are clipped to ``bounds``.  Defaults are those of
the authors' benchmark implementation (1 s window, every 16 steps, 0.01 in threshold, 20 Hz
6th-order Butterworth, bounds a0 in [0.7, 1.3], a1 in [0, 0.08] s, a2 in [0, 0.0032] s^2, rates
2, 0.05 s, 0.001 s^2 per second).

References
----------
Y. Chae, K. Kazemibidokhti, J. M. Ricles, "Adaptive time series compensator for delay
compensation of servo-hydraulic actuator systems for real-time hybrid simulation", Earthquake
Eng. Struct. Dyn. 42(11), 1697-1715, 2013.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from controllers._lti import inverse_taylor, siso_polynomials
from controllers.base import Compensator
from controllers.baselines._ats_kernel import CONSTS, ats_step
from rths.core.errors import (
    ParameterError,
    check_finite,
    check_nonnegative,
    check_positive,
)
from rths.core.filters import LowPass
from rths.core.kinematics import Kinematics
from rths.core.registry import COMPENSATORS

__all__ = ["ATSSettings", "AdaptiveTimeSeries"]


@dataclass(frozen=True, slots=True)
class ATSSettings:
    """Tuning of the ATS compensator (defaults: Chae et al. 2013 benchmark implementation).

    Attributes
    ----------
    initial
        Initial ``(a0, a1, a2)`` [-, s, s^2]; ``(1, tau, tau^2/2)`` for an expected delay ``tau``.
        Default: the Taylor coefficients of the nominal model's inverse when built from one
        (clipped to the bounds), else ``(1, 0, 0)``.
    window
        Length of the moving least-squares window [s].
    update_every
        Steps between coefficient updates (the "skipping number").
    threshold
        Minimum peak measured displacement in the window for an update [m] (0.01 in).
    bounds
        ``((lo, hi), ...)`` for a0 [-], a1 [s], a2 [s^2].
    max_rate
        Maximum rate of change of a0 [1/s], a1 [-], a2 [s].
    cutoff_hz
        Cut-off of the Butterworth low-pass on command and measurement [Hz]; ``None``: no filter.
    filter_order
        Order of that filter (even).
    """

    initial: tuple[float, float, float] | None = None
    window: float = 1.0
    update_every: int = 16
    threshold: float = 2.54e-4
    bounds: tuple[tuple[float, float], ...] = ((0.7, 1.3), (0.0, 0.08), (0.0, 0.0032))
    max_rate: tuple[float, float, float] = (2.0, 0.05, 0.001)
    cutoff_hz: float | None = 20.0
    filter_order: int = 6

    def __post_init__(self) -> None:
        if len(self.start) != 3 or len(self.bounds) != 3 or len(self.max_rate) != 3:
            raise ParameterError(
                "ATS initial, bounds and max_rate must each have 3 entries (a0, a1, a2); got "
                f"{len(self.start)}, {len(self.bounds)}, {len(self.max_rate)}"
            )
        for i, (lo, hi) in enumerate(self.bounds):
            lo_ok = check_finite(lo, f"ATS lower bound of a{i}")
            if not lo_ok < check_finite(hi, f"ATS upper bound of a{i}"):
                raise ParameterError(f"ATS bounds of a{i} must satisfy lo < hi; got {(lo, hi)!r}")
            if not lo <= check_finite(self.start[i], f"ATS initial a{i}") <= hi:
                raise ParameterError(
                    f"ATS initial a{i} must lie within its bounds {(lo, hi)!r}; "
                    f"got {self.start[i]!r}"
                )
            check_positive(self.max_rate[i], f"ATS max_rate of a{i}")
        check_positive(self.window, "ATS window")
        check_nonnegative(self.threshold, "ATS threshold")
        every = self.update_every
        if isinstance(every, bool) or not isinstance(every, int) or every < 1:
            raise ParameterError(f"ATS update_every must be a positive integer; got {every!r}")
        if self.cutoff_hz is not None:
            check_positive(self.cutoff_hz, "ATS cutoff_hz")
        if self.filter_order not in (2, 4, 6, 8):
            raise ParameterError(
                f"ATS filter_order must be 2, 4, 6 or 8; got {self.filter_order!r}"
            )

    @property
    def start(self) -> tuple[float, float, float]:
        """The coefficients the compensator starts from: ``initial``, or ``(1, 0, 0)``."""
        return (1.0, 0.0, 0.0) if self.initial is None else self.initial


@COMPENSATORS.register("ats", ATSSettings)
class AdaptiveTimeSeries(Compensator):
    """ATS compensator ``u = a0 r + a1 r' + a2 r''`` with online least squares (see module doc).

    Parameters
    ----------
    dt
        Loop time step [s].
    settings
        Tuning; :class:`ATSSettings` defaults when omitted.
    use_jit
        Step with the compiled kernel (:func:`controllers.baselines._ats_kernel.ats_step`, default;
        the
        coefficients equal the Python path's to round-off) or in Python (the reference path).
    """

    @classmethod
    def from_options(
        cls,
        options: ATSSettings,
        *,
        dt: float,
        nominal: object = None,
        delay: float = 0.0,
        **_: object,
    ) -> AdaptiveTimeSeries:
        """The ``ats`` kind; without ``initial`` it starts from the Taylor coefficients of the
        ``nominal`` model's inverse (clipped to the bounds), else from ``(1, 0, 0)``."""
        if options.initial is None and nominal is not None:
            num, den = siso_polynomials(nominal)
            c = inverse_taylor(num, den, 2, delay)
            start = tuple(float(np.clip(c[i], *options.bounds[i])) for i in range(3))
            options = replace(options, initial=start)  # type: ignore[arg-type]
        return cls(dt, options)

    def __init__(
        self, dt: float, settings: ATSSettings | None = None, *, use_jit: bool = True
    ) -> None:
        super().__init__(dt)
        self.use_jit: bool = bool(use_jit)
        self.settings = ATSSettings() if settings is None else settings
        if not isinstance(self.settings, ATSSettings):
            raise ParameterError(f"settings must be an ATSSettings; got {self.settings!r}")
        s = self.settings
        self._n_window = int(round(s.window / self.dt))
        if self._n_window < 16:
            raise ParameterError(
                f"ATS window must span at least 16 steps; got {s.window!r} s at dt={self.dt!r}"
            )
        if s.cutoff_hz is not None and not s.cutoff_hz < 0.5 / self.dt:
            raise ParameterError(
                f"ATS cutoff_hz must be below the Nyquist frequency {0.5 / self.dt}; "
                f"got {s.cutoff_hz!r}"
            )
        self._lo = np.array([b[0] for b in s.bounds])
        self._hi = np.array([b[1] for b in s.bounds])
        self._step_limit = np.asarray(s.max_rate) * s.update_every * self.dt
        self._sos = (
            LowPass(s.cutoff_hz, self.dt, s.filter_order).sos.copy()
            if s.cutoff_hz is not None
            else np.zeros((1, 6))
        )
        self._consts = np.array(
            [2.0 * self.dt, self.dt**2, s.threshold, float(s.cutoff_hz is not None),
             float(s.update_every), *self._lo, *self._hi, *self._step_limit]
        )  # fmt: skip
        assert self._consts.size == len(CONSTS)
        self.reset()

    @property
    def coefficients(self) -> NDArray[np.float64]:
        """The current ``(a0, a1, a2)`` [-, s, s^2] (a copy)."""
        if self.use_jit:
            return self._kstate[:3].copy()
        return self._coefficients.copy()

    def _reset_impl(self) -> None:
        """Return to rest with the initial coefficients and empty history."""
        self._coefficients = np.asarray(self.settings.start, dtype=float)
        self._kstate = np.array([*self.settings.start, 0.0])  # compiled path: a0..a2, u_prev
        self._zf = np.zeros((2, self._sos.shape[0], 2))
        self._window = np.zeros((2, self._n_window))
        self._counters = np.zeros(3, dtype=np.int64)
        # the same doubles as Python floats: the per-step command without NumPy scalars
        self._coefficient_floats: tuple[float, ...] = tuple(self._coefficients.tolist())
        self._u_buf = np.zeros(self._n_window)
        self._y_buf = np.zeros(self._n_window)
        self._i = 0
        self._count = 0
        self._updates = 0
        self._u_prev = 0.0
        s = self.settings  # the same Butterworth on command and measurement: its lag cancels
        self._filt_u = (
            None if s.cutoff_hz is None else LowPass(s.cutoff_hz, self.dt, s.filter_order)
        )
        self._filt_y = (
            None if s.cutoff_hz is None else LowPass(s.cutoff_hz, self.dt, s.filter_order)
        )

    def _record(self, u_prev: float, y: float) -> None:
        if self._filt_u is not None and self._filt_y is not None:
            u_prev, y = self._filt_u(u_prev), self._filt_y(y)
        self._u_buf[self._i] = u_prev
        self._y_buf[self._i] = y
        self._i = (self._i + 1) % self._n_window
        self._count += 1

    def _identify(self) -> None:
        i = self._i
        u = np.concatenate((self._u_buf[i:], self._u_buf[:i]))
        y = np.concatenate((self._y_buf[i:], self._y_buf[:i]))
        if np.max(np.abs(y)) < self.settings.threshold:
            return
        dt = self.dt
        x = np.column_stack(
            (y[1:-1], (y[2:] - y[:-2]) / (2.0 * dt), (y[2:] - 2.0 * y[1:-1] + y[:-2]) / dt**2)
        )
        scale = np.linalg.norm(x, axis=0)
        if np.any(scale == 0.0):
            return
        xs = x / scale
        normal = xs.T @ xs
        if np.linalg.cond(normal) > 1e12:  # e.g. a single sine: a0 and a2 not separable
            return
        a = np.linalg.solve(normal, xs.T @ u[1:-1]) / scale
        step = np.clip(a - self._coefficients, -self._step_limit, self._step_limit)
        self._coefficients = np.clip(self._coefficients + step, self._lo, self._hi)
        self._coefficient_floats = tuple(self._coefficients.tolist())
        self._updates += 1

    def _step_impl(self, target: Kinematics, measured: float) -> float:
        if self.use_jit:
            d, v, a = target
            return ats_step(self._sos, self._zf, self._window, self._counters, self._kstate,
                            self._consts, d, v, a, measured)  # fmt: skip
        self._record(self._u_prev, measured)
        if self._count >= self._n_window and self._count % self.settings.update_every == 0:
            self._identify()
        a0, a1, a2 = self._coefficient_floats
        u = a0 * target.displacement + a1 * target.velocity + a2 * target.acceleration
        self._u_prev = u
        return u

    def state(self) -> dict[str, float]:
        """Coefficients a0 [-], a1 [s], a2 [s^2], delay estimate a1/a0 [s], update count."""
        a0, a1, a2 = self._own_coefficients()
        return {
            "a0": a0,
            "a1": a1,
            "a2": a2,
            "delay": a1 / a0,
            "updates": float(self._count_updates()),
        }

    def _own_coefficients(self) -> tuple[float, ...]:
        return tuple(self._kstate[:3].tolist()) if self.use_jit else self._coefficient_floats

    def _count_updates(self) -> int:
        return int(self._counters[2]) if self.use_jit else self._updates

    def write_channels(self, out: NDArray[np.float64]) -> None:
        """Write :meth:`state`'s values into ``out`` (no dict: this runs every step)."""
        a0, a1, a2 = self._own_coefficients()
        out[0], out[1], out[2], out[3], out[4] = a0, a1, a2, a1 / a0, self._count_updates()
