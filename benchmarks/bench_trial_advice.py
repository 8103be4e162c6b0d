"""Two zigzags and the trial the fit asks for: hidden boats' turning coefficients, before and after it.

Run: .venv/bin/python benchmarks/bench_trial_advice.py [--boats 20] [--seed 0]
Nothing is asserted: the script prints Markdown tables for docs/manoeuvring.md and the command that made them.

Each hidden boat (:func:`boat_twin.ident.manoeuvring_trials.draw_boat`: every coefficient within ±30 % of the
twin's, x_c within ±0.3 m) runs the command line's two zigzags (``zigzag-20-20``, ``zigzag-10-10`` at its turn
speed, the helm reversing at the 50 Hz integration step, default sensor noise, through bags) and is fitted from the
default boat. The advice (:func:`boat_twin.ident.trial_advice.advise_next_trial`) names the candidate trial that
narrows the intervals most; that trial is then run on the *true* boat (with noise) and the fit repeated with the
three trials, and, as the reference, with a third zigzag 20°/20° at the same speed instead (what a user would add
without the advice). Per set: share of boats with x_c within 0.1 m and a_r within 5 % (the issue's targets), the
share of every coefficient's 95 % interval that holds the truth, and for x_c and a_r the predicted half-width over
the achieved one (median).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.ident.manoeuvring import PARAMETER_KEYS, ManoeuvringFit, fit_manoeuvring
from boat_twin.ident.manoeuvring_trials import draw_boat, recorded
from boat_twin.ident.trial_advice import advise_next_trial, candidate_scenario, half_widths
from boat_twin.io.trial import Trial
from boat_twin.twin.sea_trial import run_sea_trial
from boat_twin.vessel.scenarios import Scenario, make_scenario

SETS = ("two zigzags", "+ advised trial", "+ third zigzag 20°/20°, same speed")
KEYS = ("lateral_centre_x_m", "yaw_damping_Nms")


def run(true: TwinConfig, scenario: Scenario, seed: int, where: Path) -> Trial:
    """``scenario`` sailed by the true boat with sensor noise ``seed``, through a bag in ``where``."""
    return recorded(run_sea_trial(true, scenario, seed), f"{scenario.name}-{seed}", where)


def score(fit: ManoeuvringFit, truth: dict[str, float]) -> tuple[float, float, int, int, list[str]]:
    """x_c error (m), a_r error (relative), intervals holding the truth, intervals, the coefficients missed."""
    missed = [k for k, (lo, hi) in fit.ci95.items() if k in PARAMETER_KEYS and not lo <= truth[k] <= hi]
    return (fit.values["lateral_centre_x_m"] - truth["lateral_centre_x_m"],
            fit.values["yaw_damping_Nms"] / truth["yaw_damping_Nms"] - 1.0,
            sum(k in PARAMETER_KEYS for k in fit.ci95) - len(missed), sum(k in PARAMETER_KEYS for k in fit.ci95),
            missed)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--boats", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    base = TwinConfig()
    rows: dict[str, list[tuple[float, float, int, int, list[str]]]] = {s: [] for s in SETS}
    predicted_over_achieved: dict[str, list[float]] = {k: [] for k in KEYS}
    advised: dict[str, int] = {}
    for i in range(args.boats):
        seed = args.seed + i
        true, truth = draw_boat(base, np.random.default_rng(500 + seed))
        with tempfile.TemporaryDirectory(prefix="boat_twin_advice_") as tmp:
            where = Path(tmp)

            trials = [run(true, make_scenario(name, true.vessel, np.random.default_rng(0)), 7000 + 10 * seed + j,
                          where) for j, name in enumerate(("zigzag-20-20", "zigzag-10-10"))]
            fit = fit_manoeuvring(trials, base)
            advice = advise_next_trial(fit, base, trials)
            best = advice.candidates[0]
            advised[best.describe()] = advised.get(best.describe(), 0) + 1
            # sailed as a user would (a helm deciding at every integration step, not at the log rate)
            extra = run(true, candidate_scenario(true, best.manoeuvre, best.speed_mps, 0.0), 9000 + seed, where)
            speed = true.vessel.turn_speed_mps
            repeat = run(true, candidate_scenario(true, "zigzag-20-20", speed, 0.0), 9500 + seed, where)
            with_advised = fit_manoeuvring([*trials, extra], base)
            with_repeat = fit_manoeuvring([*trials, repeat], base)
        for name, f in zip(SETS, (fit, with_advised, with_repeat), strict=True):
            rows[name].append(score(f, truth))
        achieved = half_widths(with_advised, with_advised.stderr, with_advised.degrees_of_freedom)
        for k in KEYS:
            predicted_over_achieved[k].append(best.half_width[k] / achieved[k])
        x_err, a_err, *_ = rows[SETS[1]][-1]
        print(f"boat {i}: two zigzags x_c {rows[SETS[0]][-1][0]:+.3f} m, a_r {rows[SETS[0]][-1][1]:+.1%}; advised "
              f"{best.describe()}: x_c {x_err:+.3f} m, a_r {a_err:+.1%}", file=sys.stderr, flush=True)
    print(f"Command: .venv/bin/python benchmarks/bench_trial_advice.py --boats {args.boats} --seed {args.seed}\n")
    print("| trials | x_c within 0.1 m | a_r within 5 % | both | x_c error, median / worst | a_r error, median / worst "
          "| a_r error, mean (signed) | 95 % intervals holding the truth |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for name in SETS:
        x = np.abs([r[0] for r in rows[name]])
        a = np.abs([r[1] for r in rows[name]])
        held, total = sum(r[2] for r in rows[name]), sum(r[3] for r in rows[name])
        missed: dict[str, int] = {}
        for r in rows[name]:
            for k in r[4]:
                missed[k] = missed.get(k, 0) + 1
        where = ", ".join(f"{k} {n}" for k, n in sorted(missed.items(), key=lambda kv: -kv[1])) or "none"
        print(f"| {name} | {np.mean(x <= 0.1):.0%} | {np.mean(a <= 0.05):.0%} | "
              f"{np.mean((x <= 0.1) & (a <= 0.05)):.0%} | {np.median(x):.3f} / {np.max(x):.3f} m | "
              f"{np.median(a):.1%} / {np.max(a):.1%} | {np.mean([r[1] for r in rows[name]]):+.1%} | "
              f"{held}/{total} ({held / total:.1%}; missed: {where}) |")
    ratios = ", ".join(f"{k} {np.median(v):.2f} ({np.min(v):.2f}-{np.max(v):.2f})"
                       for k, v in predicted_over_achieved.items())
    print(f"\npredicted / achieved 95 % half-width with the advised trial, median (range): {ratios}")
    print("advised: " + ", ".join(f"{k} {n}" for k, n in sorted(advised.items(), key=lambda kv: -kv[1])))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
