"""Analysis of runs: tracking metrics (:mod:`~rths.metrics`), the report of a log
(:mod:`~rths.analysis.report`), Monte-Carlo campaigns (:mod:`~rths.analysis.montecarlo`) and
parameter studies (:mod:`~rths.analysis.study`, its plan :mod:`~rths.analysis.study_plan`, its
figures :mod:`~rths.analysis.study_figures`).

May import: campaigns, sessions and everything below them; never an experiment or a command.
"""
