"""Diagnosis on real-like data (issue 42): a boat the twin does not model, identified and diagnosed as a user would.

The boat here is written apart from the twin (its own equations and RK4 integrator, numpy only): a 5.5 m,
950 kg outboard boat whose hull has a planing hump in its resistance, cubic sway and yaw damping, a Munk moment
and an engine lag, driven through waves (Ornstein-Uhlenbeck surge, sway and yaw disturbances) — none of them in
the twin's 3-DOF model. Its sensors: GNSS velocity (0.05 m/s, 0.1 s late), IMU heading (3°) and gyro (0.06°/s).

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
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from scipy.stats import beta

from boat_twin.config import TwinConfig
from boat_twin.diagnose.model_error import measure_model_error
from boat_twin.diagnose.pipeline import diagnose_trial
from boat_twin.fleet.reports import identified_twin
from boat_twin.ident.manoeuvring import fit_manoeuvring
from boat_twin.ident.pipeline import identify_and_resimulate
from boat_twin.io.trial import Trial, TrialMetadata
from boat_twin.model_error import ModelError

DT_S = 0.1
"""Log period, s (10 Hz); the boat is integrated at 100 Hz."""
BOAT_FACTS = {"length_m": 5.5, "beam_m": 2.3, "engine_x_m": -2.4, "max_steering_rad": math.radians(30.0),
              "steering_rate_radps": math.radians(20.0), "bollard_thrust_N": 1800.0}
"""What the user states of the boat (``identify --boat``): its dimensions and engines, not its hydrodynamics."""
EFFECT_NAMES = ("command_delay", "one_side", "both_sides", "current", "heading_offset")
"""The hidden catalogue effects, each on ``--seeds`` held-out recordings."""
PROBE = "gyro_scale"
"""The hidden effect outside the catalogue: the gyro reads 1.1× the yaw rate."""


@dataclass(frozen=True)
class Boat:
    """The independent boat (SI). Not the twin's equations: see the module docstring."""

    mass_kg: float = 950.0
    surge_added_kg: float = 70.0
    sway_added_kg: float = 600.0
    yaw_inertia_kgm2: float = 2600.0
    linear_drag_Nspm: float = 45.0
    quadratic_drag_Ns2pm2: float = 16.0
    hump_N: float = 260.0
    """Planing hump: an extra resistance hump_N·exp(−((u − 4.5)/1.4)²) around 4.5 m/s."""
    sway_linear_Nspm2: float = 380.0
    sway_cubic_Ns3pm3: float = 900.0
    yaw_linear_Nms: float = 1100.0
    yaw_cubic_Nms3: float = 2.0e4
    engine_x_m: float = -2.4
    engine_lag_s: float = 0.35
    max_steering_rad: float = math.radians(30.0)
    steering_rate_radps: float = math.radians(20.0)
    wave_force_N: float = 45.0
    wave_moment_Nm: float = 90.0
    wave_time_s: float = 2.5


@dataclass(frozen=True)
class Hidden:
    """What a recording hides (defaults: nothing)."""

    delay_s: float = 0.0
    left_factor: float = 1.0
    right_factor: float = 1.0
    current_mps: tuple[float, float] = (0.0, 0.0)
    heading_offset_rad: float = 0.0
    gyro_scale: float = 1.0


HIDDEN = {"clean": Hidden(), "command_delay": Hidden(delay_s=0.5), "one_side": Hidden(left_factor=0.8),
          "both_sides": Hidden(left_factor=0.85, right_factor=0.85), "current": Hidden(current_mps=(0.25, -0.25)),
          "heading_offset": Hidden(heading_offset_rad=math.radians(8.0)), PROBE: Hidden(gyro_scale=1.1)}


def commands(rng: np.random.Generator, n: int, boat: Boat) -> np.ndarray:
    """(n, 2) random commands on the log grid: thrust per engine (N, both alike, 20-100 % of 1800 N held
    8-25 s) and steering (rad, within ±60 % of the limit, held 4-15 s)."""
    out = np.zeros((n, 2))
    for column, (low, high, hold) in enumerate(((0.2, 1.0, (8.0, 25.0)), (-0.6, 0.6, (4.0, 15.0)))):
        i = 0
        while i < n:
            span = int(rng.uniform(*hold) / DT_S)
            level = rng.uniform(low, high)
            out[i:i + span, column] = level * (1800.0 if column == 0 else boat.max_steering_rad)
            i += span
    return out


def simulate(boat: Boat, hidden: Hidden, duration_s: float, seed: int) -> Trial:
    """One recording of ``boat`` with ``hidden``, random commands of ``seed``."""
    rng = np.random.default_rng(seed)
    n = int(round(duration_s / DT_S)) + 1
    cmd = commands(rng, n, boat)
    delay = int(round(hidden.delay_s / DT_S))
    acting = np.vstack([np.repeat(cmd[:1], delay, axis=0), cmd])[:n]
    m11, m22 = boat.mass_kg + boat.surge_added_kg, boat.mass_kg + boat.sway_added_kg
    substeps, h = 10, DT_S / 10
    wave = np.zeros(3)
    wave_scale = np.array([boat.wave_force_N, boat.wave_force_N, boat.wave_moment_Nm])
    decay = math.exp(-h / boat.wave_time_s)
    # state: x, y, psi, u, v, r, thrust_left, thrust_right, steering
    s = np.array([0.0, 0.0, 0.4, 4.0, 0.0, 0.0, cmd[0, 0], cmd[0, 0], cmd[0, 1]])

    def rates(s: np.ndarray, target: np.ndarray, wave: np.ndarray) -> np.ndarray:
        psi, u, v, r, tl, tr, d = s[2:]
        thrust = hidden.left_factor * tl + hidden.right_factor * tr
        fx, fy = thrust * math.cos(d), thrust * math.sin(d)
        drag = (boat.linear_drag_Nspm * u + boat.quadratic_drag_Ns2pm2 * u * abs(u)
                + boat.hump_N * math.exp(-((abs(u) - 4.5) / 1.4) ** 2) * math.copysign(1.0, u))
        du = (fx + m22 * v * r - drag + wave[0]) / m11
        dv = (fy - m11 * u * r - boat.sway_linear_Nspm2 * abs(u) * v - boat.sway_cubic_Ns3pm3 * v**3 + wave[1]) / m22
        munk = (m22 - m11) * u * v
        dr = (boat.engine_x_m * fy - munk - boat.yaw_linear_Nms * abs(u) * r - boat.yaw_cubic_Nms3 * r**3
              + wave[2]) / boat.yaw_inertia_kgm2
        dt_thrust = (target[0] - np.array([tl, tr])) / boat.engine_lag_s
        dd = float(np.clip((target[1] - d) / h, -boat.steering_rate_radps, boat.steering_rate_radps))
        east, north = hidden.current_mps
        return np.array([u * math.cos(psi) - v * math.sin(psi) + east, u * math.sin(psi) + v * math.cos(psi) + north,
                         r, du, dv, dr, dt_thrust[0], dt_thrust[1], dd])

    states = np.zeros((n, s.size))
    for i in range(n):
        states[i] = s
        for _ in range(substeps):
            wave = wave * decay + wave_scale * math.sqrt(1 - decay**2) * rng.standard_normal(3)
            k1 = rates(s, acting[i], wave)
            k2 = rates(s + 0.5 * h * k1, acting[i], wave)
            k3 = rates(s + 0.5 * h * k2, acting[i], wave)
            k4 = rates(s + h * k3, acting[i], wave)
            s = s + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
    return _recorded(states, cmd, hidden, rng, f"real-like seed {seed}")


def _recorded(states: np.ndarray, cmd: np.ndarray, hidden: Hidden, rng: np.random.Generator, source: str) -> Trial:
    """The sensors' record of ``states`` (a Trial as the bag reader gives it)."""
    n = len(states)
    psi, u, v, r = states[:, 2], states[:, 3], states[:, 4], states[:, 5]
    east, north = hidden.current_mps
    vel_e = u * np.cos(psi) - v * np.sin(psi) + east
    vel_n = u * np.sin(psi) + v * np.cos(psi) + north
    late = np.maximum(np.arange(n) - 1, 0)  # GNSS 0.1 s late

    def noisy(x: np.ndarray, sigma: float) -> np.ndarray:
        return x + rng.normal(0.0, sigma, n)

    heading = noisy(psi + hidden.heading_offset_rad, math.radians(3.0))
    return Trial(
        t_s=np.arange(n) * DT_S, thrust_left_N=cmd[:, 0].copy(), thrust_right_N=cmd[:, 0].copy(),
        angle_left_rad=cmd[:, 1].copy(), angle_right_rad=cmd[:, 1].copy(), lat_deg=np.full(n, np.nan),
        lon_deg=np.full(n, np.nan), heading_rad=np.angle(np.exp(1j * heading)),
        yaw_rate_radps=noisy(hidden.gyro_scale * r, math.radians(0.06)), accel_x_mps2=np.full(n, np.nan),
        accel_y_mps2=np.full(n, np.nan), east_m=noisy(states[late, 0], 2.1), north_m=noisy(states[late, 1], 2.1),
        vel_east_mps=noisy(vel_e[late], 0.05), vel_north_mps=noisy(vel_n[late], 0.05),
        metadata=TrialMetadata(source=source))


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
    """'named', 'wrong', 'missed', 'unexplained' or, on a clean file, 'silent' / 'alarm'."""
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
    return "named" if sized(kind, verdict[want]) else "missed"


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
