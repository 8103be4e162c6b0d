"""Command-line start-up: CPU time of ``boat-twin`` commands, each in a fresh process, against two floors measured
in the same run — a bare ``python -c pass`` and ``python -c "import numpy, scipy.optimize"`` (what any numerical
command pays) — and the first simulate with the numba kernels cold (empty cache) and cached.

Run: make bench   (or: .venv/bin/python benchmarks/bench_cli.py [--repeats N])
Targets (printed, not asserted): every ``--help`` and ``--version`` < 0.3 s CPU; ``cable depth`` < 1 s CPU;
the first simulate of a new process within 1 s of a warm one (kernels loaded from numba's cache).
"""

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = Path(sys.executable).parent / "boat-twin"
BOAT_TWIN = [str(SCRIPT)] if SCRIPT.exists() else [sys.executable, "-m", "boat_twin.cli"]
HELPS = [["--help"], ["--version"], *([verb, "--help"] for verb in
                                      ("simulate", "identify", "diagnose", "follow", "convert", "cable", "demo")),
         *(["cable", sub, "--help"] for sub in ("depth", "length", "convergence", "speed"))]
CABLE_DEPTH = ["cable", "depth", "--case", str(ROOT / "config/cable/default.yaml")]
SIMULATE = ["simulate", "thrust-steps", "--duration", "10", "--json"]


def cpu_s(argv: list[str], env: dict[str, str] | None = None) -> float:
    """User + system CPU time, s, of one run of ``argv`` (a child process; its output discarded)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(argv, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=ROOT,
                   env={**os.environ, **(env or {})})
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def median_cpu_s(argv: list[str], repeats: int, env: dict[str, str] | None = None) -> float:
    return statistics.median(cpu_s(argv, env) for _ in range(repeats))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5, help="runs per command; the median is printed")
    repeats = parser.parse_args().repeats
    bare = median_cpu_s([sys.executable, "-c", "pass"], repeats)
    floor = median_cpu_s([sys.executable, "-c", "import numpy, scipy.optimize"], repeats)
    print(f"CPU time, median of {repeats} fresh processes (ratios to this run's floors)")
    print(f"{'command':44} {'CPU s':>7} {'/ bare':>7} {'/ numpy+scipy.optimize':>23}")

    def row(name: str, seconds: float) -> None:
        print(f"{name:44} {seconds:7.3f} {seconds / bare:7.1f} {seconds / floor:23.2f}")

    row("python -c pass", bare)
    row("python -c 'import numpy, scipy.optimize'", floor)
    worst_help = 0.0
    for argv in HELPS:
        seconds = median_cpu_s([*BOAT_TWIN, *argv], repeats)
        worst_help = max(worst_help, seconds)
        row("boat-twin " + " ".join(argv), seconds)
    depth = median_cpu_s([*BOAT_TWIN, *CABLE_DEPTH], repeats)
    row("boat-twin cable depth --case default.yaml", depth)
    cold_repeats = max(1, min(repeats, 3))  # a cold compile costs seconds: fewer runs
    with tempfile.TemporaryDirectory() as cache:
        cold = []
        for _ in range(cold_repeats):
            with tempfile.TemporaryDirectory() as empty:
                cold.append(cpu_s([*BOAT_TWIN, *SIMULATE], {"NUMBA_CACHE_DIR": empty}))
        cpu_s([*BOAT_TWIN, *SIMULATE], {"NUMBA_CACHE_DIR": cache})  # fills the cache
        warm = median_cpu_s([*BOAT_TWIN, *SIMULATE], repeats, {"NUMBA_CACHE_DIR": cache})
    row(f"simulate 10 s, numba cache empty (x{cold_repeats})", statistics.median(cold))
    row("simulate 10 s, numba cache filled", warm)
    print(f"worst --help {worst_help:.3f} s (target < 0.3 s); cable depth {depth:.3f} s (target < 1 s); "
          f"first simulate: cached kernels save {statistics.median(cold) - warm:.2f} s of CPU")


if __name__ == "__main__":
    main()
