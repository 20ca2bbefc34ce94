"""Analysis of runs: tracking metrics (:mod:`~rths.metrics`), the report of a log
(:mod:`~rths.analysis.report`) and Monte-Carlo campaigns (:mod:`~rths.analysis.montecarlo`).

May import: sessions and everything below them; never an experiment or a command.
"""
