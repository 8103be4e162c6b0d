"""How the compiled ensemble kernel shares the cores: numba's OpenMP threads wait passively, and a process that is
one of several workers on a machine (a Dask worker) runs its kernels on one thread.

numba's default threading layer here is GNU OpenMP, whose idle workers spin (``OMP_WAIT_POLICY`` active) for a
while before they sleep: with other processes on the cores, every parallel region then waits for threads that
were descheduled while spinning, and closed-loop ensembles (one parallel region per 0.02 s integration step) ran
6-13x slower on threads than on one thread at a load of 4-7 on 2 cores (issue 27). Passive waiting gives the
cores back at once; benchmarks/bench_fleet.py measures the ensemble beside a busy loop (docs/fleet-scaling.md).

A command-line run keeps BLAS on one thread unless the user sets a thread count: its matrices are small
(parameters × samples), and two OpenBLAS threads on a busy machine only spin (``diagnose`` 1.6× the CPU of one
thread; one NNLS of ``identify``'s initial guess 0.8 s against 0.07 s, a C call that holds Ctrl-C; issue 37).
"""

from __future__ import annotations

import os
import sys
from contextlib import AbstractContextManager, nullcontext

WAIT_POLICY = "PASSIVE"
"""``OMP_WAIT_POLICY`` set for the OpenMP runtime unless the user chose one: idle threads sleep at once."""
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS", "OMP_NUM_THREADS")
"""Environment variables through which a user sets the BLAS libraries' thread count (then it is theirs)."""


def configure_openmp() -> None:
    """Set ``OMP_WAIT_POLICY`` to :data:`WAIT_POLICY` unless already set. The OpenMP runtime reads it when it is
    loaded, at numba's first parallel kernel launch: call this before (``vessel.dynamics`` does on import)."""
    os.environ.setdefault("OMP_WAIT_POLICY", WAIT_POLICY)


def single_thread_environment() -> dict[str, str]:
    """Environment of a worker process that is one of several on a machine: numba, OpenMP and the BLAS libraries
    each on one thread (the processes, not threads inside them, share the cores)."""
    return {"NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
            "OMP_WAIT_POLICY": WAIT_POLICY}


def use_one_numba_thread() -> None:
    """Run this thread's numba parallel kernels on one thread (numba's thread count is per calling thread): the
    first thing a fleet task does, whatever environment its worker was started with."""
    import numba

    numba.set_num_threads(1)


def use_one_thread() -> None:
    """Run this process's numba kernels (this thread's) and BLAS calls on one thread from now on: for a task
    handed to a worker process that is already running (a process pool of a benchmark). Its environment is read
    only at start-up: setting ``NUMBA_NUM_THREADS`` in ``os.environ`` once numba's threads are launched makes
    numba's next compilation fail ("Cannot set NUMBA_NUM_THREADS to a different value once the threads have been
    launched"); :func:`single_thread_environment` is for starting a process."""
    import threadpoolctl

    use_one_numba_thread()
    threadpoolctl.threadpool_limits(1)


def _blas_threads_chosen() -> bool:
    """Whether the environment sets a BLAS thread count (:data:`BLAS_THREAD_VARIABLES`)."""
    return any(os.environ.get(name) for name in BLAS_THREAD_VARIABLES)


def one_blas_thread_environment() -> None:
    """For a command-line process, before numpy is imported: OpenBLAS, MKL and BLIS on one thread (they read it
    when they are loaded; child processes inherit it), unless the user set a BLAS thread count."""
    if not _blas_threads_chosen():
        for name in BLAS_THREAD_VARIABLES[:3]:
            os.environ[name] = "1"


def one_blas_thread() -> AbstractContextManager[object]:
    """For a command-line run: the BLAS libraries already loaded held on one thread for the ``with`` block
    (threadpoolctl; a run inside a process that had imported numpy), unless the user set a BLAS thread count."""
    if _blas_threads_chosen() or "numpy" not in sys.modules:
        return nullcontext()
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")
