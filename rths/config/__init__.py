"""Configuration: scenario files parsed strictly (:mod:`~rths.config.scenario`, over the TOML
reader :mod:`~rths.config.toml`) and built into plants, lab and compensator
(:mod:`~rths.config.build`) through the registries of kinds.

May import: :mod:`rths.core`, :mod:`rths.runtime`, ``plants`` and ``controllers``.
"""
