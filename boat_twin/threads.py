"""How the compiled ensemble kernel shares the cores: numba's OpenMP threads wait passively, and a process that is
one of several workers on a machine (a Dask worker) runs its kernels on one thread.

numba's default threading layer here is GNU OpenMP, whose idle workers spin (``OMP_WAIT_POLICY`` active) for a
while before they sleep: with other processes on the cores, every parallel region then waits for threads that
were descheduled while spinning, and closed-loop ensembles (one parallel region per 0.02 s integration step) ran
6-13x slower on threads than on one thread at a load of 4-7 on 2 cores (issue 27). Passive waiting gives the
cores back at once; benchmarks/bench_fleet.py measures the ensemble beside a busy loop (docs/fleet.md).
"""

from __future__ import annotations

import os

WAIT_POLICY = "PASSIVE"
"""``OMP_WAIT_POLICY`` set for the OpenMP runtime unless the user chose one: idle threads sleep at once."""


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
