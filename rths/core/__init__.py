"""The foundation: what every other part of the project may import.

Holds the exception hierarchy and validators (:mod:`rths.core.errors`), the shared value types
(:mod:`rths.core.kinematics`, :mod:`rths.core.scaling`), the per-sample filters
(:mod:`rths.core.filters`) and the registries of kinds (:mod:`rths.core.registry`).

May import: the standard library, numpy and scipy only.  ``plants`` and ``controllers`` import
nothing else from ``rths`` (enforced by the import-linter contracts in ``pyproject.toml``).
"""
