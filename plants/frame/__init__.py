"""The vRTHS benchmark's reference structure (Silva et al. 2020) for RTHS.

A 3-storey steel frame condensed to one lateral DOF per floor, in four partitioning cases
(:mod:`plants.frame.cases`); the benchmark's ground motions, three records read from the user's
copy of the companion package and a chirp (:mod:`plants.frame.ground_motion`); the numerical
substructure left when the first floor's spring-mass-dashpot is tested physically, and the
unpartitioned reference response (:mod:`plants.frame.substructure`).  Imports only ``plants`` and
``rths.core.errors``.
"""

from plants.frame.cases import (
    CASES,
    BenchmarkCase,
    FrameGeometry,
    benchmark_case,
    condensed_stiffness,
    modal_damping,
    natural_frequencies,
)
from plants.frame.ground_motion import (
    DEFAULT_INTENSITY,
    GROUND_MOTIONS,
    PACKAGE_ENV,
    ChirpMotion,
    GroundMotion,
    RecordedMotion,
    ground_motion,
    load_record,
    package_dir,
)
from plants.frame.substructure import FrameSubstructure, numerical_matrices, reference_response

__all__ = [
    "CASES",
    "DEFAULT_INTENSITY",
    "GROUND_MOTIONS",
    "PACKAGE_ENV",
    "BenchmarkCase",
    "ChirpMotion",
    "FrameGeometry",
    "FrameSubstructure",
    "GroundMotion",
    "RecordedMotion",
    "benchmark_case",
    "condensed_stiffness",
    "ground_motion",
    "load_record",
    "modal_damping",
    "natural_frequencies",
    "numerical_matrices",
    "package_dir",
    "reference_response",
]
