"""Servo-hydraulic transfer systems: the vRTHS benchmark plant with control--structure interaction
(:mod:`~.servo_hydraulic`) and a generic transfer function (:mod:`~.transfer_function`), their
kinds' options (:mod:`~.options`), their linear models
(:mod:`~.linear`), delay lines and rate limiters (:mod:`plants.lines`) and parameters/presets
(:mod:`~.parameters`).
"""

from plants.actuator.parameters import (
    BENCHMARK,
    HEAVY_INERTIAL_LOAD,
    MTS_IDENTIFIED,
    BenchmarkParameters,
    IdentifiedTransferFunction,
)
from plants.actuator.servo_hydraulic import MAX_SUBSTEP, ServoHydraulicActuator, default_substeps
from plants.actuator.transfer_function import TransferFunctionActuator
from plants.lines import DelayLine, RateLimiter, delayed, rate_limited

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
