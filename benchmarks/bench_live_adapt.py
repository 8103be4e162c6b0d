"""The live surge adaptation (boat_twin.shadow.adapt: the output-error fit over a moving horizon) on many boats:

A. interval coverage: boats whose mass and resistance differ from the default twin by a random −30 … +30 %,
   followed from the default twin; how often the adopted model's and the latest fit's 95 % intervals of the mass
   and the resistance factor hold the truth, and the mass error. On the twin's own trials (random commands) and
   on an independent integrator's boat (test/independent.py: classic RK4 of the same equations written apart
   from the twin's kernel, thrust and steering changing at random);
B. flapping: a twin started at the true model; adoptions and reversals over the trial (the true model should
   stay, surge and turning), the largest relative mass change adopted;
Z. constant-thrust zigzags (20°/20°) of the configured boat, followed from it: the mass is seen only in the
   speed each turn costs; the mass intervals of the fits standing at each minute once the horizon is full, and what
   is adopted;
T. the live turning adaptation (boat_twin.shadow.turning): boats whose yaw damping and yaw inertia differ from the
   default twin by a random −25 … +25 %, followed from the default twin; whether the turning coefficients are
   adopted, how often their 95 % intervals hold the truth, the yaw-damping error, the yaw-rate innovation ratio
   in the first minute and the last, and CPU per boat;
O. T's independent boats fitted offline (fit_manoeuvring over the live coefficients, from the true boat, on the
   stretch the live fit trains on at the end: 300-770 s), the commands at their issue times and on the log's
   grid (``command_switch_s`` dropped), and at the issue times with the surge model's scale fitted as the live fit
   does (``SURGE_FACTORS``): how often the intervals hold the truth, the errors.

Run: .venv/bin/python benchmarks/bench_live_adapt.py [--boats 6] [--duration-s 900] [--only BAZTO]
     [--boat-index I]  (T only: one boat of each source)
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import fields, replace
from pathlib import Path

import numpy as np
import pymap3d

from boat_twin.config import TwinConfig
from boat_twin.diagnose.hidden import scenario
from boat_twin.ident.manoeuvring import SURGE_FACTOR_KEYS, fit_manoeuvring
from boat_twin.io.trial import Trial
from boat_twin.shadow.follow import follow_trial
from boat_twin.shadow.session import ShadowSettings
from boat_twin.shadow.turning import LIVE_KEYS, coefficients
from boat_twin.twin.sea_trial import measured_trial, run_sea_trial

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "test"))
from bench_follow import boat  # noqa: E402  (run as a script: benchmarks/ is on the path)
from independent import boat_trial  # noqa: E402

NO_DIAGNOSIS = ShadowSettings(diagnose=False)


def twin_trial(config: TwinConfig, duration_s: float, seed: int) -> Trial:
    run = run_sea_trial(config, scenario("random", TwinConfig().vessel, np.random.default_rng(seed), duration_s),
                        seed)
    return measured_trial(run.record, 0, config, np.random.default_rng(seed + 100))


def independent(config: TwinConfig, duration_s: float, seed: int) -> Trial:
    """The independent integrator: each engine's thrust held 10-40 s at 60-700 N, steering ±15° held 5-30 s."""
    rng = np.random.default_rng(seed)
    holds = np.cumsum(rng.uniform(10.0, 40.0, int(duration_s / 10) + 2))
    levels = rng.uniform(60.0, 700.0, holds.size)
    turns = np.cumsum(rng.uniform(5.0, 30.0, int(duration_s / 5) + 2))
    angles = np.where(rng.random(turns.size) < 0.5, 0.0, rng.uniform(-0.26, 0.26, turns.size))
    data = boat_trial(config.vessel, lambda t: float(levels[np.searchsorted(holds, t)]),
                      lambda t: float(angles[np.searchsorted(turns, t)]), duration_s, rng, initial_surge_mps=3.0)
    lat, lon, _ = pymap3d.enu2geodetic(data.east_m, data.north_m, 0.0, 43.0, 131.0, 0.0)
    return replace(data, lat_deg=lat, lon_deg=lon)


def inside(interval: list[float], value: float) -> bool:
    return bool(interval[0] <= value <= interval[1])


def study_coverage(boats: int, duration_s: float) -> None:
    rng = np.random.default_rng(5)
    for source, make in (("twin", twin_trial), ("independent", independent)):
        rows = []
        cpu = time.process_time()
        for b in range(boats):
            mass_f, res_f = rng.uniform(0.7, 1.3, 2)
            truth = boat(float(mass_f), float(res_f))
            result = follow_trial(make(truth, duration_s, 40 + b), TwinConfig(), NO_DIAGNOSIS)
            surge, fit = result.final["model"]["surge"], result.final["model"]["latest_fit"]
            true_mass = truth.vessel.mass_kg
            rows.append((surge["mass_kg"] / true_mass - 1, inside(surge["mass_ci95_kg"], true_mass),
                         inside(surge["resistance_factor_ci95"], float(res_f)),
                         fit is not None and inside(fit["mass_ci95_kg"], true_mass),
                         fit is not None and inside(fit["resistance_factor_ci95"], float(res_f)),
                         surge["curve"]))
            print(f"   {source} boat {b}: mass ×{mass_f:.3f} resistance ×{res_f:.3f}: adopted "
                  f"{surge['mass_kg']:.0f} kg "
                  f"[{surge['mass_ci95_kg'][0]:.0f}, {surge['mass_ci95_kg'][1]:.0f}] (true {true_mass:.0f}), "
                  f"×{surge['resistance_factor']:.3f} [{surge['resistance_factor_ci95'][0]:.3f}, "
                  f"{surge['resistance_factor_ci95'][1]:.3f}] ({surge['curve']})", flush=True)
        errors = np.abs([r[0] for r in rows])
        n = len(rows)
        print(f"A  {source}: {n} boats, {duration_s / 60:.0f} min each: adopted mass interval holds the truth "
              f"{sum(r[1] for r in rows)}/{n}, resistance factor {sum(r[2] for r in rows)}/{n}; latest fit "
              f"{sum(r[3] for r in rows)}/{n} and {sum(r[4] for r in rows)}/{n} (target ~95 %); mass error median "
              f"{np.median(errors):.1%}, max {np.max(errors):.1%}; {(time.process_time() - cpu) / n:.1f} s CPU per "
              f"boat", flush=True)


def study_flapping(duration_s: float, seeds: int) -> None:
    for seed in range(seeds):
        truth = boat(1.1, 0.9)
        result = follow_trial(twin_trial(truth, duration_s, 60 + seed), truth, NO_DIAGNOSIS)
        adopted = [line for line in result.log if line.startswith("adopted surge")]
        reverted = [line for line in result.log if line.startswith("reverted surge")]
        turning = [line for line in result.log if line.startswith(("adopted turning", "reverted turning"))]
        masses = [m["surge"]["mass_kg"] for m in result.models]
        swing = max(abs(m / truth.vessel.mass_kg - 1) for m in masses) if masses else math.nan
        print(f"B  started at the truth, seed {seed}, {duration_s / 60:.0f} min: {len(adopted)} adoptions, "
              f"{len(reverted)} reversals; largest mass departure {swing:.1%}; turning: "
              f"{result.final['model']['turning']['fits']} fits, {len(turning)} adoptions or reversals", flush=True)


def study_zigzag(duration_s: float, seeds: int) -> None:
    config = TwinConfig()
    true_mass = config.vessel.mass_kg
    held, fits, errors = 0, 0, []
    for seed in range(5, 5 + seeds):
        run = run_sea_trial(config, scenario("zigzag", config.vessel, np.random.default_rng(seed), duration_s), seed)
        result = follow_trial(measured_trial(run.record, 0, config, np.random.default_rng(seed + 100)), config,
                              NO_DIAGNOSIS)
        full: list[dict] = []  # each fit once (a fit stands for several minutes while the model is confirmed)
        for m in result.models:
            fit = m["latest_fit"]
            if m["t_s"] >= 600.0 and fit is not None and not fit["mass_held"] and fit not in full:
                full.append(fit)
        inside_ci = sum(inside(f["mass_ci95_kg"], true_mass) for f in full)
        held, fits = held + inside_ci, fits + len(full)
        errors += [f["mass_kg"] / true_mass - 1 for f in full]
        surge = result.final["model"]["surge"]
        masses = ", ".join(f"{f['mass_kg']:.0f}" for f in full)
        print(f"   zigzag seed {seed}: fits from minute 10 {masses} kg, "
              f"intervals holding {true_mass:.0f} kg {inside_ci}/{len(full)}; adopted {result.final['model']['swaps']}"
              f" time(s), final {surge['mass_kg']:.0f} kg", flush=True)
    print(f"Z  constant-thrust zigzags, {seeds} trials of {duration_s / 60:.0f} min: full-horizon fits' mass "
          f"intervals hold the truth {held}/{fits}; mass error median {np.median(errors):+.1%}, range "
          f"{min(errors):+.1%} … {max(errors):+.1%}", flush=True)


def study_turning(boats: int, duration_s: float, boat_index: int | None = None) -> None:
    rng = np.random.default_rng(7)
    for source, make in (("twin", twin_trial), ("independent", independent)):
        rows = []
        cpu = time.process_time()
        for b in range(boats):
            damping_f, inertia_f = rng.uniform(0.75, 1.25, 2)
            if boat_index is not None and b != boat_index:
                continue
            base = TwinConfig() if source == "twin" else TwinConfig(vessel=replace(TwinConfig().vessel,
                                                                                     steering_rate_radps=0.0))
            derived = coefficients(base.vessel)  # the integrator's outboards swing instantly: the model says so
            truth = replace(base, vessel=replace(base.vessel, manoeuvring={
                "yaw_damping_Nms": derived["yaw_damping_Nms"] * damping_f,
                "m33_kgm2": derived["m33_kgm2"] * inertia_f}))
            result = follow_trial(make(truth, duration_s, 80 + b), base, NO_DIAGNOSIS)
            turning, surge = result.final["model"]["turning"], result.final["model"]["surge"]
            true = coefficients(truth.vessel)
            held = sum(turning["ci95"][k][0] <= true[k] <= turning["ci95"][k][1] for k in turning["ci95"])
            latest = turning["latest_fit"]
            latest_held = (sum(latest["ci95"][k][0] <= true[k] <= latest["ci95"][k][1] for k in latest["ci95"])
                           if latest is not None and latest["ci95"] else None)
            each = "; ".join(f"{k.split('_')[0]}{'' if k != 'yaw_quadratic_Nms2' else '2'} "
                             f"{turning['coefficients'][k] / true[k] - 1:+.1%}"
                             f"{'' if turning['ci95'][k][0] <= true[k] <= turning['ci95'][k][1] else '*'}"
                             for k in turning["ci95"])
            ratios = [e["yaw_rate_innovation_ratio"] for e in result.timeline]
            error = turning["coefficients"]["yaw_damping_Nms"] / true["yaw_damping_Nms"] - 1
            rows.append((turning["fitted"], held, error, ratios[0], ratios[-1], latest_held))
            ci = turning["ci95"].get("yaw_damping_Nms", [math.nan, math.nan])
            print(f"   {source} boat {b}: yaw damping ×{damping_f:.3f}, m33 ×{inertia_f:.3f}: "
                  f"{'adopted' if turning['fitted'] else 'NOT adopted'} ({turning['fits']} fits, "
                  f"{turning['swaps']} swaps), yaw damping {error:+.1%} [{ci[0] / true['yaw_damping_Nms'] - 1:+.1%}, "
                  f"{ci[1] / true['yaw_damping_Nms'] - 1:+.1%}], intervals holding the truth {held}/{len(LIVE_KEYS)}"
                  f" ({each}; * outside), latest fit's {latest_held}; yaw-rate innovation ratio {ratios[0]:.2f} → "
                  f"{ratios[-1]:.2f}; surge {surge['mass_kg']:.0f} kg [{surge['mass_ci95_kg'][0]:.0f}, "
                  f"{surge['mass_ci95_kg'][1]:.0f}] (true {truth.vessel.mass_kg:.0f})", flush=True)
        n = len(rows)
        adopted = [r for r in rows if r[0]]
        print(f"T  {source}: {n} boats, {duration_s / 60:.0f} min each: turning adopted on {len(adopted)}/{n}; "
              f"intervals holding the truth {sum(r[1] for r in adopted)}/{len(adopted) * len(LIVE_KEYS)} "
              f"(target ~95 %), the latest fit's {sum(r[5] or 0 for r in rows)}/"
              f"{sum(r[5] is not None for r in rows) * len(LIVE_KEYS)}; yaw-damping error median "
              f"{np.median(np.abs([r[2] for r in rows])):.1%}, max {np.max(np.abs([r[2] for r in rows])):.1%}; "
              f"yaw-rate innovation ratio first minute "
              f"median "
              f"{np.median([r[3] for r in rows]):.2f}, last {np.median([r[4] for r in rows]):.2f}; "
              f"{(time.process_time() - cpu) / n:.1f} s CPU per boat", flush=True)


def study_offline(boats: int, duration_s: float) -> None:
    rng = np.random.default_rng(7)  # T's boats
    for b in range(boats):
        damping_f, inertia_f = rng.uniform(0.75, 1.25, 2)
        base = TwinConfig(vessel=replace(TwinConfig().vessel, steering_rate_radps=0.0))
        derived = coefficients(base.vessel)
        truth = replace(base, vessel=replace(base.vessel, manoeuvring={
            "yaw_damping_Nms": derived["yaw_damping_Nms"] * damping_f, "m33_kgm2": derived["m33_kgm2"] * inertia_f}))
        trial = independent(truth, duration_s, 80 + b)
        n = trial.t_s.size
        stretch = replace(trial, **{f.name: getattr(trial, f.name)[3000:7701] for f in fields(trial)
                                    if isinstance(getattr(trial, f.name), np.ndarray)
                                    and getattr(trial, f.name).shape[:1] == (n,)})
        true = coefficients(truth.vessel)
        for timing, data, free in (("issue times", stretch, LIVE_KEYS),
                                   ("log grid", replace(stretch, command_switch_s=None), LIVE_KEYS),
                                   ("issue times, surge scale fitted", stretch, LIVE_KEYS + SURGE_FACTOR_KEYS)):
            fit = fit_manoeuvring([data], truth, free=free)
            held = sum(fit.ci95[k][0] <= true[k] <= fit.ci95[k][1] for k in LIVE_KEYS)
            errors = ", ".join(f"{k} {fit.values[k] / true[k] - 1:+.1%}" for k in LIVE_KEYS)
            print(f"O  independent boat {b}, {timing}: intervals holding the truth {held}/{len(LIVE_KEYS)}; {errors}",
                  flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--boats", type=int, default=6, help="boats per source in A")
    parser.add_argument("--duration-s", type=float, default=900.0, help="trial length, s")
    parser.add_argument("--flap-seeds", type=int, default=3, help="trials in B")
    parser.add_argument("--zigzag-seeds", type=int, default=4, help="trials in Z")
    parser.add_argument("--only", default="BAZTO", help="studies to run, by letter (default: all)")
    parser.add_argument("--boat-index", type=int, default=None,
                        help="T: follow only this boat of each source (the same draws as the full study)")
    args = parser.parse_args()
    if "B" in args.only:
        study_flapping(args.duration_s, args.flap_seeds)
    if "A" in args.only:
        study_coverage(args.boats, args.duration_s)
    if "Z" in args.only:
        study_zigzag(args.duration_s, args.zigzag_seeds)
    if "T" in args.only:
        study_turning(args.boats, args.duration_s, args.boat_index)
    if "O" in args.only:
        study_offline(args.boats, args.duration_s)


if __name__ == "__main__":
    main()
