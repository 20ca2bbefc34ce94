"""Models of physical things: the stay cable, inertial mass dampers, the servo-hydraulic actuator,
the rack-and-pinion inerter, HDRB isolators and the TMDI-equipped SDOF.

Plants know nothing of zenoh, MCAP or the loop; they share the small interfaces of
:mod:`plants.base`.
"""

from plants.actuator.base import Actuator
from plants.base import Kinematics, Specimen, Substructure, drive

__all__ = ["Actuator", "Kinematics", "Specimen", "Substructure", "drive"]
