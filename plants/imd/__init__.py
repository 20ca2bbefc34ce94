"""Inertial mass dampers (S0): the simplified device of S0 Eq.1 and the device with internal
stiffness of S0 Eq.12 (:mod:`~.models`), their parameters and presets (:mod:`~.parameters`), the
amplitude tracker of S0 Eq.17-18 (:mod:`~.amplitude`) and the compiled flywheel kernel
(:mod:`~.kernels`).
"""

from plants.imd.models import (
    CONTACT_FREQUENCY_HZ,
    MAX_STEP_PHASE,
    AmplitudeDamping,
    IMDParameters,
    InternalStiffnessIMD,
    SimplifiedIMD,
    ball_screw_stiffness,
    damping_from_ratio,
    imd,
    imd_from_parameters,
    screw_series_stiffness,
)

__all__ = [
    "CONTACT_FREQUENCY_HZ",
    "MAX_STEP_PHASE",
    "AmplitudeDamping",
    "IMDParameters",
    "InternalStiffnessIMD",
    "SimplifiedIMD",
    "ball_screw_stiffness",
    "damping_from_ratio",
    "imd",
    "imd_from_parameters",
    "screw_series_stiffness",
]
