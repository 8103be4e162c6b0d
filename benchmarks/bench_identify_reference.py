"""Issue 37: ``identify`` of the shipped sample against the simplest output-error fit of the same samples, both
whole processes measured in the same run (CPU time, user + system), and their ratio (the issue's target: <= 3).

The reference (:func:`reference_fit`, about 40 lines): read the trial with the package's reader, then fit
m·du/dt = T − a·u − b·u|u| (T the surge thrust Σ T_i·cos δ_i) by simulating the speed from the first measured
one with forward Euler on the trial's grid and scipy's least_squares on the speed over ground: no basis scan,
no cross-validation, no intervals, no report. ``identify`` does all of those (and writes its figures).

Run: .venv/bin/python benchmarks/bench_identify_reference.py [--repeats 2] [--trial bags/thrust_steps_sample]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = Path(sys.executable).parent / "boat-twin"
BOAT_TWIN = [str(SCRIPT)] if SCRIPT.exists() else [sys.executable, "-m", "boat_twin.cli"]


def reference_fit(path: Path) -> tuple[float, float, float, float]:
    """(mass kg, a N·s/m, b N·s²/m², speed RMSE m/s) of the output-error fit of m·du/dt = T − a·u − b·u|u|."""
    import numpy as np
    from scipy.optimize import least_squares

    from boat_twin.io.bags import read_trial

    trial = read_trial(path)
    speed = trial.speed_mps
    thrust = trial.surge_thrust_N
    known = np.isfinite(speed) & np.isfinite(thrust)
    t, speed, thrust = trial.t_s[known], speed[known], thrust[known]
    dt = np.diff(t)

    def simulate(x: np.ndarray) -> np.ndarray:
        mass, a, b = np.exp(x)
        u = np.empty_like(speed)
        u[0] = speed[0]
        for i in range(dt.size):
            u[i + 1] = u[i] + dt[i] * (thrust[i] - a * u[i] - b * u[i] * abs(u[i])) / mass
        return u

    fit = least_squares(lambda x: simulate(x) - speed, np.log([1000.0, 50.0, 5.0]), x_scale=1.0)
    mass, a, b = np.exp(fit.x)
    return float(mass), float(a), float(b), float(np.sqrt(np.mean(fit.fun**2)))


def cpu_s(argv: list[str]) -> float:
    """CPU time (user + system) of one process running ``argv`` (its output discarded; it must succeed)."""
    child = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(child.pid, 0)
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"{' '.join(argv)} failed:\n{child.stderr.read().decode() if child.stderr else ''}")
    return usage.ru_utime + usage.ru_stime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trial", type=Path, default=ROOT / "bags" / "thrust_steps_sample")
    parser.add_argument("--repeats", type=int, default=2, help="paired runs (reference, then identify)")
    parser.add_argument("--reference-only", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.reference_only:
        mass, a, b, rmse = reference_fit(args.trial)
        print(f"reference fit: mass {mass:.0f} kg, a {a:.2f} N·s/m, b {b:.3f} N·s²/m², speed RMSE {rmse:.3f} m/s")
        return
    subprocess.run([sys.executable, __file__, "--trial", str(args.trial), "--reference-only"], check=True)
    print("run  reference CPU s  identify CPU s  ratio", flush=True)
    with tempfile.TemporaryDirectory() as scratch:
        for k in range(args.repeats):
            reference = cpu_s([sys.executable, __file__, "--trial", str(args.trial), "--reference-only"])
            identify = cpu_s([*BOAT_TWIN, "identify", str(args.trial), "--out", str(Path(scratch) / "out"),
                              "--force"])
            print(f"{k + 1:>3} {reference:>16.2f} {identify:>15.2f} {identify / reference:>6.2f}", flush=True)


if __name__ == "__main__":
    main()
