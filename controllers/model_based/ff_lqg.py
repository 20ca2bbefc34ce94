"""The FF+LQG compensator of Phillips & Spencer (2013), used in the seed RTHS test (S0 §5.2).

Model-based feedforward (:mod:`controllers.model_based.feedforward`) for tracking plus LQG feedback
(:mod:`controllers.model_based.lqg`) for robustness to model error, noise and disturbances:
``u_k = u^ff_k + u^fb_k``.  This module only binds the two under the registry name ``"ff_lqg"``.
"""

from __future__ import annotations

from dataclasses import dataclass

from controllers.model_based.feedforward import FeedforwardCompensator, FeedforwardOptions
from controllers.model_based.lqg import LQGCompensator, LQGDesign, LQGWeights, design_lqg
from rths.core.errors import ParameterError
from rths.core.registry import COMPENSATORS

__all__ = ["FFLQGCompensator", "FFLQGOptions"]


@dataclass(frozen=True)
class FFLQGOptions(LQGWeights, FeedforwardOptions):
    """Options of the ``ff_lqg`` compensator kind: those of ``ff``
    (:class:`~controllers.model_based.feedforward.FeedforwardOptions`) and of ``lqg``
    (:class:`~controllers.model_based.lqg.LQGWeights`).

    The descriptions' first sentences repeat the parents' (``rths kinds`` shows the first sentence
    of the most derived class's; keep them in step).

    Parameters
    ----------
    order : int
        Order of the low-order model inverted (Phillips & Spencer: 3).  Range 1 .. 5, default 3.
    band_hz : tuple of (float, float)
        Band [Hz] over which a higher-order nominal model is fitted by the low-order one.
        Needs ``0 <= low < high``; default 0-20 Hz.
    hold_correction : bool
        Evaluate the inverse at mid-step to cancel the zero-order-hold lag.  Default True.
    error_weight : float
        ``q_y``: weight of the squared displacement error [m^2] relative to the squared feedback
        command [m^2] (dimensionless).  Range > 0, default 1e5.
    integral_weight : float
        ``q_z``: weight of the squared integrated error [m^2 s^2], [1/s^2].  ``sqrt(q_z/q_y)`` is
        roughly the angular frequency [rad/s] below which the integral dominates.  Range
        >= 0, default 1e8.
    noise_rms : float
        Sensor noise RMS [m]; the Kalman filter's measurement noise variance is its square.
        Range > 0, default 2e-5.
    process_noise_rms : float
        RMS of a white disturbance added to the command [m] (model uncertainty); with
        ``noise_rms`` it sets the Kalman filter bandwidth.  Range > 0, default 1.5e-4.
    pade_order : int
        Order of the Padé approximant that replaces a transport delay of the nominal model.
        Range 1 .. 10, default 3.
    """

    def __post_init__(self) -> None:
        FeedforwardOptions.__post_init__(self)
        LQGWeights.__post_init__(self)

    @property
    def weights(self) -> LQGWeights:
        """The LQG part."""
        return LQGWeights(**{name: getattr(self, name) for name in LQGWeights.__dataclass_fields__})


@COMPENSATORS.register("ff_lqg", FFLQGOptions)
class FFLQGCompensator(LQGCompensator):
    """Feedforward inverse of the low-order model plus LQG correction.

    Parameters
    ----------
    dt
        Loop time step [s].
    design
        LQG gains from :func:`controllers.model_based.lqg.design_lqg` (same ``dt``).
    feedforward
        The model-based feedforward (required).
    estimator
        ``"steady"`` (hot path) or ``"filterpy"``
        (:class:`~controllers.model_based.lqg.LQGCompensator`).
    use_jit
        Step with the compiled kernel (default) or the Python reference path.

    Notes
    -----
    :meth:`state` reports ``feedforward`` and ``feedback`` parts of the command [m], the
    integrated tracking error [m s], the Kalman innovation [m] and the model displacements.
    """

    @classmethod
    def from_options(  # type: ignore[override]
        cls,
        options: FFLQGOptions,
        *,
        dt: float,
        nominal: object = None,
        delay: float = 0.0,
        **_: object,
    ) -> FFLQGCompensator:
        """The ``ff_lqg`` kind (Phillips & Spencer 2013) on the ``nominal`` model."""
        if nominal is None:
            raise ParameterError("compensator 'ff_lqg' needs a nominal model; got None")
        feedforward = FeedforwardCompensator.from_options(
            options, dt=dt, nominal=nominal, delay=delay
        )
        return cls(dt, design_lqg(nominal, dt, options.weights, delay), feedforward)

    def __init__(
        self,
        dt: float,
        design: LQGDesign,
        feedforward: FeedforwardCompensator,
        *,
        estimator: str = "steady",
        use_jit: bool = True,
    ) -> None:
        if feedforward is None:
            raise ParameterError("FF+LQG needs a feedforward compensator; got None")
        super().__init__(dt, design, feedforward, estimator=estimator, use_jit=use_jit)
