"""Issue 37: cost in the recording's length. ``identify``, ``diagnose`` and ``follow`` of a short and a long
simulated trial of random commands drawn over the whole trial (default 1 h and 6 h; the default boat, seed 0,
sensor noise: ``diagnose.hidden.write_trial``; the registry's ``random`` and ``thrust-steps`` hold their last
command after 600 s and about 1,000 s), each a fresh ``boat-twin`` process: its CPU time (user + system) and
peak resident memory, and the ratios long / short measured in the same run. Linear costs give a CPU ratio of
the length ratio (6) or a little less (start-up is paid once); the issue's targets: CPU ratio <= 8, memory
ratio <= 1.3.

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
VERBS = ("identify", "diagnose", "follow")


def run_measured(argv: list[str]) -> tuple[float, float]:
    """(CPU s, peak RSS MB) of one ``boat-twin`` process running ``argv`` (its output discarded; it must succeed)."""
    child = subprocess.Popen([*BOAT_TWIN, *argv], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(child.pid, 0)
    child.returncode = os.waitstatus_to_exitcode(status)
    err = child.stderr.read().decode() if child.stderr else ""
    if child.returncode != 0:
        raise SystemExit(f"boat-twin {' '.join(argv)}: exit {child.returncode}\n{err}")
    return usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024.0


def trial(directory: Path, duration_s: float) -> Path:
    """The simulated trial, made once per directory."""
    from boat_twin.config import TwinConfig
    from boat_twin.diagnose.hidden import write_trial

    path = directory / f"random_{duration_s:g}s.mcap"
    if not path.exists():
        write_trial(path, TwinConfig(), "random", 0, duration_s)
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--short-s", type=float, default=3600.0)
    parser.add_argument("--long-s", type=float, default=21600.0)
    parser.add_argument("--verbs", nargs="+", choices=VERBS, default=list(VERBS))
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
                figures.append(run_measured([verb, str(trial(trials, duration_s)), "--out", str(out),
                                             "--force"]))
            (short_cpu, short_mb), (long_cpu, long_mb) = figures
            print(f"{verb:<10} {short_cpu:>16.1f} {short_mb:>8.0f}   {long_cpu:>16.1f} {long_mb:>8.0f}   "
                  f"{long_cpu / short_cpu:>9.2f}  {long_mb / short_mb:>12.2f}", flush=True)


if __name__ == "__main__":
    main()
