"""Timing and heading effects on a boat the twin did not make: what the diagnosis names, and what it confuses.

Run: .venv/bin/python benchmarks/bench_timing_effects.py [--seed 1] [--duration 240] [--accelerometer]
Nothing is asserted: the script prints one Markdown row per case.

Each case is a trial of the default boat (instantaneous steering) integrated by test/independent.py's
``boat_trial`` (its own RK4 at 100 Hz, the default sensor noise), with one cause hidden in it, diagnosed against
the default model with the whole catalogue. The commands: thrust steps of 400 and 800 N per engine every 15 s
(7.8-10.8 m/s), a ±15° zigzag reversed every 10 s, or a course held 20 s then turned 10 s at 12° (every
heading). Per case: what was named (or reported ambiguous) with its size and 95 % interval, and the ΔBIC of the
three best candidates of the first round: how close the others come. ``--accelerometer``: the IMU also logs its
accelerometer (the twin's 0.039 m/s² noise), which the diagnosis compares (its longitudinal specific force).
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.diagnose.pipeline import diagnose_trial
from boat_twin.sensors.um7 import Um7Config
from boat_twin.vessel.params import VesselParams

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "test"))
from independent import boat_trial  # noqa: E402  (the tests' independent integrator)


def steps(t_s: float) -> float:
    """Thrust per engine, N."""
    return 400.0 + 400.0 * (int(max(t_s, 0.0) // 15.0) % 2)


def zigzag(t_s: float) -> float:
    """Steering, rad."""
    return math.radians(15.0) * (1.0 if int(max(t_s, 0.0) // 10.0) % 2 == 0 else -1.0)


def turns(t_s: float) -> float:
    """Steering, rad."""
    return math.radians(12.0) if t_s % 30.0 > 20.0 else 0.0


def straight(t_s: float) -> float:
    """Steering, rad."""
    return 0.0


def cruise(t_s: float) -> float:
    """Thrust per engine, N."""
    return 350.0


CASES: dict[str, tuple[Callable[[float], float], Callable[[float], float], dict[str, float]]] = {
    "delay 0.45 s, thrust steps + zigzag": (steps, zigzag, {"delay_s": 0.45}),
    "delay 0.45 s, thrust steps only": (steps, straight, {"delay_s": 0.45}),
    "delay 0.45 s, zigzag only": (cruise, zigzag, {"delay_s": 0.45}),
    "lag 1.5 s, thrust steps only": (steps, straight, {"lag_s": 1.5}),
    "GNSS latency 0.6 s, thrust steps only": (steps, straight, {"latency_s": 0.6}),
    "lag 1.5 s, thrust steps + zigzag": (steps, zigzag, {"lag_s": 1.5}),
    "yaw offset −3°, turns": (cruise, turns, {"yaw_offset_rad": math.radians(-3.0)}),
    "yaw offset −3°, straight": (cruise, straight, {"yaw_offset_rad": math.radians(-3.0)}),
    "clean, thrust steps + zigzag": (steps, zigzag, {}),
}
"""Case → (thrust per engine, steering, the cause given to the integrator)."""


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seed", type=int, default=1, help="noise seed of every case (default 1)")
    parser.add_argument("--duration", type=float, default=240.0, help="trial length, s (default 240)")
    parser.add_argument("--accelerometer", action="store_true",
                        help="the IMU also logs its accelerometer (0.039 m/s² noise): the diagnosis compares it")
    args = parser.parse_args()
    params = VesselParams(steering_rate_radps=0.0)
    base = TwinConfig(vessel=params)
    accel = {"accel_stdev_mps2": Um7Config().accel_stdev_mps2} if args.accelerometer else {}
    print(f"command: .venv/bin/python benchmarks/bench_timing_effects.py --seed {args.seed} --duration "
          f"{args.duration:g}" + (" --accelerometer" if args.accelerometer else "") + "\n")
    print("| case | named (size, 95 % interval) | ambiguous | unexplained | best ΔBIC, first round |")
    print("| --- | --- | --- | --- | --- |")
    for case, (thrust, steering, cause) in CASES.items():
        trial = boat_trial(params, thrust, steering, args.duration, np.random.default_rng(args.seed), **cause, **accel)
        result = diagnose_trial(trial, base).result
        named = "; ".join(
            f"`{v['effect']}` " + ", ".join(f"{k} {p:.4g} [{v['ci95'][k][0]:.4g}, {v['ci95'][k][1]:.4g}]"
                                           for k, p in v["parameters"].items())
            for v in result["verdict"]) or "–"
        ambiguous = " or ".join(result["ambiguous"]["effects"]) if result["ambiguous"] else "–"
        first = sorted((c for c in result["candidates"] if c["round"] == 1), key=lambda c: c["delta_bic"])[:3]
        best = ", ".join(f"{c['effect']} {c['delta_bic']:.0f}" for c in first)
        print(f"| {case} | {named} | {ambiguous} | {result['unexplained']} | {best} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
