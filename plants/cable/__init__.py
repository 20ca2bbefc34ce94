"""The stay cable (S0 §5): taut-string finite elements with a node at the damper
(:mod:`~.fe`), Newmark average acceleration (:mod:`~.newmark`), the nominal interface device
condensed into the solve (:mod:`~.device`), the :class:`~plants.cable.model.Cable` substructure
(:mod:`~.model`), its properties and S0 Eq.22-23 (:mod:`~.properties`), and the exact cable--damper
frequency equation (:mod:`~.frequency_equation`).
"""

from plants.cable.model import (
    Cable,
    CableProperties,
    DistributedLoad,
    FEMatrices,
    InterfaceDevice,
    PointDamper,
    RayleighDamping,
    elements_for,
    fe_matrices,
    max_element_size,
    normalised_damper,
    normalised_stiffness,
    physical_damper,
    physical_stiffness,
)

__all__ = [
    "Cable",
    "CableProperties",
    "DistributedLoad",
    "FEMatrices",
    "InterfaceDevice",
    "PointDamper",
    "RayleighDamping",
    "elements_for",
    "fe_matrices",
    "max_element_size",
    "normalised_damper",
    "normalised_stiffness",
    "physical_damper",
    "physical_stiffness",
]
