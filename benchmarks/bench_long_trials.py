"""Issue 37: cost in the recording's length. ``identify`` (a thrust-steps trial), ``diagnose`` and ``follow`` (a
random-commands trial) of a short and a long simulated trial (default 1 h and 6 h), each a fresh ``boat-twin``
process: its CPU time (user + system) and peak resident memory, and the ratios long / short measured in the same
run. Linear costs give a CPU ratio of the length ratio (6) or a little less (start-up is paid once); the issue's
targets: CPU ratio <= 8, memory ratio <= 1.3 (memory that grows with the recording at most as its arrays do).

Run: .venv/bin/python benchmarks/bench_long_trials.py [--short-s 3600] [--long-s 21600]
     [--verbs identify diagnose follow] [--trials DIR]   (DIR keeps the simulated trials for another run)
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

SCRIPT = Path(sys.executable).parent / "boat-twin"
BOAT_TWIN = [str(SCRIPT)] if SCRIPT.exists() else [sys.executable, "-m", "boat_twin.cli"]
SCENARIO = {"identify": "thrust-steps", "diagnose": "random", "follow": "random"}
"""The trial each verb reads."""


def run_measured(argv: list[str]) -> tuple[float, float]:
    """(CPU s, peak RSS MB) of one ``boat-twin`` process running ``argv`` (its output discarded; it must succeed)."""
    child = subprocess.Popen([*BOAT_TWIN, *argv], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(child.pid, 0)
    child.returncode = os.waitstatus_to_exitcode(status)
    err = child.stderr.read().decode() if child.stderr else ""
    if child.returncode != 0:
        raise SystemExit(f"boat-twin {' '.join(argv)}: exit {child.returncode}\n{err}")
    return usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024.0


def trial(directory: Path, scenario: str, duration_s: float) -> Path:
    """The simulated trial (seed 0), made once per directory."""
    path = directory / f"{scenario}_{duration_s:g}s.mcap"
    if not path.exists():
        run_measured(["simulate", scenario, "--duration", f"{duration_s:g}", "--out", str(path)])
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--short-s", type=float, default=3600.0)
    parser.add_argument("--long-s", type=float, default=21600.0)
    parser.add_argument("--verbs", nargs="+", choices=tuple(SCENARIO), default=list(SCENARIO))
    parser.add_argument("--trials", type=Path, help="directory keeping the simulated trials (default: a temporary one)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        trials = args.trials or Path(scratch)
        trials.mkdir(parents=True, exist_ok=True)
        print(f"verb       {args.short_s:>7g} s: CPU s  peak MB   {args.long_s:>7g} s: CPU s  peak MB   "
              f"ratio CPU  ratio memory  (length ratio {args.long_s / args.short_s:g})", flush=True)
        for verb in args.verbs:
            figures = []
            for duration_s in (args.short_s, args.long_s):
                out = Path(scratch) / f"{verb}_{duration_s:g}"
                figures.append(run_measured([verb, str(trial(trials, SCENARIO[verb], duration_s)), "--out", str(out),
                                             "--force"]))
            (short_cpu, short_mb), (long_cpu, long_mb) = figures
            print(f"{verb:<10} {short_cpu:>16.1f} {short_mb:>8.0f}   {long_cpu:>16.1f} {long_mb:>8.0f}   "
                  f"{long_cpu / short_cpu:>9.2f}  {long_mb / short_mb:>12.2f}", flush=True)


if __name__ == "__main__":
    main()
