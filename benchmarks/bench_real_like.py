"""Diagnosis on real-like data (issue 42): a boat the twin does not model, identified and diagnosed as a user would.

The boat (test/real_like.py) is written apart from the twin (its own equations and RK4 integrator, numpy
only): a 5.5 m, 950 kg outboard boat whose hull has a planing hump in its resistance, cubic sway and yaw damping, a
Munk moment and an engine lag, driven through waves (Ornstein-Uhlenbeck surge, sway and yaw disturbances) — none of
them in the twin's 3-DOF model. Its sensors: GNSS velocity (0.05 m/s, 0.1 s late), IMU heading (3°), gyro (0.06°/s).

1. Clean training recordings (random commands, ``--train`` of them, 300 s) → ``identify`` (resistance and
   mass, the boat's stated dimensions as ``--boat`` facts) → the turning coefficients (``identify
   --manoeuvring``'s fit) → the twin's model error, each training recording predicted by the twin identified
   without it (:func:`boat_twin.diagnose.model_error.measure_model_error`): the twin.yaml a user gets.
2. Held-out recordings (new seeds) with an effect hidden: the boat acting on its commands 0.5 s late, its left
   engine at 0.8× thrust, both at 0.85×, a steady current of 0.35 m/s, the IMU heading 8° off; and a gyro
   reading 1.1× (outside the catalogue); plus clean ones. Each diagnosed against the twin (``diagnose_trial``,
   what ``diagnose --config twin.yaml`` runs), and against the same twin without its model error (the rule
   before issue 42) with ``--compare``.

Scored: *named* = the verdict is the hidden effect alone, sized within 25 % (delay, thrust factors' deviation
from 1, current vector, heading offset); *wrong* = a verdict naming another cause; *false alarm* = a clean file
with anything named, ambiguous or unexplained; the gyro scale should be ``unexplained`` with an empty verdict.
Rates with exact (Clopper-Pearson) 95 % bounds.

    nice -n 10 .venv/bin/python benchmarks/bench_real_like.py --seeds 4 --clean 4 --json REAL.json
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from scipy.stats import beta

from boat_twin.config import TwinConfig
from boat_twin.diagnose.model_error import measure_model_error
from boat_twin.diagnose.pipeline import diagnose_trial
from boat_twin.ident.manoeuvring import fit_manoeuvring
from boat_twin.ident.pipeline import identify_and_resimulate
from boat_twin.ident.report import identified_twin
from boat_twin.io.trial import Trial
from boat_twin.model_error import ModelError

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "test"))
from real_like import Boat, Hidden, simulate  # noqa: E402  (run as a script)

BOAT_FACTS = {"length_m": 5.5, "beam_m": 2.3, "engine_x_m": -2.4, "engine_y_m": 0.5,
              "max_steering_rad": math.radians(30.0),
              "steering_rate_radps": math.radians(20.0), "bollard_thrust_N": 1800.0,
              "engine_power_W": 80000.0}
"""What the user states of the boat (``identify --boat``): its dimensions and engines, not its hydrodynamics."""
EFFECT_NAMES = ("command_delay", "one_side", "both_sides", "current", "heading_offset")
"""The hidden catalogue effects, each on ``--seeds`` held-out recordings."""
PROBE = "gyro_scale"
"""The hidden effect outside the catalogue: the gyro reads 1.1× the yaw rate."""


HIDDEN = {"clean": Hidden(), "command_delay": Hidden(delay_s=0.5), "one_side": Hidden(left_factor=0.8),
          "both_sides": Hidden(left_factor=0.85, right_factor=0.85), "current": Hidden(current_mps=(0.25, -0.25)),
          "heading_offset": Hidden(heading_offset_rad=math.radians(8.0)), PROBE: Hidden(gyro_scale=1.1)}


def identified(trials: list[Trial]) -> TwinConfig:
    """``identify --boat`` then the turning coefficients (``identify --manoeuvring``) on ``trials``."""
    found = identify_and_resimulate(trials, boat=BOAT_FACTS)
    twin = identified_twin(found)
    if twin is None:
        raise SystemExit(f"identify built no twin: {found.twin_error}")
    return fit_manoeuvring(trials, twin).config


def train(boat: Boat, count: int, duration_s: float) -> TwinConfig:
    """The twin.yaml a user gets from ``count`` clean recordings: identified, its model error held out."""
    trials = [simulate(boat, Hidden(), duration_s, 1000 + k) for k in range(count)]
    twin = identified(trials)
    folds = [identified(trials[:k] + trials[k + 1:]) for k in range(count)]
    return replace(twin, model_error=measure_model_error(trials, folds, heldout=True))


def score(kind: str, result: dict[str, Any]) -> str:
    """'named' (sized within 25 %), 'mis-sized' (the right cause alone, its size further off), 'wrong', 'missed',
    'unexplained' (the gyro scale) or, on a clean file, 'silent' / 'alarm'."""
    verdict = {v["effect"]: v["parameters"] for v in result["verdict"]}
    if kind == "clean":
        return "silent" if not verdict and not result["ambiguous"] and not result["unexplained"] else "alarm"
    if kind == PROBE:
        return "wrong" if verdict else ("unexplained" if result["unexplained"] else "missed")
    want = {"command_delay": "command_delay", "one_side": "thrust_asymmetry", "both_sides": "thrust_asymmetry",
            "current": "water_current", "heading_offset": "heading_offset"}[kind]
    if any(name != want for name in verdict):
        return "wrong"
    if want not in verdict:
        return "missed"
    return "named" if sized(kind, verdict[want]) else "mis-sized"


def sized(kind: str, found: dict[str, float]) -> bool:
    """The named size within 25 % of the hidden one."""
    hidden = HIDDEN[kind]
    if kind == "command_delay":
        return abs(found["delay_s"] - hidden.delay_s) <= 0.25 * hidden.delay_s
    if kind in ("one_side", "both_sides"):
        true = np.array([hidden.left_factor, hidden.right_factor]) - 1.0
        got = np.array([found["left_factor"], found["right_factor"]]) - 1.0
        return bool(np.max(np.abs(got - true)) <= 0.25 * np.max(np.abs(true)))
    if kind == "current":
        true = np.array(hidden.current_mps)
        return bool(np.hypot(*(np.array([found["east_mps"], found["north_mps"]]) - true)) <= 0.25 * np.hypot(*true))
    return abs(found["offset_rad"] - hidden.heading_offset_rad) <= 0.25 * hidden.heading_offset_rad


def bounds(k: int, n: int) -> tuple[float, float]:
    """Exact (Clopper-Pearson) 95 % interval of a rate k/n."""
    low = 0.0 if k == 0 else float(beta.ppf(0.025, k, n - k + 1))
    high = 1.0 if k == n else float(beta.ppf(0.975, k + 1, n - k))
    return low, high


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--train", type=int, default=3, help="clean training recordings (default 3)")
    parser.add_argument("--seeds", type=int, default=4, help="held-out recordings per hidden effect (default 4)")
    parser.add_argument("--clean", type=int, default=4, help="clean held-out recordings (default 4)")
    parser.add_argument("--probes", type=int, default=2, help="gyro-scale recordings (default 2)")
    parser.add_argument("--duration", type=float, default=300.0, help="recording length, s (default 300)")
    parser.add_argument("--compare", action="store_true", help="also diagnose without the model error")
    parser.add_argument("--json", type=Path, help="write every row here")
    args = parser.parse_args()
    boat = Boat()
    start = time.perf_counter()
    twin = train(boat, args.train, args.duration)
    print(f"trained on {args.train} recordings in {time.perf_counter() - start:.0f} s; model error: "
          + json.dumps(twin.model_error.to_dict()), flush=True)
    jobs = [(kind, 2000 + 100 * i + k) for i, kind in enumerate(EFFECT_NAMES) for k in range(args.seeds)]
    jobs += [("clean", 3000 + k) for k in range(args.clean)] + [(PROBE, 4000 + k) for k in range(args.probes)]
    twins = {"model_error": twin} | ({"noise_only": replace(twin, model_error=ModelError())} if args.compare else {})
    rows = []
    for kind, seed in jobs:
        trial = simulate(boat, HIDDEN[kind], args.duration, seed)
        for rule, config in twins.items():
            result = diagnose_trial(trial, config).result
            row = {"kind": kind, "seed": seed, "rule": rule, "outcome": score(kind, result),
                   "verdict": result["verdict"], "unexplained": bool(result["unexplained"]),
                   "ambiguous": result["ambiguous"]}
            rows.append(row)
            print(f"{kind:15s} seed {seed} {rule:11s} {row['outcome']:11s} "
                  + ", ".join(f"{v['effect']} {v['parameters']}" for v in result["verdict"]), flush=True)
    for rule in twins:
        mine = [r for r in rows if r["rule"] == rule]
        effects = [r for r in mine if r["kind"] in EFFECT_NAMES]
        clean = [r for r in mine if r["kind"] == "clean"]
        probes = [r for r in mine if r["kind"] == PROBE]
        for label, k, n in (("named", sum(r["outcome"] == "named" for r in effects), len(effects)),
                            ("wrong", sum(r["outcome"] == "wrong" for r in effects + probes), len(effects + probes)),
                            ("false alarms", sum(r["outcome"] == "alarm" for r in clean), len(clean)),
                            ("gyro scale unexplained", sum(r["outcome"] == "unexplained" for r in probes),
                             len(probes))):
            if n:
                low, high = bounds(k, n)
                print(f"{rule}: {label} {k}/{n}, 95 % [{low:.2f}, {high:.2f}]")
    print(f"total {time.perf_counter() - start:.0f} s")
    if args.json:
        args.json.write_text(json.dumps({"model_error": twin.model_error.to_dict(), "rows": rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
