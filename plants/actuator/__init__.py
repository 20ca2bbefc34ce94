"""Servo-hydraulic transfer systems: the vRTHS benchmark plant with control--structure interaction
and a generic transfer function with delay and rate limit (:mod:`~.models`), their linear models
(:mod:`~.linear`), delay lines and rate limiters (:mod:`plants.lines`) and parameters/presets
(:mod:`~.parameters`).
"""

from plants.actuator.models import (
    BENCHMARK,
    HEAVY_INERTIAL_LOAD,
    MAX_SUBSTEP,
    MTS_IDENTIFIED,
    BenchmarkParameters,
    DelayLine,
    IdentifiedTransferFunction,
    RateLimiter,
    ServoHydraulicActuator,
    TransferFunctionActuator,
    default_substeps,
    delayed,
    rate_limited,
)

__all__ = [
    "BENCHMARK",
    "HEAVY_INERTIAL_LOAD",
    "MAX_SUBSTEP",
    "MTS_IDENTIFIED",
    "BenchmarkParameters",
    "DelayLine",
    "IdentifiedTransferFunction",
    "RateLimiter",
    "ServoHydraulicActuator",
    "TransferFunctionActuator",
    "default_substeps",
    "delayed",
    "rate_limited",
]
