"""Reader: a 1-hour trial bag into a Trial, against bare rosbags read + deserialize of the same topics.

Run: make bench   (or: .venv/bin/python benchmarks/bench_reader.py)
Target (printed, not asserted): Trial reading within 1.5x of the bare read; peak memory bounded.
"""

import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np
from rosbags.highlevel import AnyReader

from boat_twin.config import TwinConfig
from boat_twin.io.bags import ROLE_TOPICS, read_trial, write_bag
from boat_twin.io.messages import TS
from boat_twin.twin.sea_trial import run_sea_trial, trial_messages
from boat_twin.vessel.scenarios import make_scenario


def bare_read(path: Path) -> int:
    """rosbags alone: every message of the trial's topics, deserialized."""
    wanted = {"/" + t for t in ROLE_TOPICS.values()}
    count = 0
    with AnyReader([path], default_typestore=TS) as reader:
        conns = [c for c in reader.connections if c.topic in wanted]
        for conn, _, raw in reader.messages(connections=conns):
            reader.deserialize(raw, conn.msgtype)
            count += 1
    return count


def main() -> None:
    config = TwinConfig()
    scenario = make_scenario("random", config.vessel, np.random.default_rng(1), duration_s=3600.0)
    with tempfile.TemporaryDirectory() as tmp:
        bag = Path(tmp) / "hour"
        total = write_bag(bag, trial_messages(run_sea_trial(config, scenario, seed=1)))
        size_mb = sum(p.stat().st_size for p in bag.iterdir()) / 1e6
        count = bare_read(bag)
        bare_s = min(_timed(lambda: bare_read(bag)) for _ in range(2))
        trial_s = min(_timed(lambda: read_trial(bag)) for _ in range(2))
        tracemalloc.start()
        trial = read_trial(bag)
        peak_mb = tracemalloc.get_traced_memory()[1] / 1e6
        tracemalloc.stop()
    print(f"1-hour trial: {total} messages in the bag ({size_mb:.1f} MB MCAP+zstd), {count} on the Trial's topics")
    print(f"bare rosbags read+deserialize: {bare_s:.2f} s ({count / bare_s:,.0f} msg/s)")
    print(f"read_trial -> Trial ({len(trial)} samples): {trial_s:.2f} s ({count / trial_s:,.0f} msg/s), "
          f"ratio {trial_s / bare_s:.2f}x (target <= 1.5x)")
    print(f"read_trial peak Python memory: {peak_mb:.1f} MB (bag on disk {size_mb:.1f} MB)")


def _timed(fn) -> float:
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


if __name__ == "__main__":
    main()
