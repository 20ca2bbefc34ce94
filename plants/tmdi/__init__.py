"""The S1 system: SDOF primary structure on HDRBs with a TMD grounded through an inerter.

:mod:`~.parameters` (S1 Table 1, §4.2), :mod:`~.integration` (compiled S1 Eq.9-12 integrator),
:mod:`~.structure` (the monolithic model and S1 configurations), :mod:`~.substructure` (the
numerical side of the TMDI RTHS), :mod:`~.linear` (linear FRFs), :mod:`~.engine` (the shared
stepping), :mod:`~.bearing` (the HDRB as a specimen).  The uncontrolled PS calibration on S1's
numbers is an experiment: :mod:`rths.experiments.s1_shake_table.calibration`.
"""

from plants.tmdi.structure import (
    EQ7_QUANTITIES,
    HDRB_MODELS,
    PRIMARY_MASS,
    SECONDARY_MASSES,
    IntegrationError,
    TMDIParameters,
    TMDIResponse,
    TMDIStructure,
    linear_frf,
    linearised_frequencies,
    s1_configuration,
)
from plants.tmdi.substructure import NominalInerter, TMDISubstructure

__all__ = [
    "EQ7_QUANTITIES",
    "HDRB_MODELS",
    "PRIMARY_MASS",
    "SECONDARY_MASSES",
    "IntegrationError",
    "NominalInerter",
    "TMDIParameters",
    "TMDIResponse",
    "TMDIStructure",
    "TMDISubstructure",
    "linear_frf",
    "linearised_frequencies",
    "s1_configuration",
]
