"""Simulator speed: sea time per compute time for one boat (physics; + sensors + bag), and an ensemble.

Run: make bench   (or: .venv/bin/python benchmarks/bench_simulator.py)
Targets (printed, not asserted): physics >= 10,000x real time for one boat; the ensemble of 600 boats stepped
together much faster than 600 single runs.
"""

import tempfile
import time
from pathlib import Path

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.io.bags import write_bag
from boat_twin.twin.sea_trial import run_sea_trial, trial_messages
from boat_twin.vessel.scenarios import make_scenario
from boat_twin.vessel.simulate import simulate


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


if __name__ == "__main__":
    main()
