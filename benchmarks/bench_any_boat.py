"""Any boat (issue 36): the three families of config/boats identified from their own simulated trials, over seeds.

Per family and seed: a random-command trial (10 min) simulated with the boat file, `identify --boat` on it; the
effective mass m11 = m·(1 + surge added-mass ratio) against its 95 % interval (``mass`` rows). Then (``thrust``
rows, other seeds) the same with the boat's thrusters delivering THRUST_TRUTH × what their map (table, K_T(J), N)
says, identified with the nominal boat file: the thrust scale k (mass held at the boat file's) against its 95 %
interval (the default boat's file gets its mass, 1300 kg, written in). For the single-screw + rudder ship
(``turning`` rows) the turning coefficients, the thrust factor and the rudder lift factor from a 20°/20° and a
10°/10° zigzag (`identify --manoeuvring`, surge held from the boat file) against their intervals, the ship
simulated with its screw at TURN_THRUST_TRUTH and its rudder's lift slope at LIFT_TRUTH × Fujii's, and the heading
RMSE of a held-out turning circle re-simulated with the fit.
Printed: each row, then the coverage per family (target ≥ 90 % of seeds) and the largest held-out heading RMSE
(target ≤ 10°).

Run: ``.venv/bin/python benchmarks/bench_any_boat.py [--seeds 10] [--only mass|thrust|turning] [--family NAME]
[--scenario random|thrust-steps]`` (``--scenario``: the ``mass`` and ``thrust`` rows' trial).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import tempfile
from pathlib import Path
from typing import Any

import yaml

from boat_twin.cli import main
from boat_twin.config import load_twin_config
from boat_twin.vessel.actuators import fujii_lift_slope_per_rad
from boat_twin.vessel.params import derive_coefficients

BOATS = Path(__file__).resolve().parents[1] / "config" / "boats"
FAMILIES = ("skid_steer_catamaran", "single_screw_rudder", "twin_outboards")
TURNING = ("m22_kg", "m33_kgm2", "sway_damping_Nspm2", "lateral_centre_x_m", "yaw_damping_Nms",
           "sway_quadratic_Ns2pm2", "yaw_quadratic_Nms2")
THRUST_TRUTH = 0.85
"""The simulated boats' thrust over their boat file's map in the ``thrust`` rows, -."""
THRUST_SEED_OFFSET = 100
"""The ``thrust`` rows' seeds are the ``mass`` rows' + this (other trials)."""
TURN_THRUST_TRUTH = 0.9
"""The simulated ship's screw thrust over its K_T(J)'s in the ``turning`` rows, -."""
LIFT_TRUTH = 0.8
"""The simulated ship's rudder lift slope over Fujii's in the ``turning`` rows, -."""


def _boat_file(family: str, work: Path, label: str, changes: dict[str, Any]) -> Path:
    """The family's boat file with ``changes`` to its vessel (written in ``work`` as ``<family>_<label>.yaml``)."""
    data = yaml.safe_load((BOATS / f"{family}.yaml").read_text())
    data["vessel"].update(changes)
    path = work / f"{family}_{label}.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _run(argv: list[str]) -> None:
    """One boat-twin command, its printing kept quiet; fails loudly on a non-zero exit."""
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        code = main(argv)
    if code != 0:
        raise SystemExit(f"boat-twin {' '.join(argv)} exited {code}")


def surge_row(family: str, seed: int, work: Path, scenario: str = "random") -> bool:
    """Simulate and identify one random trial; print the mass against its interval; True if it holds m11."""
    boat = BOATS / f"{family}.yaml"
    m11 = derive_coefficients(load_twin_config(boat, None, None).vessel).m11_kg
    trial = work / f"{family}_{seed}.mcap"
    _run(["simulate", scenario, "--config", str(boat), "--seed", str(seed), "--out", str(trial)])
    out = work / f"{family}_{seed}_id"
    _run(["identify", str(trial), "--boat", str(boat), "--out", str(out)])
    selected = json.loads((out / "identify.json").read_text())["output_error"]["selected"]
    mass = selected["mass_kg"]
    low, high = selected["mass_ci95_kg"]
    holds = low <= m11 <= high
    print(f"{family:22s} seed {seed:2d}  m11 {m11:8.1f} kg  identified {mass:8.1f} [{low:8.1f}, {high:8.1f}]  "
          f"{'holds' if holds else 'MISSES'}")
    return holds


def thrust_row(family: str, seed: int, work: Path, scenario: str = "random") -> bool:
    """A random trial of the family's boat with its thrust at THRUST_TRUTH × its map, identified with the nominal
    boat file (its mass given); True if the thrust scale's interval holds THRUST_TRUTH."""
    nominal = _boat_file(family, work, "nominal", {"mass_kg": load_twin_config(BOATS / f"{family}.yaml", None, None)
                                        .vessel.mass_kg})
    truth = _boat_file(family, work, "weak", {"thrust_factor_left": THRUST_TRUTH, "thrust_factor_right": THRUST_TRUTH})
    trial = work / f"{family}_{seed}_thrust.mcap"
    _run(["simulate", scenario, "--config", str(truth), "--seed", str(seed), "--out", str(trial)])
    out = work / f"{family}_{seed}_thrust_id"
    _run(["identify", str(trial), "--boat", str(nominal), "--out", str(out)])
    scale = json.loads((out / "identify.json").read_text())["output_error"]["thrust_scale"]["selected"]
    low, high = scale["ci95"]
    holds = (low is None or low <= THRUST_TRUTH) and (high is None or high >= THRUST_TRUTH)
    print(f"{family:22s} seed {seed:2d}  thrust scale {THRUST_TRUTH:.3f}  identified {scale['scale']:.3f} "
          f"[{low}, {high}]  {'holds' if holds else 'MISSES'}")
    return holds


def turning_row(seed: int, work: Path) -> tuple[int, int, bool, bool, float]:
    """The ship's turning from two zigzags; (coefficients' intervals holding the truth, intervals, the thrust
    factor's and the rudder lift factor's intervals holding theirs, held-out heading RMSE °)."""
    boat = BOATS / "single_screw_rudder.yaml"
    vessel = load_twin_config(boat, None, None).vessel
    assert vessel.propulsion is not None
    truth = derive_coefficients(vessel)
    rudder = yaml.safe_load(boat.read_text())["vessel"]["propulsion"]
    rudder["rudders"][0]["lift_slope_per_rad"] = LIFT_TRUTH * fujii_lift_slope_per_rad(
        vessel.propulsion.rudders[0].aspect_ratio)
    simulated = _boat_file("single_screw_rudder", work, "turning", {"thrust_factor_left": TURN_THRUST_TRUTH,
                                                         "propulsion": rudder})
    trials = []
    for scenario in ("zigzag-20-20", "zigzag-10-10", "turning-circle"):
        path = work / f"ship_{scenario}_{seed}.mcap"
        _run(["simulate", scenario, "--config", str(simulated), "--seed", str(seed), "--out", str(path)])
        trials.append(str(path))
    out = work / f"ship_turning_{seed}"
    _run(["identify", trials[0], trials[1], "--manoeuvring", "--config", str(boat), "--validate", trials[2],
          "--out", str(out)])
    found = json.loads((out / "manoeuvring.json").read_text())["manoeuvring"]
    intervals = found["ci95"]
    held = sum(intervals[key][0] <= getattr(truth, key) <= intervals[key][1] for key in TURNING)
    thrust = intervals["thrust_factor"][0] <= TURN_THRUST_TRUTH <= intervals["thrust_factor"][1]
    lift = intervals["rudder_lift_factor"][0] <= LIFT_TRUTH <= intervals["rudder_lift_factor"][1]
    rmse = found["validation"][0]["heading_rmse_deg"]
    p = found["parameters"]
    print(f"single_screw_rudder    seed {seed:2d}  turning intervals holding the truth {held}/{len(TURNING)}, "
          f"thrust factor {p['thrust_factor']:.3f} {intervals['thrust_factor']} {'holds' if thrust else 'MISSES'}, "
          f"rudder lift factor {p['rudder_lift_factor']:.3f} {intervals['rudder_lift_factor']} "
          f"{'holds' if lift else 'MISSES'}, held-out turning circle heading RMSE {rmse:.2f}°")
    return held, len(TURNING), thrust, lift, rmse


def main_bench() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--only", choices=("mass", "thrust", "turning"), default=None)
    parser.add_argument("--family", choices=FAMILIES, default=None, help="the mass and thrust rows of one family")
    parser.add_argument("--scenario", choices=("random", "thrust-steps"), default="random")
    args = parser.parse_args()
    families = FAMILIES if args.family is None else (args.family,)
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for family in families if args.only in (None, "mass") else ():
            holds = [surge_row(family, seed, work, args.scenario) for seed in range(args.seeds)]
            print(f"{family}: mass interval holds m11 on {sum(holds)}/{len(holds)} seeds")
        for family in families if args.only in (None, "thrust") else ():
            holds = [thrust_row(family, THRUST_SEED_OFFSET + seed, work, args.scenario) for seed in range(args.seeds)]
            print(f"{family}: thrust scale interval holds {THRUST_TRUTH:g} on {sum(holds)}/{len(holds)} seeds")
        if args.only in (None, "turning"):
            rows = [turning_row(seed, work) for seed in range(args.seeds)]
            print(f"single_screw_rudder turning: {sum(r[0] for r in rows)}/{sum(r[1] for r in rows)} intervals hold "
                  f"the truth; thrust factor {sum(r[2] for r in rows)}/{len(rows)}, rudder lift factor "
                  f"{sum(r[3] for r in rows)}/{len(rows)}; held-out heading RMSE at most "
                  f"{max(r[4] for r in rows):.2f}°")


if __name__ == "__main__":
    main_bench()
