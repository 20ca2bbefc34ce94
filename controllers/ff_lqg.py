"""The FF+LQG compensator of Phillips & Spencer (2013), used in the seed RTHS test (S0 §5.2).

Model-based feedforward (:mod:`controllers.feedforward`) for tracking plus LQG feedback
(:mod:`controllers.lqg`) for robustness to model error, noise and disturbances:
``u_k = u^ff_k + u^fb_k``.  This module only binds the two under the registry name ``"ff_lqg"``.
"""

from __future__ import annotations

from controllers.feedforward import FeedforwardCompensator
from controllers.lqg import LQGCompensator, LQGDesign
from rths.core.errors import ParameterError

__all__ = ["FFLQGCompensator"]


class FFLQGCompensator(LQGCompensator):
    """Feedforward inverse of the low-order model plus LQG correction.

    Parameters
    ----------
    dt
        Loop time step [s].
    design
        LQG gains from :func:`controllers.lqg.design_lqg` (same ``dt``).
    feedforward
        The model-based feedforward (required).

    Notes
    -----
    :meth:`state` reports ``feedforward`` and ``feedback`` parts of the command [m], the
    integrated tracking error [m s], the Kalman innovation [m] and the model displacements.
    """

    kind = "ff_lqg"

    def __init__(self, dt: float, design: LQGDesign, feedforward: FeedforwardCompensator) -> None:
        if feedforward is None:
            raise ParameterError("FF+LQG needs a feedforward compensator; got None")
        super().__init__(dt, design, feedforward)
