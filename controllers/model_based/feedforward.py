"""Model-based feedforward: the inverse of a low-order actuator model applied to the target.

Phillips & Spencer (2013) model the actuator (with its specimen) by a low-order all-pole
transfer function and invert it as a polynomial in ``s``, so the command is a weighted sum of the
target and its derivatives:

.. math::

    G_a(s) = \\frac{b_0\\, e^{-s\\tau}}{s^n + a_{n-1}s^{n-1} + \\dots + a_0}, \\qquad
    u = \\frac{1}{b_0}\\left(r^{(n)} + a_{n-1} r^{(n-1)} + \\dots + a_0 r\\right)
    \\quad (\\tau = 0).

A transport delay ``tau`` is inverted by the Taylor series of :math:`e^{s\\tau}` truncated at the
model order (error :math:`(\\omega\\tau)^{n+1}/(n+1)!`, 2e-5 for 5 ms at 5 Hz with n = 3).
This is the feedforward half of the FF+LQG compensator used in the seed RTHS test (S0 §5.2).

References
----------
B. M. Phillips and B. F. Spencer Jr., "Model-based feedforward-feedback actuator control for
real-time hybrid simulation", J. Struct. Eng. 139(7), 2013 (NSEL report, 2012).
B. M. Phillips and B. F. Spencer Jr., "Model-based multiactuator control for real-time hybrid
simulation", 2013.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from controllers._lti import FloatArray, dc_gain, inverse_taylor, siso_polynomials
from controllers.base import Compensator
from controllers.model_based._lqg_kernel import pack_ff
from rths.core.compiled import CompiledStep
from rths.core.errors import (
    ParameterError,
    check_finite,
    check_nonnegative,
    check_positive,
)
from rths.core.kinematics import Kinematics
from rths.core.registry import COMPENSATORS

__all__ = [
    "FeedforwardOptions",
    "FeedforwardCompensator",
    "LowOrderFit",
    "LowOrderModel",
    "fit_low_order",
    "low_order_from_nominal",
]

#: Highest model order the feedforward inverts (derivatives beyond the 5th from differences of
#: the acceleration amplify noise by (2/dt)^(n-2) and are never useful at 2-4 kHz).
MAX_ORDER = 5


@dataclass(frozen=True, slots=True)
class LowOrderModel:
    """All-pole actuator model ``b0 exp(-s delay) / (s^n + a_{n-1} s^{n-1} + ... + a0)``.

    Attributes
    ----------
    b0
        Numerator gain [1/s^n]; ``b0/a0`` is the static gain (measured/command, m/m).
    den
        Monic denominator coefficients in descending powers of ``s``, ``(1, a_{n-1}, ..., a0)``,
        with ``a_i`` in [1/s^(n-i)].
    delay
        Pure transport delay [s].
    """

    b0: float
    den: tuple[float, ...]
    delay: float = 0.0

    def __post_init__(self) -> None:
        check_positive(self.b0, "low-order model gain b0")
        check_nonnegative(self.delay, "low-order model delay")
        if len(self.den) < 2 or len(self.den) - 1 > MAX_ORDER:
            raise ParameterError(
                f"low-order model order must lie in [1, {MAX_ORDER}]; got {len(self.den) - 1}"
            )
        if self.den[0] != 1.0:
            raise ParameterError(f"low-order model denominator must be monic; got {self.den!r}")
        for i, a in enumerate(self.den):
            check_finite(a, f"low-order model denominator coefficient {i}")
        if np.max(np.roots(self.den).real) >= 0.0:
            raise ParameterError(f"low-order model must be stable; got denominator {self.den!r}")

    @property
    def order(self) -> int:
        """Number of poles ``n``."""
        return len(self.den) - 1

    def inverse_coefficients(self) -> FloatArray:
        """Coefficients ``c`` (ascending) of the feedforward ``u = sum_i c_i r^(i)``."""
        num = np.array([self.b0])
        return inverse_taylor(num, np.asarray(self.den, dtype=float), self.order, self.delay)

    def frequency_response(self, freq_hz: FloatArray) -> FloatArray:
        """Complex FRF (measured/command) at the frequencies ``freq_hz`` [Hz]."""
        s = 2j * np.pi * np.asarray(freq_hz, dtype=float)
        return self.b0 * np.exp(-s * self.delay) / np.polyval(self.den, s)


@dataclass(frozen=True, slots=True)
class LowOrderFit:
    """Result of :func:`fit_low_order`: the model and its relative FRF error over the band.

    Attributes
    ----------
    model : LowOrderModel
        The fitted all-pole model (static gain exact, transport delay carried over).
    band_hz : tuple of (float, float)
        The fit band ``(lo, hi)`` [Hz], ``0 <= lo < hi``.
    max_relative_error : float
        Largest relative complex FRF error ``|G_fit(jw) - G(jw)| / |G(jw)|`` over the band [-].
    rms_relative_error : float
        RMS of that relative error over the band [-].
    """

    model: LowOrderModel
    band_hz: tuple[float, float]
    max_relative_error: float
    rms_relative_error: float


def fit_low_order(
    nominal: object,
    order: int = 3,
    band_hz: tuple[float, float] = (0.0, 20.0),
    delay: float = 0.0,
    n_freq: int = 400,
) -> LowOrderFit:
    """Fit an all-pole model of the given order to the FRF of a (higher-order) nominal model.

    The static gain is kept exact (``b0 = G(0) a0``) and the fit minimises the RMS *relative*
    complex error
    ``|G_fit(jw) - G(jw)| / |G(jw)|`` over ``n_freq`` uniformly spaced frequencies in ``band_hz``
    (scipy Levenberg-Marquardt on the log-coefficients, started from Levy's linear least-squares
    solution of ``den(jw) G(jw) = b0``), which is what matters for an inverse: the feedforward's
    tracking error at frequency ``w`` equals this relative error.  ``delay`` [s] is a transport
    delay of the nominal model, kept out of the fit and carried into the result.

    For the vRTHS benchmark plant (5 poles) a 3rd-order fit over 0-20 Hz has a relative error of
    at most 2.0 % (RMS 0.7 %) and a low-frequency delay of 25.0 ms; 4th order over 0-20 Hz:
    0.28 % (tests/test_feedforward.py).

    Parameters
    ----------
    nominal : control.TransferFunction or control.StateSpace
        Stable continuous-time SISO command-to-measured model [m/m] (without its transport
        delay).
    order : int
        Order ``n`` of the all-pole fit, 1 .. ``MAX_ORDER`` = 5 (default 3, Phillips & Spencer).
    band_hz : tuple of (float, float)
        Fit band ``(lo, hi)`` [Hz], ``0 <= lo < hi`` (default 0-20 Hz).
    delay : float
        Transport delay ``tau`` [s] of the nominal model, >= 0 (default 0); not fitted, carried
        into the result.
    n_freq : int
        Number of uniformly spaced fit frequencies in the band (default 400).

    Raises
    ------
    ParameterError
        If the nominal model is not a stable continuous-time SISO system, ``order`` is out of
        range, the band is not ``0 <= lo < hi``, or no stable model of that order fits.
    """
    num, den = siso_polynomials(nominal)
    if isinstance(order, bool) or not isinstance(order, int) or not 1 <= order <= MAX_ORDER:
        raise ParameterError(f"fit order must be an integer in [1, {MAX_ORDER}]; got {order!r}")
    lo, hi = (float(band_hz[0]), float(band_hz[1]))
    if not (np.isfinite(lo) and np.isfinite(hi) and 0.0 <= lo < hi):
        raise ParameterError(f"fit band must satisfy 0 <= lo < hi [Hz]; got {band_hz!r}")
    delay = check_nonnegative(delay, "nominal delay")
    freq = np.linspace(lo, hi, int(n_freq))
    s = 2j * np.pi * freq
    h = np.polyval(num, s) / np.polyval(den, s)
    weight = 1.0 / np.abs(h)
    # Levy: (a0 + a1 s + ... + a_{n-1} s^{n-1}) h - b0 = -s^n h, weighted by 1/|h|
    cols = np.column_stack([h * s**i for i in range(order)] + [-np.ones_like(h)]) * weight[:, None]
    rhs = -(s**order) * h * weight
    a_real = np.vstack([cols.real, cols.imag])
    b_real = np.concatenate([rhs.real, rhs.imag])
    scale = np.linalg.norm(a_real, axis=0)
    p0 = np.linalg.lstsq(a_real / scale, b_real, rcond=None)[0] / scale
    if np.any(p0 <= 0.0):  # a stable polynomial has positive coefficients (necessary)
        p0 = np.abs(p0) + 1e-12

    g0 = dc_gain(num, den)

    def model(a: FloatArray) -> FloatArray:
        # b0 = G(0) a0 keeps the static gain exact (a slow target is inverted without error)
        return g0 * a[0] / (s**order + sum(a[i] * s**i for i in range(order)))

    def residual(log_a: FloatArray) -> FloatArray:
        e = (model(np.exp(log_a)) - h) / h
        return np.concatenate([e.real, e.imag])

    def stable(a: FloatArray) -> bool:
        return bool(np.max(np.roots(np.r_[1.0, a[::-1]]).real) < 0.0)

    sol = least_squares(residual, np.log(p0[:order]), method="lm", x_scale="jac")
    a_fit = np.exp(sol.x)
    if not stable(a_fit):  # the refinement left the stable region: fall back on Levy
        a_fit = p0[:order]
    if not stable(a_fit):
        raise ParameterError(
            f"no stable all-pole fit of order {order} over {lo}-{hi} Hz; "
            "raise the order or narrow the band"
        )
    err = np.abs(model(a_fit) - h) / np.abs(h)
    fitted = LowOrderModel(
        b0=float(g0 * a_fit[0]), den=(1.0, *map(float, a_fit[::-1])), delay=delay
    )
    return LowOrderFit(fitted, (lo, hi), float(err.max()), float(np.sqrt(np.mean(err**2))))


def low_order_from_nominal(nominal: object, delay: float = 0.0) -> LowOrderModel | None:
    """The nominal model itself as a :class:`LowOrderModel` if it is all-pole, else ``None``.

    Parameters
    ----------
    nominal : control.TransferFunction or control.StateSpace
        Stable continuous-time SISO command-to-measured model [m/m].
    delay : float
        Its transport delay [s] (default 0), carried into the model.
    """
    num, den = siso_polynomials(nominal)
    if num.size != 1 or den.size - 1 > MAX_ORDER or den.size < 2:
        return None
    return LowOrderModel(b0=float(num[0]), den=tuple(map(float, den)), delay=delay)


@dataclass(frozen=True)
class FeedforwardOptions:
    """Options of the ``ff`` compensator kind.

    Parameters
    ----------
    order
        Order of the low-order model inverted (Phillips & Spencer: 3).
    band_hz
        Band [Hz] over which a higher-order nominal model is fitted by the low-order one.
    hold_correction
        Evaluate the inverse at mid-step to cancel the zero-order-hold lag.
    """

    order: int = 3
    band_hz: tuple[float, float] = (0.0, 20.0)
    hold_correction: bool = True

    def __post_init__(self) -> None:
        if isinstance(self.order, bool) or not isinstance(self.order, int):
            raise ParameterError(f"feedforward order must be an integer; got {self.order!r}")
        if not 1 <= self.order <= MAX_ORDER:
            raise ParameterError(
                f"feedforward order must lie in [1, {MAX_ORDER}]; got {self.order}"
            )
        lo, hi = (check_finite(f, "feedforward band_hz") for f in self.band_hz)
        if not 0.0 <= lo < hi:
            raise ParameterError(
                f"feedforward band_hz must be [low, high] with 0 <= low < high [Hz]; got "
                f"{list(self.band_hz)!r}"
            )

    def low_order(self, nominal: object, delay: float) -> LowOrderModel:
        """The model to invert: the nominal itself when it is all-pole of degree <= ``order``,
        else its fit over ``band_hz`` (:func:`fit_low_order`)."""
        if nominal is None:
            raise ParameterError("compensator 'ff' needs a nominal model; got None")
        exact = low_order_from_nominal(nominal, delay)
        if exact is not None and exact.order <= self.order:
            return exact
        return fit_low_order(nominal, self.order, self.band_hz, delay).model


@COMPENSATORS.register("ff", FeedforwardOptions)
class FeedforwardCompensator(Compensator):
    """Inverse-model feedforward ``u_k = sum_i c_i r^(i)`` (Phillips & Spencer 2013).

    Derivatives: displacement, velocity and acceleration of the target come from the numerical
    substructure; the jerk and higher derivatives are backward differences of the acceleration
    history.  A first backward difference ``(a_{k+1} - a_k)/dt`` is exactly a half-sample delay
    times ``sinc`` in frequency: it is the jerk at the *midpoint* ``t_{k+1/2}`` with an amplitude
    error ``(w dt)^2/24`` (2e-6 at 10 Hz and 4096 Hz) and no phase error there.  Because the
    actuator holds ``u_k`` over ``[t_k, t_{k+1}]`` (ZOH, an average lag of ``dt/2``), the whole
    inverse is evaluated at that midpoint (``hold_correction=True``): lower derivatives are
    averaged over the two ends of the step, which cancels the ZOH lag of ``w dt/2`` rad (0.4 %
    J2 at 5 Hz and 4096 Hz) to second order.  The m-th difference (orders 4 and 5) is centred
    at ``t_{k+1-m/2}``, half a sample or more behind; its coefficient is small enough that this
    costs less than the ZOH error it replaces.

    Parameters
    ----------
    dt
        Loop time step [s].
    model
        The low-order actuator model to invert.
    hold_correction
        Evaluate the inverse at mid-step to cancel the zero-order-hold lag (default ``True``).
    """

    @classmethod
    def from_options(
        cls,
        options: FeedforwardOptions,
        *,
        dt: float,
        nominal: object = None,
        delay: float = 0.0,
        **_: object,
    ) -> FeedforwardCompensator:
        """The ``ff`` kind: the inverse of :meth:`FeedforwardOptions.low_order`."""
        if options.band_hz[1] > 0.5 / dt:
            raise ParameterError(
                f"feedforward band_hz {list(options.band_hz)!r} must lie below the Nyquist "
                f"frequency {0.5 / dt:g} Hz of the loop rate"
            )
        return cls(dt, options.low_order(nominal, delay), options.hold_correction)

    def __init__(self, dt: float, model: LowOrderModel, hold_correction: bool = True) -> None:
        super().__init__(dt)
        if not isinstance(model, LowOrderModel):
            raise ParameterError(f"model must be a LowOrderModel; got {model!r}")
        self.model = model
        self.hold_correction = bool(hold_correction)
        self._c = [float(ci) for ci in model.inverse_coefficients()]
        self._n_diff = max(0, model.order - 2)  # derivatives from differences of acceleration
        self.reset()

    def _reset_impl(self) -> None:
        """Return to rest: previous target and acceleration history are zero."""
        self._prev = (0.0, 0.0, 0.0)
        self._acc: deque[float] = deque([0.0] * (self._n_diff + 1), maxlen=self._n_diff + 1)
        self._u = 0.0

    def command(self, target: Kinematics) -> float:
        """Advance the derivative history with ``target`` and return the feedforward [m]."""
        r, v, a = target.displacement, target.velocity, target.acceleration
        c = self._c
        if self.hold_correction:
            r0, v0, a0 = self._prev
            terms = [0.5 * (r + r0), 0.5 * (v + v0), 0.5 * (a + a0)]
        else:
            terms = [r, v, a]
        self._acc.appendleft(a)
        hist = self._acc
        dt = self.dt
        if self._n_diff >= 1:
            terms.append((hist[0] - hist[1]) / dt)
        if self._n_diff >= 2:
            terms.append((hist[0] - 2.0 * hist[1] + hist[2]) / dt**2)
        if self._n_diff >= 3:
            terms.append((hist[0] - 3.0 * hist[1] + 3.0 * hist[2] - hist[3]) / dt**3)
        self._prev = (r, v, a)
        u = 0.0
        for ci, ti in zip(c, terms):
            u += ci * ti
        self._u = float(u)
        return self._u

    def _step_impl(self, target: Kinematics, measured: float) -> float:
        return self.command(target)

    def compiled_step(self) -> CompiledStep:
        """This compensator for the loop's fused kernel (family ``"ff"``: constants ``P``,
        state ``S`` of :func:`controllers.model_based._lqg_kernel.ff_step` and the step
        count)."""
        p, s = pack_ff(self.dt, self._c, self.hold_correction, self._n_diff)
        n = self._n_diff + 1
        s[0:3], s[3 : 3 + n], s[-1] = self._prev, list(self._acc), self._u
        counter = np.array([float(self._steps)])

        def commit() -> None:
            self._prev = (float(s[0]), float(s[1]), float(s[2]))
            self._acc = deque(s[3 : 3 + n].tolist(), maxlen=n)
            self._u, self._steps = float(s[-1]), int(counter[0])

        return CompiledStep("ff", (p,), (s, counter), commit)

    def state(self) -> dict[str, float]:
        """``feedforward`` command [m] of the last step."""
        return {"feedforward": self._u}
