"""LQG feedback for actuator tracking: steady-state Kalman filter + LQR with integral action.

The feedback half of the Phillips & Spencer (2013) FF+LQG compensator (S0 §5.2: "the LQG
regulator is designed to increase the robustness of the system for any measurement noise or
disturbance associated with model uncertainty").  Design, on the ZOH-discretised nominal model
``x_{k+1} = A x_k + B u_k``, ``y_k = C x_k`` (balanced realisation, a transport delay replaced by a
Padé approximant):

* Error model.  The tracking error ``e^y = y - r`` is modelled as the output of the nominal
  dynamics driven by the feedback command and an input-equivalent disturbance ``w`` (what the
  feedforward misses: model error, unmodelled specimen forces),
  ``e_{k+1} = A e_k + B (u^fb_k + w_k)``, ``e^y_k = C e_k + v_k``.  The tracking error is also
  integrated, ``z_{k+1} = z_k + dt (r_{k+1} - y_{k+1}) = z_k - dt C (A e_k + B u^fb_k)``.
* LQR (``control.dlqr``) on the augmented state ``[e; z]`` minimises
  ``sum q_y (C e)^2 + q_z z^2 + (u^fb)^2`` and gives ``u^fb = -K_e e - k_z z``.  The integral makes
  a constant output disturbance or gain error vanish in steady state.
* Kalman filter (``control.dlqe``) on the measured error ``y_k - r_k``: process noise enters
  with the command (``G = B``, variance ``process_noise_rms^2``), sensor noise variance
  ``noise_rms^2``.
  ``dlqe`` returns the *predictor* gain ``L = A P C' (C P C' + R)^-1`` of
  ``x_{k+1|k} = A x_{k|k-1} + B u_k + L (y_k - C x_{k|k-1})``, with ``P`` the a-priori
  covariance.  Here the command ``u_k`` is computed *after* ``y_k`` arrives, so the filter is used
  in current-estimator form with the filter gain ``M = P C' (C P C' + R)^-1`` (``L = A M``):
  ``x_{k|k} = x_{k|k-1} + M (y_k - C x_{k|k-1})``, ``x_{k+1|k} = A x_{k|k} + B u_k``.
  That estimator is ``filterpy.kalman.KalmanFilter`` (``update`` then ``predict``) started at
  the steady state: :meth:`LQGDesign.kalman_filter` builds it, and ``estimator="filterpy"``
  runs the compensator on it; the default ``"steady"`` hot path applies the constant gain ``M``
  directly and is tested step for step against filterpy (``tests/test_lqg_filterpy.py``).

References
----------
B. M. Phillips and B. F. Spencer Jr., "Model-based feedforward-feedback actuator control for
real-time hybrid simulation", J. Struct. Eng. 139(7), 2013 (NSEL report, 2012).
G. F. Franklin, J. D. Powell, M. Workman, Digital Control of Dynamic Systems, 3rd ed., 1998
(current estimator; integral control by state augmentation).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import control
import numpy as np

from controllers._lti import FloatArray, balanced_realization, dc_gain, siso_polynomials
from controllers.base import Compensator
from controllers.model_based import _lqg_kernel
from controllers.model_based.feedforward import FeedforwardCompensator
from rths.core.channels import Channel
from rths.core.compiled import CompiledStep
from rths.core.errors import (
    ParameterError,
    check_nonnegative,
    check_positive,
    check_positive_int,
)
from rths.core.kinematics import Kinematics
from rths.core.registry import COMPENSATORS

if TYPE_CHECKING:
    from filterpy.kalman import KalmanFilter

__all__ = ["LQGCompensator", "LQGDesign", "LQGWeights", "design_lqg", "discrete_nominal"]


#: Highest Padé order for a nominal delay: beyond it the polynomial coefficients span more
#: orders of magnitude than double precision resolves.
MAX_PADE_ORDER = 10


@dataclass(frozen=True, slots=True)
class LQGWeights:
    """Weights of the LQG design.

    Defaults were tuned on the vRTHS benchmark (1-5 Hz multi-sine, 2e-5 m sensor noise, 4096 and
    2048 Hz, 10 perturbed plants): they cut the feedforward's J2 about 4x on perturbed plants
    and still improve on it on the nominal plant, where the sensor noise passed by the feedback
    (~0.1 % J2) is what remains.  The integral corner ``sqrt(q_z/q_y)`` = 32 rad/s (5 Hz) and a
    Kalman filter that trusts the measurement (``process_noise_rms`` 7.5x ``noise_rms``) let the
    loop follow the real plant rather than the model.

    Attributes
    ----------
    error_weight
        ``q_y``: weight of the squared displacement error [m^2] relative to the squared feedback
        command [m^2] (dimensionless).
    integral_weight
        ``q_z``: weight of the squared integrated error [m^2 s^2], [1/s^2].  ``sqrt(q_z/q_y)`` is
        roughly the angular frequency [rad/s] below which the integral dominates.
    noise_rms
        Sensor noise RMS [m]; the Kalman filter's measurement noise variance is its square.
    process_noise_rms
        RMS of a white disturbance added to the command [m] (model uncertainty); with
        ``noise_rms`` it sets the Kalman filter bandwidth.
    pade_order
        Order of the Padé approximant that replaces a transport delay of the nominal model.
    """

    error_weight: float = 1.0e5
    integral_weight: float = 1.0e8
    noise_rms: float = 2.0e-5
    process_noise_rms: float = 1.5e-4
    pade_order: int = 3

    def __post_init__(self) -> None:
        check_positive(self.error_weight, "LQG error_weight")
        check_nonnegative(self.integral_weight, "LQG integral_weight")
        check_positive(self.noise_rms, "LQG noise_rms")
        check_positive(self.process_noise_rms, "LQG process_noise_rms")
        check_positive_int(self.pade_order, "LQG pade_order")
        if self.pade_order > MAX_PADE_ORDER:
            raise ParameterError(
                f"LQG pade_order must be at most {MAX_PADE_ORDER} (higher Padé approximants "
                f"are ill-conditioned); got {self.pade_order!r}"
            )


@dataclass(frozen=True)
class LQGDesign:
    """Discrete model and gains of an LQG design (arrays are read-only by convention).

    Attributes
    ----------
    dt
        Time step [s].
    a, b, c
        Discrete model, shapes ``(n, n)``, ``(n,)``, ``(n,)`` (balanced state coordinates).
    gain_state, gain_integral
        LQR gains ``K_e`` (shape ``(n,)``) and ``k_z`` [1/s]: ``u_fb = -K_e e - k_z z``.
    filter_gain
        Current-estimator gain ``M`` (shape ``(n,)``).
    predictor_gain
        ``L = A M`` as returned by ``control.dlqe`` (shape ``(n,)``).
    covariance
        A-priori steady-state error covariance ``P`` (shape ``(n, n)``).
    static_gain
        Nominal DC gain ``G(0)`` (measured/command).
    weights
        The weights used.
    """

    dt: float
    a: FloatArray
    b: FloatArray
    c: FloatArray
    gain_state: FloatArray
    gain_integral: float
    filter_gain: FloatArray
    predictor_gain: FloatArray
    covariance: FloatArray
    static_gain: float
    weights: LQGWeights = field(default_factory=LQGWeights)

    @property
    def order(self) -> int:
        """Number of model states ``n``."""
        return self.a.shape[0]

    def kalman_filter(self) -> KalmanFilter:
        """The estimator as a ``filterpy.kalman.KalmanFilter`` at its steady state.

        ``F = A``, ``B``, ``H = C`` (column/row matrices: filterpy broadcasts a 1-D ``u``
        silently), ``Q = q B B'`` (process noise enters with the command), ``R = r`` and the
        a-priori covariance ``P`` of the DARE, which ``update`` + ``predict`` keep (so its gain
        ``K`` is the current-estimator gain ``M``); ``x = 0``.
        """
        from filterpy.kalman import KalmanFilter

        n = self.order
        kf = KalmanFilter(dim_x=n, dim_z=1, dim_u=1)
        kf.F = self.a.copy()
        kf.B = self.b.reshape(n, 1).copy()
        kf.H = self.c.reshape(1, n).copy()
        kf.Q = self.weights.process_noise_rms**2 * np.outer(self.b, self.b)
        kf.R = np.array([[self.weights.noise_rms**2]])
        kf.P = self.covariance.copy()
        kf.x = np.zeros((n, 1))
        return kf


def discrete_nominal(
    nominal: object, dt: float, delay: float = 0.0, pade_order: int = 3
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """ZOH discretisation ``(A, B, C)`` of the nominal model (balanced coordinates).

    A transport delay [s] is replaced by a Padé approximant of order ``pade_order`` in series.

    Parameters
    ----------
    nominal : control.TransferFunction or control.StateSpace
        Stable, strictly proper continuous-time SISO command-to-measured model [m/m].
    dt : float
        Loop step [s], > 0 (the ZOH sampling period).
    delay : float
        Transport delay of the nominal model [s], >= 0 (default 0).
    pade_order : int
        Order of the Padé approximant of the delay (default 3).

    Returns
    -------
    A : numpy.ndarray, shape (n, n)
        Discrete state matrix.
    B : numpy.ndarray, shape (n,)
        Input vector (command [m]).
    C : numpy.ndarray, shape (n,)
        Output vector (measured displacement [m]).
    """
    dt = check_positive(dt, "time step dt")
    delay = check_nonnegative(delay, "nominal delay")
    num, den = siso_polynomials(nominal)
    if num.size >= den.size:
        raise ParameterError(
            f"nominal model must be strictly proper (no direct feedthrough); got numerator "
            f"degree {num.size - 1} and denominator degree {den.size - 1}"
        )
    if delay > 0.0:
        pn, pd = control.pade(delay, pade_order)
        num, den = np.polymul(num, pn), np.polymul(den, pd)
    a_c, b_c, c_c, d_c = balanced_realization(num, den)
    sys_d = control.c2d(control.ss(a_c, b_c, c_c, d_c), dt, method="zoh")
    return (np.asarray(sys_d.A), np.asarray(sys_d.B)[:, 0], np.asarray(sys_d.C)[0, :])


def _design_failure(weights: LQGWeights, delay: float, why: object) -> str:
    return (
        f"LQG design failed ({why}): no stabilising Riccati solution for error_weight="
        f"{weights.error_weight!r}, integral_weight={weights.integral_weight!r}, noise_rms="
        f"{weights.noise_rms!r}, process_noise_rms={weights.process_noise_rms!r} and a nominal "
        f"delay of {delay!r} s"
    )


def design_lqg(
    nominal: object, dt: float, weights: LQGWeights | None = None, delay: float = 0.0
) -> LQGDesign:
    """LQR and Kalman gains for the nominal actuator model (see the module docstring).

    Parameters
    ----------
    nominal
        Continuous-time SISO model command [m] -> measured displacement [m] (python-control).
    dt
        Loop time step [s].
    weights
        Design weights; :class:`LQGWeights` defaults when omitted.
    delay
        Transport delay of the nominal model [s].
    """
    weights = LQGWeights() if weights is None else weights
    if not isinstance(weights, LQGWeights):
        raise ParameterError(f"weights must be an LQGWeights; got {weights!r}")
    a, b, c = discrete_nominal(nominal, dt, delay, weights.pade_order)
    n = a.shape[0]
    num, den = siso_polynomials(nominal)
    # augmented LQR model: [e; z], z_{k+1} = z_k - dt C (A e_k + B u_k)
    a_aug = np.zeros((n + 1, n + 1))
    a_aug[:n, :n] = a
    a_aug[n, :n] = -dt * (c @ a)
    a_aug[n, n] = 1.0
    b_aug = np.r_[b, -dt * (c @ b)][:, None]
    q_aug = np.zeros((n + 1, n + 1))
    q_aug[:n, :n] = weights.error_weight * np.outer(c, c)
    q_aug[n, n] = weights.integral_weight
    qn = np.array([[weights.process_noise_rms**2]])
    rn = np.array([[weights.noise_rms**2]])
    try:
        with np.errstate(all="ignore"):
            k_aug, _, _ = control.dlqr(a_aug, b_aug, q_aug, np.eye(1))
            # Kalman filter: process noise with the command (G = B), sensor noise R
            l_pred, p_prior, _ = control.dlqe(a, b[:, None], c[None, :], qn, rn)
    except (np.linalg.LinAlgError, ValueError) as exc:
        raise ParameterError(_design_failure(weights, delay, exc)) from None
    k_aug = np.asarray(k_aug)[0]
    p_prior = np.asarray(p_prior)
    if not (np.all(np.isfinite(k_aug)) and np.all(np.isfinite(p_prior))):
        raise ParameterError(_design_failure(weights, delay, "non-finite gains"))
    m_filter = p_prior @ c / (c @ p_prior @ c + rn[0, 0])
    return LQGDesign(
        dt=float(dt),
        a=a,
        b=b,
        c=c,
        gain_state=k_aug[:n],
        gain_integral=float(k_aug[n]),
        filter_gain=m_filter,
        predictor_gain=np.asarray(l_pred)[:, 0],
        covariance=p_prior,
        static_gain=dc_gain(num, den),
        weights=weights,
    )


@COMPENSATORS.register("lqg", LQGWeights)
class LQGCompensator(Compensator):
    """LQG tracking compensator: feedforward command plus LQG correction.

    ``u_k = u^ff_k + u^fb_k``.  With ``feedforward=None`` (kind ``"lqg"``) the feedforward is the
    static inverse ``r_{k+1}/G(0)`` and the LQG alone removes the error at low frequency; with a
    :class:`~controllers.model_based.feedforward.FeedforwardCompensator` it is the FF+LQG
    compensator of
    Phillips & Spencer (2013) (kind ``"ff_lqg"``, :mod:`controllers.model_based.ff_lqg`).

    Parameters
    ----------
    dt
        Loop time step [s]; must equal ``design.dt``.
    design
        Gains from :func:`design_lqg`.
    feedforward
        Model-based feedforward, or ``None`` for the static inverse.
    estimator
        ``"steady"``: the constant-gain hot path; ``"filterpy"``: the same estimator run by
        ``filterpy.kalman.KalmanFilter`` (:meth:`LQGDesign.kalman_filter`; always the Python
        path, ~20 us more per step on the reference VM).
    use_jit
        Step with the compiled kernel (:mod:`controllers.model_based._lqg_kernel`, one call per
        step);
        False runs the readable Python reference (same results to round-off, tested).  Ignored
        (False) with ``estimator="filterpy"``.
    """

    #: Declared channels of :meth:`state` / :meth:`write_channels`.
    CHANNELS: tuple[Channel, ...] = (
        Channel("feedforward", "m", "feedforward part of the command"),
        Channel("feedback", "m", "LQG feedback part of the command"),
        Channel("tracking_error", "m", "measured minus target at t_k"),
        Channel("predicted_error", "m", "Kalman prediction of the next tracking error"),
        Channel("integral_error", "m s", "integral of target minus measured"),
        Channel("innovation", "m", "Kalman innovation"),
    )

    @classmethod
    def from_options(
        cls,
        options: LQGWeights,
        *,
        dt: float,
        nominal: object = None,
        delay: float = 0.0,
        **_: object,
    ) -> LQGCompensator:
        """The ``lqg`` kind: LQG feedback alone, designed on the ``nominal`` model."""
        if nominal is None:
            raise ParameterError("compensator 'lqg' needs a nominal model; got None")
        return cls(dt, design_lqg(nominal, dt, options, delay))

    def __init__(
        self,
        dt: float,
        design: LQGDesign,
        feedforward: FeedforwardCompensator | None = None,
        *,
        estimator: str = "steady",
        use_jit: bool = True,
    ) -> None:
        super().__init__(dt)
        if estimator not in ("steady", "filterpy"):
            raise ParameterError(f"estimator must be 'steady' or 'filterpy'; got {estimator!r}")
        self.estimator = estimator
        if not isinstance(design, LQGDesign):
            raise ParameterError(f"design must be an LQGDesign; got {design!r}")
        if not np.isclose(design.dt, self.dt, rtol=1e-12, atol=0.0):
            raise ParameterError(
                f"LQG design time step must equal dt={self.dt!r}; got {design.dt!r}"
            )
        if feedforward is not None and not isinstance(feedforward, FeedforwardCompensator):
            raise ParameterError(
                f"feedforward must be a FeedforwardCompensator; got {feedforward!r}"
            )
        if feedforward is not None and not np.isclose(feedforward.dt, self.dt, rtol=1e-12):
            raise ParameterError(
                f"feedforward time step must equal dt={self.dt!r}; got {feedforward.dt!r}"
            )
        self.design = design
        self.feedforward = feedforward
        self._inv_gain = 1.0 / design.static_gain
        self.use_jit = bool(use_jit) and estimator == "steady"
        ff = feedforward
        self._p, self._s = _lqg_kernel.pack(
            design.dt,
            design.a,
            design.b,
            design.c,
            design.gain_state,
            design.gain_integral,
            design.filter_gain,
            self._inv_gain,
            None if ff is None else ff._c,
            False if ff is None else ff.hold_correction,
            0 if ff is None else ff._n_diff,
        )
        self._log = self._s[-len(_lqg_kernel.LOG_NAMES) :]
        self.reset()

    def _reset_impl(self) -> None:
        """Return to rest: error estimate, integral and previous target are zero."""
        self._e_hat = np.zeros(self.design.order)  # predicted error state e_{k|k-1}
        self._z = 0.0  # integrated tracking error [m s]
        self._r_prev = 0.0  # target for the current time t_k
        self._u_ff = 0.0
        self._u_fb = 0.0
        self._innovation = 0.0
        self._error = 0.0
        self._kf = self.design.kalman_filter() if self.estimator == "filterpy" else None
        if self.feedforward is not None:
            self.feedforward.reset()
        self._s[:] = 0.0
        if self.use_jit:  # compile before the clock starts
            _lqg_kernel.lqg_step(self._p, self._s.copy(), 0.0, 0.0, 0.0, 0.0)

    def _step_impl(self, target: Kinematics, measured: float) -> float:
        if self.use_jit:
            return float(
                _lqg_kernel.lqg_step(
                    self._p,
                    self._s,
                    target.displacement,
                    target.velocity,
                    target.acceleration,
                    measured,
                )
            )
        d = self.design
        # measurement update (current estimator) with the tracking error y_k - r_k
        self._error = measured - self._r_prev
        kf = self._kf
        if kf is None:
            self._innovation = float(self._error - d.c @ self._e_hat)
            e_now = self._e_hat + d.filter_gain * self._innovation
        else:
            kf.update(np.array([[self._error]]))
            self._innovation = float(kf.y[0, 0])
            e_now = kf.x[:, 0].copy()
        self._z -= d.dt * self._error  # integral of r_k - y_k
        # feedforward and LQR correction
        if self.feedforward is None:
            u_ff = target.displacement * self._inv_gain
        else:
            u_ff = self.feedforward.command(target)
        u_fb = float(-(d.gain_state @ e_now) - d.gain_integral * self._z)
        # time update to t_{k+1}
        if kf is None:
            self._e_hat = d.a @ e_now + d.b * u_fb
        else:
            kf.predict(u=np.array([[u_fb]]))
            self._e_hat = kf.x[:, 0].copy()
        self._r_prev = target.displacement
        self._u_ff, self._u_fb = u_ff, u_fb
        return u_ff + u_fb

    def compiled_step(self) -> CompiledStep | None:
        """This compensator for the loop's fused kernel (family ``"lqg"``: constants ``P``,
        state ``S`` of :func:`controllers.model_based._lqg_kernel.lqg_step` and the step
        count); None on the reference path or with the ``filterpy`` estimator."""
        if not self.use_jit:
            return None
        counter = np.array([float(self._steps)])

        def commit() -> None:
            self._steps = int(counter[0])

        return CompiledStep("lqg", (self._p,), (self._s, counter), commit)

    def channels(self) -> tuple[Channel, ...]:
        """:data:`CHANNELS` (the keys of :meth:`state`, with units)."""
        return self.CHANNELS

    def write_channels(self, out: FloatArray) -> None:
        """Write :meth:`state`'s values into ``out`` (one slice copy when compiled)."""
        if self.use_jit:
            out[:] = self._log
        else:
            out[:] = tuple(self.state().values())

    def state(self) -> dict[str, float]:
        """Feedforward and feedback parts [m], tracking error and its estimate [m], integral
        [m s], Kalman innovation [m]."""
        if self.use_jit:
            return dict(zip(_lqg_kernel.LOG_NAMES, self._log.tolist()))
        return {
            "feedforward": float(self._u_ff),
            "feedback": self._u_fb,
            "tracking_error": float(self._error),
            "predicted_error": float(self.design.c @ self._e_hat),
            "integral_error": float(self._z),
            "innovation": self._innovation,
        }
