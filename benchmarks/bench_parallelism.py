"""Two threads or two worker processes against one on the same work, in the same run, and what the package chose.

Run: nice -n 10 .venv/bin/python benchmarks/bench_parallelism.py [--boats 2000] [--tasks 4] [--rounds 3]
[--busy 2 --settle 60]. ``--busy N`` starts N busy Python loops (at this process's niceness) and waits ``--settle``
seconds (the 1-minute load average rises) before measuring: the loaded case. Targets (issue 37, printed, not
asserted): 2 threads / 2 workers >= 1.7x one on an idle machine; on a loaded one the chosen count never slower
than one (>= 1.0x). Work: a closed-loop zigzag ensemble (20°/20°, 75 s) of ``--boats`` boats; threads: numba's
parallel kernel on 1 and on 2 threads; workers: ``--tasks`` such ensembles on a process pool of 1 and of 2
one-thread workers (started and warmed before the clock); the four interleaved, best of ``--rounds``. Printed
beside: the fleet's default worker count.
"""

from __future__ import annotations

import argparse
import math
import os
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from typing import Any

from boat_twin.config import TwinConfig
from boat_twin.fleet.engine import default_workers
from boat_twin.threads import use_one_thread


def _ensemble(boats: int) -> tuple[Any, Any, list[Any]]:
    """The zigzag scenario, the vessel configuration and ``boats`` drawn boats."""
    from boat_twin.fleet.ensemble import EnsembleSpec, boat_draws
    from boat_twin.vessel.scenarios import Zigzag
    from boat_twin.vessel.simulate import OUTPUT_RATE_HZ

    config = TwinConfig()
    angle = math.radians(20.0)
    zigzag = Zigzag(config.vessel, angle, angle, duration_s=75.0, decision_rate_hz=OUTPUT_RATE_HZ)
    vessels, _ = boat_draws(EnsembleSpec("zigzag-20-20", boats, config=config), 0, boats)
    return config.vessel, zigzag, vessels


def task(boats: int) -> float:
    """(In a pool worker.) One ensemble of ``boats`` boats on one thread; its wall time, s."""
    from boat_twin.vessel.simulate import simulate

    use_one_thread()
    vessel, zigzag, vessels = _ensemble(boats)
    start = time.perf_counter()
    simulate(vessel, zigzag, boats=vessels)
    return time.perf_counter() - start


def warm(boats: int) -> float:
    """(In a pool worker.) The kernels compiled, then a pause so that each worker takes one warm-up task."""
    task(min(boats, 64))
    time.sleep(1.0)
    return 0.0


def measure(boats: int, tasks: int, rounds: int) -> dict[str, float]:
    """Best wall time, s, of the ensemble on 1 and on 2 numba threads in this process, and of ``tasks`` ensembles
    on a pool of 1 and of 2 warmed one-thread workers: the four interleaved in each round (the other jobs' load
    drifts between runs)."""
    import numba

    from boat_twin.vessel.simulate import simulate

    vessel, zigzag, vessels = _ensemble(boats)
    simulate(vessel, zigzag, boats=vessels[:64])  # compiled
    times = dict.fromkeys(("1 thread", "2 threads", "1 worker", "2 workers"), math.inf)
    pools = {n: ProcessPoolExecutor(n, mp_context=get_context("spawn")) for n in (1, 2)}
    try:
        for n, pool in pools.items():
            list(pool.map(warm, [boats] * n))
        for _ in range(rounds):
            for threads in (1, 2):
                numba.set_num_threads(threads)
                start = time.perf_counter()
                simulate(vessel, zigzag, boats=vessels)
                label = f"{threads} thread" + "s" * (threads > 1)
                times[label] = min(times[label], time.perf_counter() - start)
            for n, pool in pools.items():
                start = time.perf_counter()
                list(pool.map(task, [boats] * tasks))
                label = f"{n} worker" + "s" * (n > 1)
                times[label] = min(times[label], time.perf_counter() - start)
    finally:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        for pool in pools.values():
            pool.shutdown()
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--boats", type=int, default=2000, help="boats of the ensemble")
    parser.add_argument("--tasks", type=int, default=4, help="ensembles handed to the pool")
    parser.add_argument("--rounds", type=int, default=3, help="interleaved rounds; the best is kept")
    parser.add_argument("--busy", type=int, default=0, help="busy Python loops started beside (the loaded case)")
    parser.add_argument("--settle", type=float, default=60.0, help="with --busy: seconds waited before measuring")
    args = parser.parse_args()
    loops = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(args.busy)]
    try:
        if loops:
            time.sleep(args.settle)
        load = os.getloadavg()
        cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
        chosen = default_workers()
        times = measure(args.boats, args.tasks, args.rounds)
        end = os.getloadavg()
    finally:
        for loop in loops:
            loop.kill()
            loop.wait()
    print(f"{cores} cores, {args.busy} busy loops beside, load average {load[0]:.2f} / {load[1]:.2f} / {load[2]:.2f} "
          f"at the start, {end[0]:.2f} at the end; chosen workers (fleet default_workers): {chosen}")
    print(f"numba threads, zigzag ensemble {args.boats} boats x 75 s: 1 thread {times['1 thread']:.2f} s, 2 threads "
          f"{times['2 threads']:.2f} s; 2 / 1 speed-up {times['1 thread'] / times['2 threads']:.2f}x")
    print(f"worker processes, {args.tasks} ensembles of {args.boats} boats: 1 worker {times['1 worker']:.2f} s, "
          f"2 workers {times['2 workers']:.2f} s; 2 / 1 speed-up {times['1 worker'] / times['2 workers']:.2f}x")
    print("targets: >= 1.7x idle, the chosen count >= 1.0x of one when loaded")


if __name__ == "__main__":
    main()
