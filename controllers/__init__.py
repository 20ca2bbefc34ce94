"""Delay/dynamics compensators for the RTHS loop: model-based feedforward + LQG
(Phillips & Spencer 2013) and the baselines (none, polynomial extrapolation, adaptive time series).
"""

from controllers.base import Compensator

__all__ = ["Compensator"]
