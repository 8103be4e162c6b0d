"""Where fleet tasks run: a Dask client (a local cluster of worker processes, or an existing scheduler) or None
(this process, one task after another).

Dask and distributed are an optional extra (``pip install 'boat_twin[fleet]'``). Without them the default
scheduler falls back to this process with one line on stderr; a scheduler address names what is missing.
Imported by the verbs only when they run (``--help`` stays light).
"""

from __future__ import annotations

import logging
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from boat_twin.errors import InputError
from boat_twin.threads import single_thread_environment

LOCAL = "local"
"""A local cluster: one worker process per core (``--workers``), one thread each."""
SYNC = "sync"
"""No Dask: the tasks run in this process one after another (tracebacks and a debugger work; no extra needed)."""
SCHEDULER_HELP = ("where the tasks run: 'local' (default: a Dask cluster on this machine, one worker process per "
                  "core, one thread each), 'sync' (this process, one after another; for debugging), or a Dask "
                  "scheduler's address such as tcp://HOST:8786 (a cluster started with 'dask scheduler' and "
                  "'dask worker', dask-jobqueue or Kubernetes; the trials and --out must be at the same paths on "
                  "every worker). Needs the fleet extra (pip install 'boat_twin[fleet]'); without it, 'local' runs "
                  "in this process")
"""Help text of ``--scheduler``."""
MISSING = "dask and distributed are not installed (pip install 'boat_twin[fleet]')"
"""What is missing when the fleet extra is not installed."""
LOCAL_CLUSTER_CONFIG = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "2s",
    "distributed.worker.memory.monitor-interval": "1s",
}
"""Dask settings of a local cluster, tuned for fleet tasks (each one long Python call of seconds to minutes) rather
than Dask's default of many millisecond tasks: no statistical profiler (a thread sampling each task's stack every
10 ms for a flame graph that would show one function), and the event-loop health check (every 20 ms by default),
the system monitor (500 ms) and the memory monitor of each worker and nanny (100 ms) at 1-2 s. Together they took
3-8 % of the workers' CPU away from the tasks (docs/fleet.md); a worker over its memory limit is still stopped
within a second. A cluster at an address keeps its own settings."""
CONNECT_TIMEOUT_S = 10.0
"""How long to wait for a scheduler at an address, s."""
WORKER_START_TIMEOUT_S = 120.0
"""How long a local cluster's worker process may take to reach its scheduler before it gives up, s (Dask's
``death_timeout``; without one, a worker that never reports keeps the cluster's start waiting forever)."""


def dask_installed() -> bool:
    """Whether ``distributed`` (and so dask) can be imported."""
    try:
        import distributed  # noqa: F401
    except ImportError:
        return False
    return True


def _say(message: str) -> None:
    sys.stderr.write(f"boat-twin: {message}\n")
    sys.stderr.flush()


def default_workers() -> int:
    """Worker processes of a local cluster: the cores this process may use."""
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except AttributeError:  # not Linux
        return max(os.cpu_count() or 1, 1)


@contextmanager
def open_client(scheduler: str = LOCAL, workers: int | None = None, quiet: bool = False) -> Iterator[Any]:
    """A Dask client for ``scheduler`` (:data:`LOCAL`, :data:`SYNC` or an address) for the ``with`` block, or
    None where the tasks run in this process. A local cluster has ``workers`` processes (default: the cores), one
    thread each with numba, OpenMP and BLAS on one thread; it is shut down when the block ends. Its dashboard
    link (and any fallback) is said on stderr unless ``quiet``."""
    if workers is not None and workers < 1:
        raise InputError(f"--workers must be at least 1, got {workers}")
    if scheduler == SYNC:
        yield None
        return
    if scheduler != LOCAL and "://" not in scheduler and ":" not in scheduler:
        raise InputError(f"--scheduler {scheduler!r}: expected 'local', 'sync' or an address such as "
                         "tcp://HOST:8786")
    if not dask_installed():
        if scheduler != LOCAL:
            raise InputError(f"--scheduler {scheduler}: {MISSING}")
        if not quiet:
            _say(f"{MISSING}: running the tasks one after another in this process")
        yield None
        return
    import dask
    from distributed import Client, LocalCluster

    if scheduler == LOCAL:
        count = workers or default_workers()
        with dask.config.set(LOCAL_CLUSTER_CONFIG), \
                LocalCluster(n_workers=count, threads_per_worker=1, processes=True, dashboard_address=":0",
                             silence_logs=logging.ERROR, env=single_thread_environment(),
                             death_timeout=WORKER_START_TIMEOUT_S) as cluster, \
                Client(cluster) as client:
            if not quiet:
                _say(f"local Dask cluster: {count} worker process(es), 1 thread each; dashboard "
                     f"{client.dashboard_link}")
            yield client
        return
    if workers is not None:
        raise InputError("--workers sizes a local cluster; a cluster at an address has the workers it was given")
    try:
        client = Client(scheduler, timeout=f"{CONNECT_TIMEOUT_S:g}s")
    except (OSError, TimeoutError, ValueError) as err:
        raise InputError(f"--scheduler {scheduler}: cannot reach a Dask scheduler there ({err})") from None
    with client:
        if not quiet:
            count = len(client.scheduler_info().get("workers", {}))
            _say(f"Dask scheduler {scheduler}: {count} worker(s); dashboard {client.dashboard_link}")
        yield client
