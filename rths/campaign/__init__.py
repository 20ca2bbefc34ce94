"""Campaigns: many independent runs as a Dask task graph, results streamed into one table.

A campaign (:class:`~rths.campaign.runs.Campaign`) is a list of independent runs -- a scenario
with overrides and a seed (:mod:`~rths.campaign.scenario`), or any picklable payload and a
top-level task function -- executed by :func:`~rths.campaign.executor.execute` on an embedded,
quiet ``dask.distributed`` ``LocalCluster`` sized to the machine, or on a cluster given by its
scheduler address (``tcp://HOST:8786``) unchanged (:mod:`~rths.campaign.cluster`); short runs
share a task (:func:`~rths.campaign.executor.batch_size`), each still its own row.  Every
finished run becomes one row of a :class:`~rths.campaign.table.ResultTable` (Parquet or CSV) as
it arrives; rows already in the
table are skipped on the next invocation (resume), and a run that raises becomes a row with
``status = "error"``, never a crash.  Results depend only on each run's inputs and seed, so the
table is the same on 1 worker, 2 workers or a cluster (:func:`~rths.campaign.table.digest`).

Used by Monte Carlo (:mod:`rths.analysis.montecarlo`), parameter studies
(:mod:`rths.analysis.study`), ``rths sweep``'s PGA grid and the diagnosis's blind suites
(``tools/score_diagnosis.py``, task :func:`rths.diagnose.suite.diagnose_case`).

May import: sessions and everything below them; never analysis, diagnose, an experiment or a
command.
"""

from rths.campaign.executor import CampaignStats, Cluster, execute, map_tasks
from rths.campaign.runs import Campaign, Run
from rths.campaign.table import ResultTable, digest

__all__ = [
    "Campaign",
    "CampaignStats",
    "Cluster",
    "ResultTable",
    "Run",
    "digest",
    "execute",
    "map_tasks",
]
