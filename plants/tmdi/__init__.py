"""The S1 system: SDOF primary structure on HDRBs with a TMD grounded through an inerter.

:mod:`~.parameters` (S1 Table 1, §4.2), :mod:`~.kernel` (compiled S1 Eq.9-12 integrator),
:mod:`~.structure` (the monolithic model and S1 configurations), :mod:`~.substructure` (the
numerical side of the TMDI RTHS), :mod:`~.linear` (linear FRFs), :mod:`~.calibration` (the
uncontrolled PS calibration).
"""

from plants.tmdi.structure import (
    EQ7_QUANTITIES,
    HDRB_MODELS,
    PRIMARY_MASS,
    S1_UNCONTROLLED,
    SECONDARY_MASSES,
    IntegrationError,
    PSCalibration,
    TMDIParameters,
    TMDIResponse,
    TMDIStructure,
    UncontrolledObservations,
    calibrate_uncontrolled_ps,
    harmonic_balance_crest,
    linear_frf,
    linearised_frequencies,
    s1_configuration,
    stepped_sine_crest,
)
from plants.tmdi.substructure import NominalInerter, TMDISubstructure

__all__ = [
    "EQ7_QUANTITIES",
    "HDRB_MODELS",
    "PRIMARY_MASS",
    "S1_UNCONTROLLED",
    "SECONDARY_MASSES",
    "IntegrationError",
    "NominalInerter",
    "PSCalibration",
    "TMDIParameters",
    "TMDIResponse",
    "TMDIStructure",
    "TMDISubstructure",
    "UncontrolledObservations",
    "calibrate_uncontrolled_ps",
    "harmonic_balance_crest",
    "linear_frf",
    "linearised_frequencies",
    "s1_configuration",
    "stepped_sine_crest",
]
