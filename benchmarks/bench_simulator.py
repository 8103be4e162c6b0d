"""Simulator speed: sea time per compute time for one boat (physics; + sensors + bag), and an ensemble.

Run: make bench   (or: .venv/bin/python benchmarks/bench_simulator.py)
Targets (printed, not asserted): physics >= 10,000x real time for one boat; the ensemble of 600 boats stepped
together much faster than 600 single runs; a training set of 10^4 20°/20° zigzags (75 s, boats drawn as
the manoeuvring study's hidden boats: ident.manoeuvring_trials.draw_boat) in < 60 s on 2 cores, its boats shared
among numba's threads (vessel.dynamics.PARALLEL_MIN_BOATS) against one thread, with identical results, and the
memory it holds bounded by its ensemble runs of 2000 boats (not the 10^4).
"""

import math
import resource
import tempfile
import time
from pathlib import Path

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.ident.manoeuvring_trials import draw_boat
from boat_twin.io.bags import write_bag
from boat_twin.twin.sea_trial import run_sea_trial, trial_messages
from boat_twin.vessel import dynamics
from boat_twin.vessel.params import VesselParams
from boat_twin.vessel.scenarios import Zigzag, make_scenario
from boat_twin.vessel.simulate import OUTPUT_RATE_HZ, simulate

TRAINING_SET = 10_000
BATCH = 2000
"""Boats per ensemble run of the training set (bench_zigzag_inverse.BATCH)."""


def peak_rss_mb() -> float:
    """Peak resident memory of this process so far, MB (Linux: ru_maxrss in KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def best_of(repeats: int, fn) -> float:
    """Smallest wall time of ``repeats`` calls, s."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    config = TwinConfig()
    params = config.vessel
    hour = make_scenario("random", params, np.random.default_rng(1), duration_s=3600.0)
    simulate(params, make_scenario("random", params, np.random.default_rng(1), duration_s=10.0))  # compile
    physics_s = best_of(3, lambda: simulate(params, hour))
    print(f"physics, one boat, 3600 s random commands: {physics_s:.3f} s -> {3600 / physics_s:,.0f}x real time "
          f"(target >= 10,000x)")
    zigzag = make_scenario("zigzag-20-20", params, np.random.default_rng(1), duration_s=600.0)
    closed_s = best_of(3, lambda: simulate(params, zigzag))
    print(f"physics, one boat, 600 s closed-loop zigzag: {closed_s:.3f} s -> {600 / closed_s:,.0f}x real time")
    ten_min = make_scenario("random", params, np.random.default_rng(1), duration_s=600.0)
    with tempfile.TemporaryDirectory() as tmp:
        def full() -> None:
            trial = run_sea_trial(config, ten_min, seed=1)
            write_bag(Path(tmp) / "bag", trial_messages(trial), force=True)
        full_s = best_of(2, full)
    print(f"with GNSS + UM7 sensors + MCAP bag writing, 600 s: {full_s:.2f} s -> {600 / full_s:,.0f}x real time")
    short = make_scenario("random", params, np.random.default_rng(2), duration_s=120.0)
    starts = np.zeros((600, 6))
    starts[:, 3] = np.linspace(0.0, 9.0, 600)
    together_s = best_of(3, lambda: simulate(params, short, initial_states=starts))
    singles_s = best_of(1, lambda: [simulate(params, short, initial_states=starts[i : i + 1]) for i in range(600)])
    print(f"ensemble 600 boats x 120 s: together {together_s:.3f} s, 600 single runs {singles_s:.3f} s, "
          f"ratio {singles_s / together_s:.1f}x")
    threads_by_size(params)
    training_set(params)


def threads_by_size(params: VesselParams) -> None:
    """One RK4 step of N boats (a closed-loop helm's call), one thread against numba's threads, per N: where
    vessel.dynamics.PARALLEL_MIN_BOATS should lie."""
    dynamics_ = dynamics.Dynamics(params)
    parallel_min = dynamics.PARALLEL_MIN_BOATS
    for n in (1, 4, 8, 64, 2000):
        commands, environments = np.full((n, 4), 800.0), np.zeros((n, 4))
        commands[:, 2:] = 0.0
        per_call = []
        for threshold in (n + 1, n):  # one thread, then threads
            dynamics.PARALLEL_MIN_BOATS = threshold
            states, steering = np.zeros((n, 6)), np.zeros((n, 2))
            states[:, 3] = 5.0
            args = (states, commands, environments, 0.02, steering)
            dynamics_.step(*args)  # compile
            per_call.append(best_of(5, lambda args=args: [dynamics_.step(*args) for _ in range(200)]) / 200)
        print(f"one step of {n} boats: one thread {per_call[0] * 1e6:.1f} us, threads {per_call[1] * 1e6:.1f} us, "
              f"ratio {per_call[0] / per_call[1]:.2f}x")
    dynamics.PARALLEL_MIN_BOATS = parallel_min


def training_set(params: VesselParams) -> None:
    """10^4 closed-loop zigzags in ensemble runs of :data:`BATCH`: threads against one thread on one run, then
    the whole set on threads, and the peak memory."""
    angle = math.radians(20.0)
    zigzag = Zigzag(params, angle, angle, duration_s=75.0, decision_rate_hz=OUTPUT_RATE_HZ)
    rng = np.random.default_rng(0)
    boats = [draw_boat(TwinConfig(vessel=params), rng)[0].vessel for _ in range(TRAINING_SET)]
    simulate(params, zigzag, boats=boats[: dynamics.PARALLEL_MIN_BOATS])  # compile the threaded kernels
    start = time.perf_counter()
    threaded = simulate(params, zigzag, boats=boats[:BATCH])
    threads_s = time.perf_counter() - start
    parallel_min = dynamics.PARALLEL_MIN_BOATS
    dynamics.PARALLEL_MIN_BOATS = BATCH + 1
    start = time.perf_counter()
    serial = simulate(params, zigzag, boats=boats[:BATCH])
    serial_s = time.perf_counter() - start
    dynamics.PARALLEL_MIN_BOATS = parallel_min
    same = all(np.array_equal(getattr(threaded, f), getattr(serial, f)) for f in ("states", "derivatives"))
    record_mb = sum(getattr(threaded, f).nbytes for f in ("states", "commands", "derivatives", "steering_rad",
                                                          "command_issued_s")) / 1e6
    del threaded, serial
    print(f"zigzag ensemble {BATCH} boats x 75 s: threads {threads_s:.2f} s, one thread {serial_s:.2f} s, ratio "
          f"{serial_s / threads_s:.2f}x, identical: {same}")
    start = time.perf_counter()
    for lo in range(0, TRAINING_SET, BATCH):
        simulate(params, zigzag, boats=boats[lo:lo + BATCH])
    total_s = time.perf_counter() - start
    print(f"training set {TRAINING_SET} zigzags x 75 s in runs of {BATCH}: {total_s:.1f} s on threads, "
          f"{TRAINING_SET / total_s:.0f} zigzags/s (target < 60 s); one run's record {record_mb:.0f} MB, "
          f"peak RSS of this benchmark {peak_rss_mb():.0f} MB")


if __name__ == "__main__":
    main()
