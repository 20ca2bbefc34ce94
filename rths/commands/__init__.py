"""Sub-commands of the ``rths`` CLI, one module each (discovered by :mod:`rths.cli`)."""
