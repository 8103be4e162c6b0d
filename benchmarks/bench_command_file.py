"""A long command file: ``boat-twin simulate --commands FILE --out o.mcap`` on 30,000 and 300,000 rows (0.1 s
apart: 50 min and 8.3 h of commands, every row different), CPU time of each run (a fresh process), rows and
simulated seconds per CPU second, and the ratio of the two runs' costs (linear: about 10, less the start-up).

Run: make bench   (or: .venv/bin/python benchmarks/bench_command_file.py [--rows 30000 300000])
"""

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

SCRIPT = Path(sys.executable).parent / "boat-twin"
BOAT_TWIN = [str(SCRIPT)] if SCRIPT.exists() else [sys.executable, "-m", "boat_twin.cli"]
STEP_S = 0.1
"""Time between two rows, s."""


def write_commands(path: Path, rows: int) -> None:
    """``rows`` command rows STEP_S apart, thrust and steering varying slowly."""
    t_s = np.arange(rows) * STEP_S
    thrust = 400.0 + 300.0 * np.sin(t_s / 200.0)
    angle = 0.2 * np.sin(t_s / 50.0)
    np.savetxt(path, np.column_stack([t_s, thrust, thrust, angle, angle]), fmt="%.4f", delimiter=",",
               header="t,thrust_left_N,thrust_right_N,angle_left_rad,angle_right_rad", comments="")


def run(commands: Path, out: Path) -> tuple[float, float, int]:
    """CPU s (user + system), wall s and progress lines of one ``simulate --commands``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.monotonic()
    done = subprocess.run([*BOAT_TWIN, "simulate", "--commands", str(commands), "--out", str(out)], check=True,
                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall_s = time.monotonic() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return cpu, wall_s, sum(line.startswith("simulate: ") for line in done.stderr.splitlines())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, nargs="+", default=[30_000, 300_000])
    args = parser.parse_args()
    costs = []
    with tempfile.TemporaryDirectory() as tmp:
        for rows in args.rows:
            commands = Path(tmp) / f"c{rows}.csv"
            write_commands(commands, rows)
            cpu, wall, lines = run(commands, Path(tmp) / f"o{rows}.mcap")
            simulated_s = (rows - 1) * STEP_S
            costs.append(cpu)
            print(f"{rows:>8,} rows ({simulated_s / 3600:.2f} h): {cpu:6.1f} s CPU, {wall:6.1f} s wall, "
                  f"{rows / cpu:,.0f} rows/s, {simulated_s / cpu:,.0f} simulated s per CPU s, {lines} progress line(s)")
    if len(costs) > 1:
        print(f"cost ratio {costs[-1] / costs[0]:.1f} for {args.rows[-1] / args.rows[0]:.0f} times the rows")


if __name__ == "__main__":
    main()
