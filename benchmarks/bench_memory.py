"""Memory: peak RSS of ``boat-twin simulate`` (+ bag writing) and of read_trial for 1-hour and 6-hour trials.

Each case runs in its own process; its peak resident set size comes from os.wait4 (ru_maxrss of that child).
The reference is bare rosbags streaming (read + deserialize the Trial's topics, nothing kept) of the same bags.
Run: make bench   (or: .venv/bin/python benchmarks/bench_memory.py)
Target (printed, not asserted): the 6-hour peak within 1.3x of the 1-hour peak, for simulate and for read_trial.
read_trial returns the Trial, whose float64 columns grow with the trial by design; its row is also printed with
the Trial's own arrays subtracted (the reader's working memory), which is what the 1.3x bounds for it.
"""

import os
import subprocess
import sys
import tempfile
from pathlib import Path

DURATIONS_S = (3600.0, 21600.0)
"""Trial lengths compared: 1 h and 6 h, s."""

READ_TRIAL = """
from dataclasses import fields
from pathlib import Path
import numpy as np
from boat_twin.io.bags import read_trial
trial = read_trial(Path(sys.argv[1]))
print(sum(getattr(trial, f.name).nbytes for f in fields(trial) if isinstance(getattr(trial, f.name), np.ndarray)))
"""
"""Reads the bag into a Trial and prints the bytes of the Trial's arrays."""
BARE_READ = """
from pathlib import Path
from rosbags.highlevel import AnyReader
from boat_twin.io.bags import ROLE_TOPICS
from boat_twin.io.messages import TS
wanted = {"/" + t for t in ROLE_TOPICS.values()}
with AnyReader([Path(sys.argv[1])], default_typestore=TS) as reader:
    for conn, _, raw in reader.messages(connections=[c for c in reader.connections if c.topic in wanted]):
        reader.deserialize(raw, conn.msgtype)
"""


def peak_rss_mb(argv: list[str]) -> tuple[float, str]:
    """Run ``argv`` to completion and return its peak resident set size, MB, and its standard output."""
    with tempfile.TemporaryFile() as out:
        child = subprocess.Popen(argv, stdout=out)
        _, status, usage = os.wait4(child.pid, 0)
        child.returncode = os.waitstatus_to_exitcode(status)
        if child.returncode != 0:
            raise RuntimeError(f"{' '.join(argv)} exited with {child.returncode}")
        out.seek(0)
        return usage.ru_maxrss / 1024.0, out.read().decode()  # ru_maxrss is in KiB on Linux


def python_case(code: str, bag: Path) -> list[str]:
    """A fresh interpreter running ``code`` with the bag path as sys.argv[1]."""
    return [sys.executable, "-c", "import sys\n" + code, str(bag)]


def main() -> None:
    cli = str(Path(sys.executable).with_name("boat-twin"))
    peaks: dict[str, list[float]] = {"simulate + write": [], "read_trial": [], "read_trial minus the Trial": [],
                                     "bare rosbags streaming": []}
    with tempfile.TemporaryDirectory() as tmp:
        for duration in DURATIONS_S:
            bag = Path(tmp) / f"random_{duration:.0f}s"
            peaks["simulate + write"].append(peak_rss_mb(
                [cli, "simulate", "random", "--duration", f"{duration:g}", "--seed", "1", "--out", str(bag)])[0])
            peak, trial_bytes = peak_rss_mb(python_case(READ_TRIAL, bag))
            peaks["read_trial"].append(peak)
            peaks["read_trial minus the Trial"].append(peak - int(trial_bytes) / 2**20)
            peaks["bare rosbags streaming"].append(peak_rss_mb(python_case(BARE_READ, bag))[0])
    print("peak RSS, MB" + " " * 16 + "".join(f"{d / 3600:>8.0f} h" for d in DURATIONS_S) + "   6h/1h (target <= 1.3x)")
    for name, (hour, six) in peaks.items():
        print(f"{name:<27} {hour:8.1f} {six:9.1f}   {six / hour:5.2f}x")


if __name__ == "__main__":
    main()
