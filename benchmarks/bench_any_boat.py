"""Any boat (issue 36): the three families of config/boats identified from their own simulated trials, over seeds.

Per family and seed: a random-command trial (10 min) simulated with the boat file, `identify --boat` on it; the
effective mass m11 = m·(1 + surge added-mass ratio) against its 95 % interval. For the single-screw + rudder ship
also the turning coefficients from a 20°/20° and a 10°/10° zigzag (`identify --manoeuvring`, surge held from the
boat file) against their intervals, and the heading RMSE of a held-out turning circle re-simulated with them.
Printed: each row, then the coverage per family (target ≥ 90 % of seeds) and the largest held-out heading RMSE
(target ≤ 10°).

Run: ``.venv/bin/python benchmarks/bench_any_boat.py [--seeds 10]``.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import tempfile
from pathlib import Path

from boat_twin.cli import main
from boat_twin.config import load_twin_config
from boat_twin.vessel.params import derive_coefficients

BOATS = Path(__file__).resolve().parents[1] / "config" / "boats"
FAMILIES = ("skid_steer_catamaran", "single_screw_rudder", "twin_outboards")
TURNING = ("m22_kg", "m33_kgm2", "sway_damping_Nspm2", "lateral_centre_x_m", "yaw_damping_Nms",
           "sway_quadratic_Ns2pm2", "yaw_quadratic_Nms2")


def _run(argv: list[str]) -> None:
    """One boat-twin command, its printing kept quiet; fails loudly on a non-zero exit."""
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        code = main(argv)
    if code != 0:
        raise SystemExit(f"boat-twin {' '.join(argv)} exited {code}")


def surge_row(family: str, seed: int, work: Path) -> bool:
    """Simulate and identify one random trial; print the mass against its interval; True if it holds m11."""
    boat = BOATS / f"{family}.yaml"
    m11 = derive_coefficients(load_twin_config(boat, None, None).vessel).m11_kg
    trial = work / f"{family}_{seed}.mcap"
    _run(["simulate", "random", "--config", str(boat), "--seed", str(seed), "--out", str(trial)])
    out = work / f"{family}_{seed}_id"
    _run(["identify", str(trial), "--boat", str(boat), "--out", str(out)])
    selected = json.loads((out / "identify.json").read_text())["output_error"]["selected"]
    mass = selected["mass_kg"]
    low, high = selected["mass_ci95_kg"]
    holds = low <= m11 <= high
    print(f"{family:22s} seed {seed:2d}  m11 {m11:8.1f} kg  identified {mass:8.1f} [{low:8.1f}, {high:8.1f}]  "
          f"{'holds' if holds else 'MISSES'}")
    return holds


def turning_row(seed: int, work: Path) -> tuple[int, int, float]:
    """The ship's turning from two zigzags; (intervals holding the truth, intervals, held-out heading RMSE °)."""
    boat = BOATS / "single_screw_rudder.yaml"
    truth = derive_coefficients(load_twin_config(boat, None, None).vessel)
    trials = []
    for scenario in ("zigzag-20-20", "zigzag-10-10", "turning-circle"):
        path = work / f"ship_{scenario}_{seed}.mcap"
        _run(["simulate", scenario, "--config", str(boat), "--seed", str(seed), "--out", str(path)])
        trials.append(str(path))
    out = work / f"ship_turning_{seed}"
    _run(["identify", trials[0], trials[1], "--manoeuvring", "--config", str(boat), "--validate", trials[2],
          "--out", str(out)])
    found = json.loads((out / "manoeuvring.json").read_text())["manoeuvring"]
    intervals = found["ci95"]
    held = sum(intervals[key][0] <= getattr(truth, key) <= intervals[key][1] for key in TURNING)
    rmse = found["validation"][0]["heading_rmse_deg"]
    print(f"single_screw_rudder    seed {seed:2d}  turning intervals holding the truth {held}/{len(TURNING)}, "
          f"held-out turning circle heading RMSE {rmse:.2f}°")
    return held, len(TURNING), rmse


def main_bench() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for family in FAMILIES:
            holds = [surge_row(family, seed, work) for seed in range(args.seeds)]
            print(f"{family}: mass interval holds m11 on {sum(holds)}/{len(holds)} seeds")
        rows = [turning_row(seed, work) for seed in range(args.seeds)]
        print(f"single_screw_rudder turning: {sum(r[0] for r in rows)}/{sum(r[1] for r in rows)} intervals hold "
              f"the truth; held-out heading RMSE at most {max(r[2] for r in rows):.2f}°")


if __name__ == "__main__":
    main_bench()
