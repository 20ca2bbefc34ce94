"""Where a campaign runs: an embedded ``LocalCluster`` sized to the machine, or a scheduler.

:class:`Cluster` says where; :func:`client_for` opens a ``dask.distributed`` client on it (an
embedded cluster is started and closed with the client).

An embedded cluster is a *quiet* one (:data:`QUIET_CONFIG`).  Dask's defaults suit long-lived,
observed clusters: every worker samples its own stack 100 times a second for the dashboard's
profile, every process ticks its event loop 50 times a second to detect blocking, samples its
CPU and memory twice a second and the scheduler looks for work to steal 10 times a second.  A
campaign's run is CPU-bound Python on one thread per worker, so each of those wake-ups takes the
run's GIL or a core from it.  Measured on the 2-core VM (``tools/bench_campaign.py``, step 0:
a 2-worker cluster whose workers both spin a pure-Python loop for 8 s; CPU beyond the spinning
threads): with the defaults 0.033-0.046 core in the client process (scheduler, nannies, client)
and 0.028-0.036 core in each worker, 0.09-0.12 of the 2 cores in all; quiet, 0.008-0.010 core
and 0.002-0.005 core per worker, 0.02 in all.  A run's results do not depend on any of these
settings.  An external scheduler (``scheduler=``) keeps its own configuration.
"""

from __future__ import annotations

import logging
import os
import re
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import TYPE_CHECKING

from rths.core.errors import ConfigError, check_positive_int

if TYPE_CHECKING:
    from distributed import Client

__all__ = ["QUIET_CONFIG", "Cluster", "client_for", "default_workers"]

_ADDRESS = re.compile(r"^(tcp|tls|ucx|inproc)://[^\s/]+$")

#: Dask settings of an embedded cluster (module docstring): no statistical profiler in the
#: workers (it is the dashboard's, and the embedded cluster has none), event-loop ticks and
#: system samples once a second instead of 50 and 2 times, the nannies' memory checks once a
#: second instead of 10 times (a worker over its limit is still stopped within a second), no
#: work stealing (runs are queued on the scheduler and handed to whichever worker is free:
#: nothing to steal).
QUIET_CONFIG: dict[str, object] = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "1s",
    "distributed.worker.memory.monitor-interval": "1s",
    "distributed.scheduler.work-stealing": False,
}


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


@contextmanager
def client_for(cluster: Cluster) -> Iterator[Client]:
    """A Dask client (an embedded cluster is started with :data:`QUIET_CONFIG` and closed with
    it).

    Parameters
    ----------
    cluster
        Where: a scheduler address or the embedded cluster's size and kind.
    """
    import dask
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
    # the settings hold while the cluster lives: worker processes receive them when spawned
    with (
        dask.config.set(QUIET_CONFIG),
        LocalCluster(
            n_workers=cluster.workers or default_workers(),
            threads_per_worker=1,
            processes=cluster.processes,
            dashboard_address=":0",  # any free port: never collides with another cluster's 8787
            silence_logs=logging.CRITICAL,
        ) as local,
        Client(local) as client,
    ):
        yield client
