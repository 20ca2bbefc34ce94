"""Real-time hybrid simulation (RTHS) framework.

The framework pairs a numerical substructure (:mod:`plants.cable.model`,
:mod:`plants.tmdi.structure`) with an emulated physical specimen behind a servo-hydraulic actuator
(:mod:`plants.imd.models`,
:mod:`plants.actuator`), closes the loop with a compensator (:mod:`controllers`), streams the
signals over Eclipse Zenoh and records them to MCAP.  Everything is in SI units.

This package is deliberately light to import: sub-modules are imported where they are used.
"""

from importlib.metadata import PackageNotFoundError, version

__all__ = ["__version__"]

try:
    __version__: str = version("rths")
except PackageNotFoundError:  # running from a source tree without an install
    __version__ = "0.0.0+unknown"
