"""Fill the registries of kinds (:mod:`rths.core.registry`) by importing the modules that define
them.

Every module of the ``plants`` and ``controllers`` packages is imported (so a new damper model is
discovered by being there), then every module named in the ``rths.kinds`` entry-point group, so a
lab's own package can add kinds without touching this project::

    # the lab's pyproject.toml
    [project.entry-points."rths.kinds"]
    my_dampers = "my_lab.dampers"
"""

from __future__ import annotations

import importlib
import pkgutil
from importlib.metadata import entry_points

from rths.core.errors import ConfigError
from rths.core.registry import FAMILIES, Registry

__all__ = ["PACKAGES", "load_kinds", "registry"]

#: Packages whose every module is imported to register kinds.
PACKAGES: tuple[str, ...] = ("plants", "controllers")

_loaded = False


def load_kinds() -> None:
    """Import every module that may register a kind (once per process).

    Raises
    ------
    ConfigError
        If an entry-point module of the ``rths.kinds`` group cannot be imported.
    """
    global _loaded
    if _loaded:
        return
    for name in PACKAGES:
        package = importlib.import_module(name)
        for info in pkgutil.walk_packages(package.__path__, prefix=f"{name}."):
            importlib.import_module(info.name)
    for point in entry_points(group="rths.kinds"):
        try:
            importlib.import_module(point.value)
        except ImportError as exc:
            raise ConfigError(
                f"entry point {point.name!r} of group 'rths.kinds' names module {point.value!r}, "
                f"which cannot be imported: {exc}"
            ) from None
    _loaded = True


def registry(family: str) -> Registry:
    """The filled registry of ``family`` (``"substructure"``, ``"specimen"``, ``"actuator"``,
    ``"compensator"``).

    Parameters
    ----------
    family : str
        ``"substructure"``, ``"specimen"``, ``"actuator"`` or ``"compensator"``.
    """
    load_kinds()
    return FAMILIES[family]
