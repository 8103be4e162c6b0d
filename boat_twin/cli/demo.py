"""``boat-twin demo``: the main job on the shipped sample — regenerate it, read it back, summarize, plot, identify."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from boat_twin.cli import verb_help
from boat_twin.errors import InputError
from boat_twin.files import ReportSet, refuse_input_as_output, to_json
from boat_twin.fleet.outputs import IDENTIFY_OUTPUTS
from boat_twin.units import KGF_N, KNOT_MPS

if TYPE_CHECKING:
    from boat_twin.io.trial import Trial

SAMPLE_BAG = Path("bags/thrust_steps_sample")
"""The shipped sample trial (regenerate: ``make sample``)."""
SAMPLE_SEED = 1
"""Seed the sample was made with."""
OUTPUTS = ("thrust_steps", "sample_trial.png", "identify")
"""What ``demo --out DIR`` writes: the regenerated bag, the plot, the identification report."""
OUTPUT_KINDS: dict[str, str | tuple[str, ...]] = {"thrust_steps": "bag", "identify": IDENTIFY_OUTPUTS}
"""What --force may replace at each of :data:`OUTPUTS` (the plot: a file): a bag, a directory of identify's reports."""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``demo`` verb."""
    p = subparsers.add_parser("demo", help=verb_help("demo"),
                              description="Regenerate the shipped thrust-steps sample, check it matches, read it "
                              "back as a Trial, print speeds per thrust level and sensor rates, plot, identify.")
    p.add_argument("--sample", type=Path, default=SAMPLE_BAG, metavar="BAG",
                   help=f"sample bag (default {SAMPLE_BAG})")
    p.add_argument("--out", type=Path, default=Path("out/demo"), metavar="DIR",
                   help="report directory (default out/demo)")
    p.add_argument("--force", action="store_true",
                   help=f"overwrite an earlier demo's outputs in --out ({', '.join(OUTPUTS)})")
    p.add_argument("--json", action="store_true", help="machine-readable summary on stdout")
    p.set_defaults(handler=run)


def thrust_levels(trial: Trial) -> list[dict[str, float]]:
    """Each run of constant surge thrust: its thrust, duration and the speed over its last 10 s (mean, stdev)."""
    import numpy as np

    thrust = trial.surge_thrust_N
    edges = np.flatnonzero(np.diff(thrust) != 0) + 1
    levels = []
    for start, stop in zip(np.r_[0, edges], np.r_[edges, thrust.size], strict=True):
        tail = (trial.t_s[start:stop] >= trial.t_s[stop - 1] - 10.0)
        speed = trial.speed_mps[start:stop][tail]
        speed = speed[np.isfinite(speed)]
        if speed.size and np.isfinite(thrust[start]):
            levels.append({
                "thrust_N": float(thrust[start]),
                "duration_s": float(trial.t_s[stop - 1] - trial.t_s[start]),
                "final_speed_mps": float(speed.mean()),
                "final_speed_stdev_mps": float(speed.std()),
            })
    return levels


def run(args: argparse.Namespace) -> int:
    """Handler of ``demo`` (the libraries are imported in :func:`_run`, so that ``--help`` answers at once): the
    report set (:data:`OUTPUTS`) is written whole beside --out and swapped in, or not at all."""
    if not args.sample.exists():
        raise InputError(f"{args.sample}: sample bag not found (run from the repository root, or 'make sample')")
    refuse_input_as_output(args.out, args.sample)
    with ReportSet(args.out, OUTPUTS, args.force, OUTPUT_KINDS) as reports:
        code = _run(args, args.out, reports.staging)
        reports.commit()
    return code


def _run(args: argparse.Namespace, out: Path, staging: Path) -> int:
    """The tour, writing into ``staging`` (swapped in as ``out`` when complete)."""
    import numpy as np

    from boat_twin.config import TwinConfig
    from boat_twin.io.bags import read_trial, write_bag
    from boat_twin.plots import plot_trial
    from boat_twin.twin.sea_trial import run_sea_trial, trial_messages
    from boat_twin.vessel.scenarios import make_scenario

    print(f"[1/4] regenerating the sample: thrust-steps, seed {SAMPLE_SEED} ...", file=sys.stderr)
    config = TwinConfig()
    scenario = make_scenario("thrust-steps", config.vessel, np.random.default_rng(SAMPLE_SEED))
    regenerated = out / "thrust_steps"
    write_bag(staging / "thrust_steps", trial_messages(run_sea_trial(config, scenario, SAMPLE_SEED)))
    print("[2/4] reading both bags back ...", file=sys.stderr)
    sample, again = read_trial(args.sample), read_trial(staging / "thrust_steps")
    identical = len(sample) == len(again) and bool(np.array_equal(sample.speed_mps, again.speed_mps, equal_nan=True))
    levels = thrust_levels(sample)
    print("[3/4] plotting ...", file=sys.stderr)
    plot_trial(sample, staging / "sample_trial.png", f"{args.sample}: thrust steps")
    result = {"sample": str(args.sample), "regenerated": str(regenerated), "identical": identical,
              "metadata": sample.metadata.summary_line(), "levels": levels,
              "plots": [str(out / "sample_trial.png")]}
    if args.json:
        print(to_json(result))
        return 0
    print(sample.metadata.summary_line())
    print(f"regenerated with seed {SAMPLE_SEED}: {'identical' if identical else 'DIFFERENT'} to the shipped sample")
    print(f"{'surge thrust (N)':>17} {'(kgf)':>6} {'held (s)':>9} {'speed, last 10 s (m/s)':>24} {'(kn)':>6}")
    for lv in levels:
        speed = lv["final_speed_mps"]
        print(f"{lv['thrust_N']:17.1f} {lv['thrust_N'] / KGF_N:6.1f} {lv['duration_s']:9.1f} "
              f"{speed:16.3f} ± {lv['final_speed_stdev_mps']:.3f} {speed / KNOT_MPS:6.2f}")
    print(f"plot: {out / 'sample_trial.png'}")
    print("[4/4] identifying the sample and the paper's table ...", file=sys.stderr)
    print(identification_summary(sample, out, staging))
    return 0


def identification_summary(sample: Trial, out: Path, staging: Path | None = None) -> str:
    """Identify the sample trial as ``identify SAMPLE --out`` does (its report and the figures of the record
    fitted into ``staging/identify``, named ``out/identify``; ``staging`` defaults to ``out``; the true curve
    drawn under the identified ones) and reproduce Dyda & Chumakova (2021)."""
    from boat_twin.config import TwinConfig
    from boat_twin.ident.paper import reproduce
    from boat_twin.ident.pipeline import identify_trials
    from boat_twin.ident.report import write_identify_report

    result, found = identify_trials([sample])
    write_identify_report((staging or out) / "identify", result, found, str(sample.metadata.source), None,
                          out / "identify",
                          true_resistance_N=TwinConfig().vessel.resistance.force_N)  # the sample's own boat
    oe = result["output_error"]
    lo, hi = oe["selected"]["mass_ci95_kg"]
    paper = reproduce()
    fisher = paper["paper"]["fisher"]
    lines = [
        f"sample: output-error fit {oe['selected']['model']} over every sample, effective mass "
        f"{oe['selected']['mass_kg']:.0f} kg, 95% CI [{lo:.0f}, {hi:.0f}] (simulated boat: "
        f"{TwinConfig().vessel.mass_kg * 1.05:.0f} kg); {len(result['steady_points'])} steady points; "
        f"report in {out / 'identify'}",
        f"Dyda & Chumakova (2021) Table 7 Fisher statistic, recomputed: N=1 {fisher['1']:.2f}, N=3 {fisher['3']:.2f}, "
        f"N=5 {fisher['5']:.2f} (printed: 314.76, 228.98, 315.3)",
        f"least-squares optimum on Table 1: selected order N = {paper['selected_order']}",
    ]
    return "\n".join(lines)
