"""Closed-loop trials with the helm inside the compiled kernel, against the Python step loop, and where an ensemble
of them runs best: numba's threads (prange over the boats), one thread, or Dask worker processes of one thread
each, on an idle machine and beside busy loops.

Run: .venv/bin/python benchmarks/bench_closed_loop.py [--boats 2000] [--busy 2] [--parts single,ensemble,load]
(the Dask rows need the fleet extra). Every ratio is measured in the same run; each figure is the best of
interleaved rounds (the other jobs' load drifts between runs). The load average is printed with each part.

- single: one boat's 75 s 20°/20° zigzag (the ensembles' trial) and a 600 s one: the compiled helm against the
  same scenario asked from the Python step loop (`vessel.simulate`'s reference path), with identical records;
- ensemble: a zigzag ensemble of --boats boats drawn as the manoeuvring study's (±30 %): the compiled helm on
  numba's threads (prange, one parallel region per run; dynamic chunks of 16 boats, and numba's equal shares),
  the same prange kernel on one thread, the same loop compiled without prange on one thread, 2 Dask worker
  processes of one thread each (half the boats each; the cluster started, the boats drawn and the kernels loaded
  before the clock), and the Python step loop (one region per 0.02 s step) on the threads and on one thread.
  CPU time is beside the wall time: on a machine shared with other sessions, Linux's autogroup scheduler gives
  this session a share of the cores whatever its threads and processes, so only the CPU time compares the work;
- open: the open-loop kernel on one thread in its prange form against the plain loop: a one-boat hour, and a
  live twin's single tick (1000 calls);
- load: the ensemble rows again beside --busy busy loops (`while True: pass`, one process each).
"""

from __future__ import annotations

import argparse
import functools
import math
import os
import subprocess
import sys
import time
from collections.abc import Callable
from typing import Any

import numba
import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.fleet.ensemble import EnsembleSpec, boat_draws
from boat_twin.vessel import dynamics
from boat_twin.vessel.scenarios import Zigzag, make_scenario
from boat_twin.vessel.simulate import SimulationRecord, simulate

ANGLE = math.radians(20.0)
DURATION_S = 75.0
"""Length of the ensembles' zigzags, s (the training sets' and the fleet ensembles')."""


def load() -> str:
    return f"load average {os.getloadavg()[0]:.1f}"


def best(rounds: int, runs: dict[str, Callable[[], Any]]) -> dict[str, tuple[float, float]]:
    """Best wall time of each run over ``rounds`` interleaved rounds, with the CPU time of that run (this
    process's threads, or what a run returns as its workers' CPU), s."""
    times = dict.fromkeys(runs, (math.inf, math.inf))
    for _ in range(rounds):
        for label, run in runs.items():
            start, cpu = time.perf_counter(), time.process_time()
            result = run()
            wall, cpu = time.perf_counter() - start, time.process_time() - cpu
            if isinstance(result, tuple):  # (value, the workers' CPU time)
                cpu = result[1]
            if wall < times[label][0]:
                times[label] = (wall, cpu)
    return times


def same(a: SimulationRecord, b: SimulationRecord) -> bool:
    return all(np.array_equal(getattr(a, n), getattr(b, n))
               for n in ("states", "derivatives", "steering_rad", "commands", "command_issued_s"))


def single(params: Any) -> None:
    for duration, rounds in ((DURATION_S, 7), (600.0, 3)):
        zigzag = Zigzag(params, ANGLE, ANGLE, speed_mps=params.turn_speed_mps, duration_s=duration)
        identical = same(simulate(params, zigzag), simulate(params, zigzag, compiled_helm=False))
        measured = best(rounds, {"compiled": lambda z=zigzag: simulate(params, z),
                                 "python": lambda z=zigzag: simulate(params, z, compiled_helm=False)})
        (wall, cpu), (py_wall, py_cpu) = measured["compiled"], measured["python"]
        print(f"one boat, {duration:g} s zigzag 20/20: compiled helm {wall * 1e3:.1f} ms, CPU {cpu * 1e3:.1f} ms "
              f"({duration / wall:,.0f}x real time); Python step loop {py_wall * 1e3:.1f} ms, CPU {py_cpu * 1e3:.1f} "
              f"ms ({duration / py_wall:,.0f}x); speed-up {py_wall / wall:.1f}x (CPU {py_cpu / cpu:.1f}x); records "
              f"identical: {identical}; {load()}")


@numba.njit
def serial_closed_loop(states, steering, thrust, kind, helm_parameters, memory, history, last, changed,  # noqa: ANN001
                       first_tick, lags, coefficients, table, u_max, extra, environments, dt, substeps, output_rate,
                       out_states, out_derivatives, out_steering, out_commands, out_issued) -> None:
    """The closed-loop kernel's loop over the boats compiled as a plain loop (no prange), for comparison."""
    for b in range(states.shape[0]):
        dynamics._closed_loop_boat(b, states, steering, thrust, kind, helm_parameters, memory, history, last,
                                   changed, first_tick, lags, coefficients, table, u_max, extra, environments, dt,
                                   substeps, output_rate, out_states, out_derivatives, out_steering, out_commands,
                                   out_issued)


def open_loop(params: Any) -> None:
    """The open-loop kernel in its two forms on one thread: a long run, and a live twin's single tick (the
    call :data:`~boat_twin.vessel.dynamics.PRANGE_MIN_BOAT_TICKS` keeps on the plain loop)."""
    hour = make_scenario("random", params, np.random.default_rng(1), duration_s=3600.0)
    model = dynamics.Dynamics(params)
    states, steering, thrust = np.array([[0.0, 0.0, 0.0, 3.0, 0.0, 0.0]]), np.zeros((1, 2)), np.full((1, 2), 100.0)
    tick = np.array([[[100.0, 100.0, 0.1, 0.1]]])

    def below(threshold: int, run: Callable[[], Any]) -> Callable[[], Any]:
        """``run`` with the plain loop for runs below ``threshold`` boat-ticks (0: the prange form always)."""
        def call() -> Any:
            keep, dynamics.PRANGE_MIN_BOAT_TICKS = dynamics.PRANGE_MIN_BOAT_TICKS, threshold
            try:
                return run()
            finally:
                dynamics.PRANGE_MIN_BOAT_TICKS = keep
        return call

    def ticks() -> None:
        for _ in range(1000):
            model.run(states, tick, np.zeros((1, 4)), 0.02, 5, steering, thrust)

    def hour_run() -> None:
        simulate(params, hour)

    runs = {"hour, plain": below(sys.maxsize, hour_run), "hour, prange": below(0, hour_run),
            "tick, plain": below(sys.maxsize, ticks), "tick, prange": below(0, ticks)}
    for run in runs.values():
        run()
    measured = best(5, runs)
    cpu = {k: v[1] for k, v in measured.items()}
    print(f"open loop, one boat on one thread: 3600 s random commands, CPU {cpu['hour, plain'] * 1e3:.1f} ms plain "
          f"loop, {cpu['hour, prange'] * 1e3:.1f} ms prange form ({cpu['hour, plain'] / cpu['hour, prange']:.2f}x); "
          f"a single tick {cpu['tick, plain'] * 1e3:.1f} us plain, {cpu['tick, prange'] * 1e3:.1f} us prange form; "
          f"{load()}")


def on_threads(threads: int, run: Callable[[], Any], kernel: Any = None, chunk_boats: int | None = None
               ) -> Callable[[], Any]:
    """``run`` with numba on ``threads`` threads (the library's rule: threads from 64 boats), the closed-loop
    ``kernel`` in place of the library's prange one, and ``chunk_boats`` boats per dynamic chunk (0: numba's
    fixed equal shares) if given."""
    def call() -> Any:
        numba.set_num_threads(threads)
        keep = dynamics._closed_loop_parallel, dynamics.CLOSED_LOOP_CHUNK_BOATS
        if kernel is not None:
            dynamics._closed_loop_parallel = kernel
        if chunk_boats is not None:
            dynamics.CLOSED_LOOP_CHUNK_BOATS = chunk_boats
        try:
            return run()
        finally:
            dynamics._closed_loop_parallel, dynamics.CLOSED_LOOP_CHUNK_BOATS = keep
            numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    return call


@functools.cache
def drawn(boats: int, first: int, count: int) -> tuple[TwinConfig, list[Any]]:
    """The config and boats ``first`` .. of the bench's ensemble (drawn once per process: the warm-up's)."""
    config = TwinConfig()
    return config, boat_draws(EnsembleSpec("zigzag-20-20", boats, config=config), first, count)[0]


def part_of_ensemble(boats: int, first: int, count: int) -> tuple[float, float]:
    """(A Dask task.) Boats ``first`` .. of the bench's ensemble on one numba thread: their final yaw summed, and
    the task's CPU time, s."""
    from boat_twin.threads import use_one_numba_thread

    use_one_numba_thread()
    config, vessels = drawn(boats, first, count)
    cpu = time.process_time()
    zigzag = Zigzag(config.vessel, ANGLE, ANGLE, speed_mps=config.vessel.turn_speed_mps, duration_s=DURATION_S)
    final = float(simulate(config.vessel, zigzag, boats=vessels).states[-1, :, 2].sum())
    return final, time.process_time() - cpu


def ensemble_runs(boats: int, config: TwinConfig, vessels: list[Any], client: Any) -> dict[str, Callable[[], Any]]:
    params = config.vessel
    zigzag = Zigzag(params, ANGLE, ANGLE, speed_mps=params.turn_speed_mps, duration_s=DURATION_S)
    threads = numba.config.NUMBA_NUM_THREADS
    def run() -> Any:
        return simulate(params, zigzag, boats=vessels)

    runs: dict[str, Callable[[], Any]] = {
        f"prange, {threads} threads": on_threads(threads, run),
        f"prange, {threads} threads, equal shares": on_threads(threads, run, chunk_boats=0),
        "prange, 1 thread": on_threads(1, run),
        "plain loop, 1 thread": on_threads(1, run, kernel=serial_closed_loop),
    }
    if client is not None:
        workers = len(client.scheduler_info()["workers"])
        size = math.ceil(boats / workers)

        def dask() -> tuple[float, float]:
            futures = [client.submit(part_of_ensemble, boats, lo, min(size, boats - lo), pure=False)
                       for lo in range(0, boats, size)]
            parts = client.gather(futures)
            return sum(p[0] for p in parts), sum(p[1] for p in parts)

        runs[f"Dask, {workers} processes x 1 thread"] = dask
    def python_loop() -> Any:
        return simulate(params, zigzag, boats=vessels, compiled_helm=False)

    runs[f"Python step loop, {threads} threads"] = on_threads(threads, python_loop)
    runs["Python step loop, 1 thread"] = on_threads(1, python_loop)
    return runs


def ensemble(boats: int, rounds: int, client: Any, label: str) -> None:
    config, vessels = drawn(boats, 0, boats)
    runs = ensemble_runs(boats, config, vessels, client)
    for run in runs.values():  # every kernel loaded (and the workers' too) before the clock
        run()
    print(f"{label}: zigzag ensemble {boats} boats x {DURATION_S:g} s, best of {rounds} rounds; {load()} at the start")
    times = best(rounds, runs)
    fastest = min(wall for wall, _ in times.values())
    print(f"  {'':<40} {'wall s':>7} {'ms/boat':>8} {'/fastest':>8} {'CPU s':>7} {'CPU ms/boat':>11}")
    for name, (wall, cpu) in times.items():
        print(f"  {name:<40} {wall:7.2f} {wall / boats * 1e3:8.2f} {wall / fastest:8.2f} {cpu:7.2f} "
              f"{cpu / boats * 1e3:11.2f}")
    print(f"  {load()} at the end")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--boats", type=int, default=2000, help="ensemble size")
    parser.add_argument("--rounds", type=int, default=3, help="interleaved rounds of the ensemble rows")
    parser.add_argument("--busy", type=int, default=2, help="busy-loop processes beside the 'load' part")
    parser.add_argument("--parts", default="single,open,ensemble,load", help="which parts, comma-separated")
    args = parser.parse_args()
    parts = args.parts.split(",")
    print(f"{os.cpu_count()} cores, numba {numba.__version__} threading layer "
          f"{numba.config.THREADING_LAYER}, OMP_WAIT_POLICY {os.environ.get('OMP_WAIT_POLICY')}; {load()}")
    params = TwinConfig().vessel
    if "single" in parts:
        single(params)
    if "open" in parts:
        open_loop(params)
    if "ensemble" not in parts and "load" not in parts:
        return
    from contextlib import nullcontext

    from boat_twin.fleet.engine import LOCAL, dask_installed, open_client

    context = open_client(LOCAL, 2, quiet=True) if dask_installed() else nullcontext()
    with context as client:
        if "ensemble" in parts:
            ensemble(args.boats, args.rounds, client, "idle (other jobs aside)")
        if "load" in parts:
            loops = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(args.busy)]
            try:
                time.sleep(1.0)
                ensemble(args.boats, args.rounds, client, f"beside {args.busy} busy loops")
            finally:
                for loop in loops:
                    loop.kill()
                    loop.wait()


if __name__ == "__main__":
    main()
