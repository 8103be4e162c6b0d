"""``boat-twin identify``: the thrust–speed model m·dv/dt = F − Fc(v) from the paper's table or a trial, or
(``--manoeuvring``) the turning coefficients from one or more zigzag / turning-circle trials.

A front end over :mod:`boat_twin.ident.pipeline` and :mod:`boat_twin.ident.manoeuvring` (the computation) and
:mod:`boat_twin.ident.report` (text, files, figures).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from boat_twin.cli import verb_help
from boat_twin.cli.options import (
    TRIAL_HELP,
    add_fleet_options,
    add_trial_options,
    claim_out_dir,
    read_options_from_args,
    run_each,
    trial_from_args,
    trial_inputs,
    twin_config_from_args,
)
from boat_twin.errors import InputError
from boat_twin.files import atomic_save_figure, atomic_write_text, to_json
from boat_twin.fleet.outputs import IDENTIFY_OUTPUTS

TABLE_OUTPUTS = ("identify.json", "report.txt", "model.yaml", "fits.png", "residuals.png")
"""What ``identify --table --out DIR`` writes."""
TRIAL_OUTPUTS = IDENTIFY_OUTPUTS
"""What ``identify TRIAL --out DIR`` writes."""
MANOEUVRING_OUTPUTS = ("manoeuvring.json", "twin.yaml")
"""What ``identify TRIAL... --manoeuvring --out DIR`` writes: the result and the twin config with the fit."""


def _run_table(args: argparse.Namespace, out: Path | None) -> int:
    from boat_twin.ident.pipeline import identify_table, model_dict, write_model_yaml
    from boat_twin.ident.report import table_figures, table_report

    result, si_fit = identify_table(args.monotone, args.order, args.max_order, args.through_origin)
    report = table_report(result, si_fit)
    if out is not None:
        atomic_write_text(out / "identify.json", to_json(result) + "\n")
        atomic_write_text(out / "report.txt", report)
        write_model_yaml(
            out / "model.yaml",
            model_dict(si_fit),
            f"Dyda & Chumakova (2021) Table 1 read as kn/kgf, least squares N = {si_fit.order}, SI units",
        )
        fits_fig, resid_fig = table_figures(result)
        atomic_save_figure(out / "fits.png", fits_fig, "identify --table dyda2021")
        atomic_save_figure(out / "residuals.png", resid_fig, "identify --table dyda2021")
    sys.stdout.write(to_json(result) + "\n" if args.json else report)
    return 0


def run(args: argparse.Namespace) -> int:
    """Handler of ``boat-twin identify``."""
    from boat_twin.ident.steady import MAX_ORDER

    if args.order is not None and not 1 <= args.order <= MAX_ORDER:
        raise InputError(f"--order must be from 1 to {MAX_ORDER}, got {args.order}")
    if not 1 <= args.max_order <= MAX_ORDER:
        raise InputError(f"--max-order must be from 1 to {MAX_ORDER}, got {args.max_order}")
    for name, value in (("--steady-window", args.steady_window), ("--thrust-tolerance", args.thrust_tolerance)):
        if value is not None and not (math.isfinite(value) and value > 0.0):
            raise InputError(f"{name} must be a positive number, got {value:g}")
    if args.table is not None and args.trial:
        raise InputError("give a TRIAL or --table, not both")
    if args.each:
        return _run_each(args)
    if args.table is not None:
        with claim_out_dir(args.out, TABLE_OUTPUTS, args.force) as reports:
            return _run_table(args, reports.staging if reports else None)
    if not args.trial:
        raise InputError("nothing to identify: give a TRIAL (bag, .mcap, .tlog, .BIN, .csv) or --table dyda2021")
    if args.manoeuvring:
        with claim_out_dir(args.out, MANOEUVRING_OUTPUTS, args.force, trial_inputs(args)) as reports:
            return _run_manoeuvring(args, reports.staging if reports else None)
    for name in ("validate", "window", "model"):
        if getattr(args, name):
            raise InputError(f"--{name} needs --manoeuvring")
    with claim_out_dir(args.out, TRIAL_OUTPUTS, args.force, trial_inputs(args)) as reports:
        return _run_trial(args, reports.staging if reports else None)


def _boat_path(args: argparse.Namespace) -> Path | None:
    """The file of the boat's facts: --boat, else the --config the trials were read with (a boat file's
    thrusters and hull are the boat's), else None (the default boat carried to the identified mass)."""
    return args.boat if args.boat is not None else args.config


def _boat_source(args: argparse.Namespace) -> str | None:
    """:func:`_boat_path` as the reports name it."""
    path = _boat_path(args)
    return None if path is None else str(path)


def _boat_facts(args: argparse.Namespace) -> dict[str, float] | None:
    """The vessel facts of :func:`_boat_path` (None without one); fields identify measures itself are said to be
    ignored."""
    from boat_twin.ident.twin_config import read_boat_file

    path = _boat_path(args)
    if path is None:
        return None
    boat_file = read_boat_file(path)
    if boat_file.ignored:
        sys.stderr.write(f"{path}: ignoring {', '.join(boat_file.ignored)} (identify measures the resistance and "
                         "the effective mass, and reads only the vessel's facts)\n")
    return boat_file.facts


def _run_each(args: argparse.Namespace) -> int:
    """--each: every trial identified on its own (not pooled), each read with the --config boat, on the
    --scheduler's workers."""
    from boat_twin.fleet.jobs import IdentifyJob

    for name in ("table", "manoeuvring", "validate", "window", "model"):
        if getattr(args, name):
            raise InputError(f"--each identifies each trial's thrust-speed model; --{name} does not apply")
    read = read_options_from_args(args)
    job = IdentifyJob(read, args.order, min(args.max_order, 6), args.monotone, args.steady_window,
                      args.thrust_tolerance, _boat_facts(args),
                      _boat_source(args), twin_config_from_args(args))
    return run_each(args, job)


def _run_manoeuvring(args: argparse.Namespace, out: Path | None) -> int:
    """Fit the turning coefficients to the trials (surge held from --config/--model), replay the --validate
    trials with the fit, report; --out writes the result and a twin config ``simulate --config`` loads."""
    from boat_twin.config import save_config
    from boat_twin.ident.manoeuvring import WINDOW_S, fit_manoeuvring, validate
    from boat_twin.ident.trial_advice import advise_next_trial

    window_s = WINDOW_S if args.window is None else args.window
    if not (math.isfinite(window_s) and window_s > 0.0):
        raise InputError(f"--window must be a positive number of seconds, got {window_s:g}")
    base = twin_config_from_args(args)
    trials = []
    for path in args.trial:
        sys.stderr.write(f"reading {path} ...\n")
        trials.append(trial_from_args(path, args))
    held_out = [trial_from_args(path, args) for path in args.validate]
    sys.stderr.write(f"fitting the manoeuvring coefficients to {len(trials)} trial(s) ...\n")
    fit = fit_manoeuvring(trials, base, window_s)
    block = fit.to_dict()
    block["validation"] = [validate(trial, fit.config) for trial in held_out]
    advice = advise_next_trial(fit, base, trials, window_s)
    block["next_trial"] = advice.to_dict()
    result = {"manoeuvring": block}
    if out is not None:
        atomic_write_text(out / "manoeuvring.json", to_json(result) + "\n")
        sources = ", ".join(map(str, args.trial))
        save_config(fit.config, out / "twin.yaml", f"boat_twin twin config: manoeuvring coefficients from {sources}")
    if args.json:
        sys.stdout.write(to_json(result) + "\n")
        return 0
    lines = [f"{len(trials)} trial(s), {block['windows']} windows of {window_s:g} s, "
             f"{block['evaluations']} model evaluations, {block['fit_time_s']:.1f} s"]
    for key, value in block["parameters"].items():
        lo, hi = block["ci95"][key]
        lines.append(f"{key:24s} {value:11.5g}   95% CI [{lo:.5g}, {hi:.5g}]")
    lines += [f"not identified: {key}: {why}" for key, why in block["not_identified"].items()]
    lines += [f"not separated: {' / '.join(pair['parameters'])} (correlation {pair['correlation']:+.3f}): "
              f"{pair['why']}" for pair in block["not_separated"]]
    ratios = ", ".join(f"{s} {r:.2f}" for s, r in block["residual_to_noise"].items())
    lines.append(("MISFIT: residuals above the measured noise (" if block["misfit"] else
                  "residual RMS / measured noise: ") + ratios + (
                  f"; thresholds {block['misfit_threshold']}): the model lacks a cause in these trials and the "
                  "coefficients are biased" if block["misfit"] else ""))
    timing = block["steering_timing"]
    if not timing["flagged"]:  # a flagged check says so in its note
        low, high = timing["delay_ci95_s"]
        lines.append(f"steering timing: delay {timing['delay_s']:+.3f} s, 95% CI [{low:+.3f}, {high:+.3f}] s (score "
                     f"test t {timing['t']:+.2f}, limit ±{timing['t_limit']:g})")
    for check in block["validation"]:
        track = "track: no GNSS positions" if check["track_rmse_m"] is None \
            else f"track RMSE {check['track_rmse_m']:.1f} m"
        line = (f"validation {check['source']}: heading RMSE {check['heading_rmse_deg']:.2f}°, yaw rate RMSE "
                f"{check['yaw_rate_rmse_degps']:.3f}°/s, {track}")
        if "tactical_diameter_m" in check:
            d = check["tactical_diameter_m"]
            line += f", tactical diameter {d['predicted']:.1f} m predicted vs {d['measured']:.1f} m measured"
        lines.append(line)
    lines.append(f"next trial: {advice.summary()}")
    lines += [f"note: {note}" for note in block["notes"]]
    sys.stdout.write("\n".join(lines) + "\n")
    return 0


def rejected_summary(rejected: list[dict[str, Any]]) -> str:
    """One line: the rejected segments counted by reason (the details are in identify.json / --json)."""
    kinds: dict[str, int] = {}
    for seg in rejected:
        reason = seg["reason"]
        kind = "held shorter than the test window" if "shorter than" in reason else reason.split(":")[0]
        kinds[kind] = kinds.get(kind, 0) + 1
    counts = ", ".join(f"{n} {kind}" for kind, n in sorted(kinds.items(), key=lambda item: -item[1]))
    return f"rejected segments: {counts} (each with its reason in --json / identify.json)"


def _say(line: str) -> None:
    """A progress line on stderr."""
    sys.stderr.write(line + "\n")


def _run_trial(args: argparse.Namespace, out: Path | None) -> int:
    """Recorded trials, pooled: replay through the online identifier, batch fits, dynamic mass, re-simulation of
    each with the identified model (closing the loop), report (into --out, claimed by the caller)."""
    from boat_twin.ident.pipeline import identify_trials
    from boat_twin.ident.report import count, model_lines, resimulation_line, write_identify_report

    boat = _boat_facts(args)
    config = twin_config_from_args(args)
    trials = []
    for path in args.trial:
        sys.stderr.write(f"reading {path} ...\n")
        trials.append(trial_from_args(path, args))
        sys.stderr.write(trials[-1].metadata.summary_line() + "\n")
    sys.stderr.write("identifying, then re-simulating the trial's commands with the identified model ...\n")
    options = {"order": args.order, "max_order": min(args.max_order, 6), "monotone": args.monotone,
               "window_s": args.steady_window, "thrust_tolerance_N": args.thrust_tolerance, "boat": boat,
               "config": config}
    result, found = identify_trials(trials, **options)
    vessel = found.vessel
    if out is not None:
        from boat_twin.fleet.twin_error import identified_model_error

        model_error, how = identified_model_error(trials, found, options, _say)
        _say(how)
        write_identify_report(out, result, found, ", ".join(map(str, args.trial)),
                              _boat_source(args), args.out, model_error=model_error)
    if args.json:
        sys.stdout.write(to_json(result) + "\n")
        return 0
    lines = [f"trial{'s' if len(trials) > 1 else ''} {', '.join(map(str, args.trial))}: "
             f"{count(len(result['steady_points']), 'steady point')}, "
             f"{count(len(result.get('rejected_segments', [])), 'segment')} rejected"]
    lines += model_lines(result)
    if result.get("rejected_segments"):
        lines.append(rejected_summary(result["rejected_segments"]))
    if vessel is not None:
        lines.append(f"twin: {vessel.length_m:.3g} m x {vessel.beam_m:.3g} m, {vessel.mass_kg:.4g} kg, bollard "
                     f"{vessel.bollard_thrust_N:.4g} N per engine (geometry from "
                     f"{_boat_path(args) or 'the default boat carried to this mass'})"
                     + ("; turning from the hull's dimensions (Clarke et al. 1983: assumed, no turn stated)"
                        if vessel.turning == "hull" else "")
                     + (f"; written to {args.out / 'twin.yaml'}" if args.out is not None else ""))
    for entry in result["trials"]:
        prefix = f"{entry['source']}: " if len(trials) > 1 else ""
        lines.append(prefix + resimulation_line(entry["resimulation"]))
    lines += [f"warning: {w}" for w in result.get("warnings", [])]
    sys.stdout.write("\n".join(lines) + "\n")
    return 0


def register(subparsers: Any) -> None:
    """Add the ``identify`` verb."""
    p = subparsers.add_parser(
        "identify",
        help=verb_help("identify"),
        description="Identify the longitudinal model m·du/dt = T - Fc(u) (Dyda & Chumakova 2021). From trials: an "
        "output-error fit over every sample (effective mass, Fc non-decreasing with Fc(0) = 0, complexity by "
        "cross-validated prediction, beside the baseline a·u + b·u|u|), with the paper's steady-point power "
        "series Fc(v) = sum c_i·v^i as a view. Internally SI; the built-in table is reported in its own units "
        "(kn, kgf).",
    )
    p.add_argument("trial", nargs="*", type=Path,
                   help=TRIAL_HELP + "; several trials of one boat are pooled into one identification (--each: each on "
                   "its own; a directory of trials or a quoted glob pattern then expands)")
    add_trial_options(p)
    add_fleet_options(p, "identify")
    p.add_argument("--manoeuvring", action="store_true",
                   help="fit the turning coefficients (m22, m33, sway/yaw damping, lateral centre, cross-flow drag, "
                   "steering offset) to the TRIALs (zigzags, turning circles), surge held from --config/--model")
    p.add_argument("--validate", action="append", type=Path, default=[], metavar="TRIAL",
                   help="with --manoeuvring: a trial not fitted, replayed with the fit to report its error")
    p.add_argument("--window", type=float, metavar="S",
                   help="with --manoeuvring: replay window, s (default 20; a trial needs 6 windows)")
    p.add_argument("--config", type=Path, metavar="FILE",
                   help="twin configuration YAML (default the built-in boat): a TRIAL's thrust commands are read as "
                   "requests its engines deliver (at most eta*P/u ahead, W and m/s) through its steering actuator, "
                   "its GNSS latency (s) and IMU yaw offset (rad) apply; with --manoeuvring also the prior and the "
                   "held surge")
    p.add_argument("--model", type=Path, metavar="FILE",
                   help="with --manoeuvring: identified surge model YAML (identify TRIAL --out) over the config's "
                   "vessel")
    p.add_argument(
        "--table",
        choices=["dyda2021"],
        help="built-in steady-state table: dyda2021 = Dyda & Chumakova (2021) Table 1, v in kn, F in kgf",
    )
    p.add_argument(
        "--order", type=int, metavar="N",
        help="power-series order N of the steady points' fit (the table's model; for a trial a view beside the "
        "output-error model; default: chosen by leave-one-out cross-validation and the Bayesian information "
        "criterion, BIC)"
    )
    p.add_argument(
        "--max-order", type=int, default=8, metavar="N",
        help="highest order N tried by the selection (default 8; a recorded trial tries at most 6)",
    )
    p.add_argument(
        "--monotone",
        action="store_true",
        help="constrain the power series to be non-decreasing from 0 to the top speed and Fc(0) >= 0 (the "
        "output-error model of a trial always is)",
    )
    p.add_argument(
        "--through-origin", action="store_true", help="impose Fc(0) = c0 = 0 (no resistance at rest)"
    )
    p.add_argument(
        "--steady-window", type=float, metavar="S",
        help="shortest settled tail the steady-state detector tests, s (default: derived from the trial: the surge "
        "time constant seen after thrust steps, or what the speed noise needs; see docs/identification.md)")
    p.add_argument(
        "--thrust-tolerance", type=float, metavar="N",
        help="thrust counts as constant within this of a segment's start, N (default: derived from the commands: "
        "half their smallest step, or 4 sigma of their jitter)")
    p.add_argument(
        "--boat", type=Path, metavar="FILE",
        help="the boat's facts for the twin --out writes (twin.yaml): vessel fields, e.g. length_m, beam_m, "
        "draft_m, engine_y_m, bollard_thrust_N (SI; docs/identification.md), or a twin config as simulate --config "
        "takes (its resistance, effective mass and other sections are ignored: identify measures them); facts not "
        "given are the default boat's carried to the identified mass; its mass_kg is held when the data do not "
        "identify the mass (default: the --config boat, if given)")
    p.add_argument("--json", action="store_true", help="machine-readable result on stdout")
    p.add_argument(
        "--out",
        type=Path,
        metavar="DIR",
        help="write identify.json, model.yaml (SI), twin.yaml (a complete twin configuration of the boat, for "
        "simulate/diagnose --config) and PNG plots here (report.txt too with --table; manoeuvring.json and "
        "twin.yaml with --manoeuvring)",
    )
    p.add_argument("--force", action="store_true", help="overwrite existing reports in --out")
    p.set_defaults(handler=run)
