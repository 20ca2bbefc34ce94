"""Execute a campaign as a ``dask.distributed`` task graph and stream its rows into a table.

Every run not yet in the table is executed by :func:`attempt` of the campaign's task on the
run's payload, in a task of one run or -- for short runs -- a few (:func:`attempt_batch`,
:func:`batch_size`), each run still its own row.  Runs are independent, so the graph is flat;
tasks are submitted two per worker ahead of the workers, results arrive in completion order
(``as_completed``) and each row is added to the :class:`~rths.campaign.table.ResultTable` at
once, which writes itself every couple of seconds: an interrupted campaign keeps what it
finished, and the next invocation skips those runs.

Where (:class:`~rths.campaign.cluster.Cluster`):

* default -- an embedded ``LocalCluster`` with one single-threaded worker process per core (runs
  are CPU-bound Python: processes, not threads, use the cores), quiet
  (:data:`~rths.campaign.cluster.QUIET_CONFIG`), started and closed here;
* ``scheduler="tcp://HOST:8786"`` -- an existing cluster (``dask scheduler`` on one host,
  ``dask worker tcp://HOST:8786`` on each node, every node with this package installed).  The
  campaign is the same: payloads carry everything a run needs (the scenario text, not its path),
  so workers need no shared file system.

A run that raises becomes a row with ``status = "error"`` and the exception in ``error``; a
worker that dies (e.g. killed for memory) fails only the run it held, also as a row (the runs of
a task of several that fails so are run again one task each).

Every run computes with one BLAS/OpenMP thread (:func:`attempt`, threadpoolctl), wherever it
runs: a multi-threaded BLAS sums a dot product in a thread-count-dependent order (different last
bits, e.g. in the vRTHS J1 correlations), and on a busy 2-core machine its spinning threads made
those 150 dot products of 168k samples cost 2 s instead of 0.04 s.  Dask's worker processes
already start with ``OPENBLAS_NUM_THREADS=1``; threads of this process and runs without Dask get
the same limit here.
"""

from __future__ import annotations

import sys
import time
import uuid
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

from rths.campaign.cluster import Cluster, client_for, default_workers
from rths.campaign.runs import Campaign, Run, Task
from rths.campaign.table import ResultTable, Row
from rths.core.errors import check_positive_int

__all__ = [
    "MAX_BATCH",
    "TASK_TARGET",
    "CampaignStats",
    "Cluster",
    "attempt",
    "attempt_batch",
    "batch_size",
    "client_for",
    "default_workers",
    "execute",
    "map_tasks",
    "one_blas_thread",
]

T = TypeVar("T")
R = TypeVar("R")

#: Wall time a task of several runs aims at [s] (:func:`batch_size`): long enough that the
#: scheduler's cost per task (1.9-3.1 ms measured on an embedded cluster) is a fraction of a
#: percent, short enough that rows still stream every couple of seconds per worker and an
#: interruption loses little.
TASK_TARGET = 2.0
#: Most runs in one task.
MAX_BATCH = 16


@dataclass
class CampaignStats:
    """What an :func:`execute` call did.

    Attributes
    ----------
    total
        Runs in the campaign.
    skipped
        Runs already in the table (resumed).
    ran
        Runs executed now.
    failed
        Of those, rows with ``status = "error"``.
    workers
        Worker threads the cluster had when the campaign started (0 if none had joined).
    startup
        Time to start (or reach) the cluster [s].
    wall
        Time from the first submission to the last row [s].
    busy
        Sum of the runs' own wall times [s] (``wall_s``).
    cpu
        Sum of the runs' CPU times [s] (``cpu_s``).
    tasks
        Tasks the runs were grouped in (:func:`batch_size`).
    shutdown
        Time to close the embedded cluster (or the client) after the last row [s].
    """

    total: int = 0
    skipped: int = 0
    ran: int = 0
    failed: int = 0
    workers: int = 0
    startup: float = 0.0
    wall: float = 0.0
    busy: float = 0.0
    cpu: float = 0.0
    tasks: int = 0
    shutdown: float = 0.0

    @property
    def overhead_per_run(self) -> float:
        """Worker time not spent in runs, per run [s]: ``(wall * workers - busy) / ran``
        (scheduling, serialisation, transfer, idle workers at the end)."""
        if self.ran == 0 or self.workers == 0:
            return float("nan")
        return (self.wall * self.workers - self.busy) / self.ran


_ONE_BLAS_THREAD = False


def one_blas_thread() -> None:
    """Limit BLAS and OpenMP to one thread in this process (once; the limit stays): the same
    bits on every worker, and one run per core."""
    global _ONE_BLAS_THREAD
    if not _ONE_BLAS_THREAD:
        from threadpoolctl import threadpool_limits

        threadpool_limits(1)
        _ONE_BLAS_THREAD = True


def attempt(task: Task, payload: Any) -> Row:
    """Run ``task(payload)`` on a worker (one BLAS thread, :func:`one_blas_thread`): its row plus
    ``status``, ``error``, ``wall_s`` (wall time [s]), ``cpu_s`` (CPU time of the worker thread
    [s]: the run's cost whatever else loads the machine) and ``worker``; an exception becomes
    ``status = "error"`` (never propagates).

    Parameters
    ----------
    task
        The campaign's task.
    payload
        The run's payload.
    """
    one_blas_thread()
    start, cpu = time.perf_counter(), time.thread_time()
    try:
        row = dict(task(payload))
        status = row.pop("status", "ok")
        error = None
    except Exception as exc:  # a failed run is a row, whatever failed
        row, status, error = {}, "error", f"{type(exc).__name__}: {exc}"
    row.update(status=status, error=error, wall_s=time.perf_counter() - start)
    row.update(cpu_s=time.thread_time() - cpu, worker=_worker())
    return row


def _worker() -> str:
    try:
        from distributed import get_worker

        w = get_worker()
        return str(w.name if w.name is not None else w.address)
    except (ImportError, ValueError):
        return "local"


def batch_size(mean_run: float | None, remaining: int, workers: int) -> int:
    """Runs per task: as many as fill :data:`TASK_TARGET` seconds at the mean run time so far
    (at most :data:`MAX_BATCH`), but at most ``remaining / (2 workers)`` so that the campaign
    ends on single runs (no worker waits on another's long batch); 1 until a run has finished.

    Parameters
    ----------
    mean_run
        Mean wall time of the runs finished so far [s]; None: none yet.
    remaining
        Runs not yet submitted.
    workers
        Worker threads of the cluster.
    """
    if mean_run is None or remaining <= 0:
        return 1
    by_cost = int(TASK_TARGET / mean_run) if mean_run > 0 else MAX_BATCH
    return max(1, min(MAX_BATCH, by_cost, remaining // (2 * max(workers, 1))))


def attempt_batch(task: Task, payloads: Sequence[Any]) -> list[Row]:
    """:func:`attempt` of each payload in turn, on one worker (one task of the graph).

    Parameters
    ----------
    task
        The campaign's task.
    payloads
        The batch's payloads.
    """
    return [attempt(task, payload) for payload in payloads]


def execute(
    campaign: Campaign,
    table: ResultTable,
    cluster: Cluster | None = None,
    *,
    progress: bool = True,
    retry_failed: bool = False,
    on_row: Callable[[Row], None] | None = None,
    batch: int | None = None,
) -> CampaignStats:
    """Run every run of ``campaign`` whose key ``table`` does not hold; rows go into ``table``.

    Runs are submitted a few tasks ahead of the workers (two per worker thread), so the
    scheduler always has the next one at hand; a task holds :func:`batch_size` runs (short runs
    share a task, which pays the scheduler's per-task cost once), each with its own row.

    Parameters
    ----------
    campaign
        The runs and their task.
    table
        Receives one row per run as it finishes (and skips the runs it already holds).
    cluster
        Where to run (default: an embedded cluster sized to the machine).
    progress
        A progress bar over runs on stderr (shown only when stderr is a terminal).
    retry_failed
        Run again the runs whose rows say ``status = "error"``.
    on_row
        Called with each new row, in completion order.
    batch
        Runs per task, fixed (1: one task per run); None: :func:`batch_size`.
    """
    where = cluster or Cluster()
    stats = CampaignStats(total=len(campaign))
    if retry_failed:
        rows = table.rows([run.key for run in campaign.runs])
        table.discard(str(row["run"]) for row in rows if row.get("status") == "error")
    pending = deque((i, r) for i, r in enumerate(campaign.runs) if r.key not in table)
    stats.skipped = stats.total - len(pending)
    table.reindex({r.key: i for i, r in enumerate(campaign.runs) if r.key in table})
    if not pending:
        table.flush()
        return stats
    if batch is not None:
        check_positive_int(batch, "runs per task")
    from distributed import as_completed
    from tqdm import tqdm

    start = time.perf_counter()
    bar = tqdm(
        total=len(pending),
        unit="run",
        desc=campaign.name,
        file=sys.stderr,
        disable=None if progress else True,  # None: off when stderr is not a terminal
        leave=False,
        dynamic_ncols=True,
    )
    try:
        with client_for(where) as client:
            stats.workers = sum(client.nthreads().values())
            stats.startup = time.perf_counter() - start
            token = uuid.uuid4().hex[:8]
            held: dict[Any, list[tuple[int, Run]]] = {}  # future -> its runs
            alone: deque[tuple[int, Run]] = deque()
            done = as_completed()

            def submit() -> None:
                if alone:  # runs of a task whose worker died: one task each, to find the culprit
                    runs = [alone.popleft()]
                else:
                    mean = stats.busy / stats.ran if stats.ran else None
                    n = batch or batch_size(mean, len(pending), stats.workers)
                    runs = [pending.popleft() for _ in range(min(n, len(pending)))]
                payloads = [run.payload for _, run in runs]
                key = f"runs-{runs[0][1].key}-{len(runs)}-{token}"
                future = client.submit(attempt_batch, campaign.task, payloads, key=key, pure=False)
                held[future] = runs
                done.add(future)

            ahead, counted = 2 * max(stats.workers, 1), time.perf_counter()
            while (pending or alone) and len(held) < ahead:
                submit()
            t0 = time.perf_counter()
            try:
                for future in done:
                    runs = held.pop(future)
                    try:
                        parts: list[Row] = future.result()
                    except Exception as exc:  # e.g. KilledWorker: a row per run it held
                        if len(runs) > 1:  # which run killed it? each again on its own
                            alone.extend(runs)
                            parts, runs = [], []
                        else:
                            parts = [{"status": "error", "error": f"{type(exc).__name__}: {exc}"}]
                    for (i, run), part in zip(runs, parts, strict=True):
                        row: Row = {"run": run.key, "index": i, **run.inputs, **part}
                        _record(stats, table, row)
                        bar.update()
                        if stats.failed:
                            bar.set_postfix_str(f"{stats.failed} failed")
                        if on_row is not None:
                            on_row(row)
                    if time.perf_counter() - counted > 2.0:  # workers may join or leave
                        ahead, counted = (
                            2 * max(sum(client.nthreads().values()), 1),
                            time.perf_counter(),
                        )
                    while (pending or alone) and len(held) < ahead:
                        submit()
                    stats.tasks += 1
            finally:  # closing the client releases what is still queued (e.g. on Ctrl-C)
                stats.wall = time.perf_counter() - t0
            closing = time.perf_counter()
        stats.shutdown = time.perf_counter() - closing
    finally:
        bar.close()
        table.flush()
    return stats


def _record(stats: CampaignStats, table: ResultTable, row: Row) -> None:
    """Add ``row`` to ``table`` and count it in ``stats``."""
    table.add(row)
    stats.ran += 1
    stats.failed += row.get("status") == "error"
    wall = row.get("wall_s")
    stats.busy += wall if isinstance(wall, float) else 0.0
    cpu = row.get("cpu_s")
    stats.cpu += cpu if isinstance(cpu, float) else 0.0


def map_tasks(
    task: Callable[[T], R],
    payloads: Sequence[T],
    cluster: Cluster | None = None,
    *,
    progress: bool = True,
    desc: str = "tasks",
) -> list[R]:
    """``[task(p) for p in payloads]`` on a cluster, for work whose results are not table rows
    (e.g. the FRFs of ``rths sweep``): results in payload order; the first task that raises
    raises here (no table, no resume).

    Parameters
    ----------
    task
        Top-level function (importable by name on the workers).
    payloads
        Its arguments, one task each.
    cluster
        Where to run (default: an embedded cluster sized to the machine).
    progress
        A progress bar over tasks on stderr (shown only when stderr is a terminal).
    desc
        The progress bar's label.
    """
    from distributed import as_completed
    from tqdm import tqdm

    if not payloads:
        return []
    with (
        client_for(cluster or Cluster()) as client,
        tqdm(
            total=len(payloads),
            unit="task",
            desc=desc,
            file=sys.stderr,
            disable=None if progress else True,
            leave=False,
        ) as bar,
    ):
        futures = client.map(task, list(payloads), pure=False)
        for _ in as_completed(futures):
            bar.update()
        results: list[R] = client.gather(futures)
    return results
