"""Execute a campaign as a ``dask.distributed`` task graph and stream its rows into a table.

Every run not yet in the table becomes one task (:func:`attempt` of the campaign's task on the
run's payload).  Runs are independent, so the graph is flat; results arrive in completion order
(``as_completed``) and each is added to the :class:`~rths.campaign.table.ResultTable` at once,
which writes itself every couple of seconds: an interrupted campaign keeps what it finished, and
the next invocation skips those runs.

Where (:class:`Cluster`):

* default -- an embedded ``LocalCluster`` with one single-threaded worker process per core (runs
  are CPU-bound Python: processes, not threads, use the cores), started and closed here;
* ``scheduler="tcp://HOST:8786"`` -- an existing cluster (``dask scheduler`` on one host,
  ``dask worker tcp://HOST:8786`` on each node, every node with this package installed).  The
  campaign is the same: payloads carry everything a run needs (the scenario text, not its path),
  so workers need no shared file system.

A run that raises becomes a row with ``status = "error"`` and the exception in ``error``; a
worker that dies (e.g. killed for memory) fails only the runs it held, also as rows.

Every run computes with one BLAS/OpenMP thread (:func:`attempt`, threadpoolctl), wherever it
runs: a multi-threaded BLAS sums a dot product in a thread-count-dependent order (different last
bits, e.g. in the vRTHS J1 correlations), and on a busy 2-core machine its spinning threads made
those 150 dot products of 168k samples cost 2 s instead of 0.04 s.  Dask's worker processes
already start with ``OPENBLAS_NUM_THREADS=1``; threads of this process and runs without Dask get
the same limit here.
"""

from __future__ import annotations

import logging
import os
import re
import sys
import time
import uuid
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, TypeVar

from rths.campaign.runs import Campaign, Task
from rths.campaign.table import ResultTable, Row
from rths.core.errors import ConfigError, check_positive_int

if TYPE_CHECKING:
    from distributed import Client

__all__ = [
    "CampaignStats",
    "Cluster",
    "attempt",
    "client_for",
    "default_workers",
    "execute",
    "map_tasks",
    "one_blas_thread",
]

T = TypeVar("T")
R = TypeVar("R")

_ADDRESS = re.compile(r"^(tcp|tls|ucx|inproc)://[^\s/]+$")


def default_workers() -> int:
    """Cores this process may use (the embedded cluster's default size)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


@dataclass(frozen=True)
class Cluster:
    """Where a campaign runs.

    Parameters
    ----------
    scheduler
        Address of an existing Dask scheduler (``tcp://HOST:8786``); None: an embedded
        ``LocalCluster``.
    workers
        Worker count of the embedded cluster (default: :func:`default_workers`); ignored with a
        scheduler.
    processes
        Embedded workers are processes (True, the default) or threads of this process (False:
        quick to start, for tests; the GIL then serialises pure-Python runs).
    connect_timeout
        How long to wait for a scheduler [s].
    """

    scheduler: str | None = None
    workers: int | None = None
    processes: bool = True
    connect_timeout: float = 10.0

    def __post_init__(self) -> None:
        if self.scheduler is not None and not _ADDRESS.match(self.scheduler):
            raise ConfigError(
                f"scheduler address must look like tcp://HOST:8786; got {self.scheduler!r}"
            )
        if self.workers is not None:
            check_positive_int(self.workers, "number of workers")

    def describe(self) -> str:
        """One phrase for messages: ``2 local worker processes`` or the scheduler address."""
        if self.scheduler:
            return f"scheduler {self.scheduler}"
        n = self.workers or default_workers()
        kind = "processes" if self.processes else "threads"
        return f"{n} local worker {kind}"


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


@contextmanager
def client_for(cluster: Cluster) -> Iterator[Client]:
    """A Dask client (an embedded cluster is started and closed with it).

    Parameters
    ----------
    cluster
        Where: a scheduler address or the embedded cluster's size and kind.
    """
    from distributed import Client, LocalCluster

    if cluster.scheduler is not None:
        try:
            client = Client(cluster.scheduler, timeout=cluster.connect_timeout)
        except (OSError, TimeoutError) as exc:
            raise ConfigError(
                f"cannot reach the Dask scheduler at {cluster.scheduler}: {exc}"
            ) from None
        with client:
            yield client
        return
    local = LocalCluster(
        n_workers=cluster.workers or default_workers(),
        threads_per_worker=1,
        processes=cluster.processes,
        dashboard_address=":0",  # any free port: never collides with another cluster's 8787
        silence_logs=logging.CRITICAL,
    )
    with local, Client(local) as client:
        yield client


def execute(
    campaign: Campaign,
    table: ResultTable,
    cluster: Cluster | None = None,
    *,
    progress: bool = True,
    retry_failed: bool = False,
    on_row: Callable[[Row], None] | None = None,
) -> CampaignStats:
    """Run every run of ``campaign`` whose key ``table`` does not hold; rows go into ``table``.

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
    """
    where = cluster or Cluster()
    stats = CampaignStats(total=len(campaign))
    if retry_failed:
        rows = table.rows([run.key for run in campaign.runs])
        table.discard(str(row["run"]) for row in rows if row.get("status") == "error")
    pending = [(i, r) for i, r in enumerate(campaign.runs) if r.key not in table]
    stats.skipped = stats.total - len(pending)
    table.reindex({r.key: i for i, r in enumerate(campaign.runs) if r.key in table})
    if not pending:
        table.flush()
        return stats
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
            futures = {
                client.submit(
                    attempt, campaign.task, run.payload, key=f"run-{run.key}-{token}", pure=False
                ): (i, run)
                for i, run in pending
            }
            t0 = time.perf_counter()
            try:
                for future in as_completed(futures):
                    i, run = futures[future]
                    try:
                        part: Row = future.result()
                    except Exception as exc:  # e.g. KilledWorker: a row
                        part = {"status": "error", "error": f"{type(exc).__name__}: {exc}"}
                    row: Row = {"run": run.key, "index": i, **run.inputs, **part}
                    table.add(row)
                    stats.ran += 1
                    stats.failed += row.get("status") == "error"
                    wall = part.get("wall_s")
                    stats.busy += wall if isinstance(wall, float) else 0.0
                    cpu = part.get("cpu_s")
                    stats.cpu += cpu if isinstance(cpu, float) else 0.0
                    bar.update()
                    if stats.failed:
                        bar.set_postfix_str(f"{stats.failed} failed")
                    if on_row is not None:
                        on_row(row)
            finally:  # closing the client releases what is still queued (e.g. on Ctrl-C)
                stats.wall = time.perf_counter() - t0
    finally:
        bar.close()
        table.flush()
    return stats


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
