"""Sub-commands that run campaigns of many runs on Dask: ``study``, ``sweep`` and ``compare``
(their shared options are :mod:`rths.commands._campaign`, which ``run --monte-carlo`` uses too)."""
