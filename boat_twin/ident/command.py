"""``boat-twin identify``: the thrust–speed model m·dv/dt = F − Fc(v) from the paper's table or a trial.

Front-end glue over :mod:`~boat_twin.ident.steady`, :mod:`~boat_twin.ident.dynamic`,
:mod:`~boat_twin.ident.online` and :mod:`~boat_twin.ident.paper`: :func:`identify_arrays` runs every
identifier on a trial's arrays (the function bag replay calls), :func:`model_dict` and
:func:`write_model_yaml` write the identified model that the vessel loader accepts as an override.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from matplotlib.figure import Figure

from boat_twin.data import dyda2021_table1, dyda2021_table1_si
from boat_twin.errors import InputError
from boat_twin.ident.dynamic import DynamicWindow, check_samples, identify_dynamic
from boat_twin.ident.online import OnlineThrustSpeedIdentifier, SteadyCriteria, detect_steady_segments
from boat_twin.ident.paper import (
    PAPER_COEFFICIENTS,
    PAPER_FISHER,
    PAPER_ORDERS,
    paper_model_values,
    reproduce,
)
from boat_twin.ident.resimulate import Resimulation, resimulate, resimulation_figure
from boat_twin.ident.steady import MAX_ORDER, FitResult, fit_power_series, select_order
from boat_twin.io.files import atomic_save_figure, atomic_write_text, ensure_out_dir, to_json
from boat_twin.io.sources import TRIAL_HELP, add_trial_options
from boat_twin.io.trial import COMMAND_ROLES, Trial
from boat_twin.units import KGF_N, KNOT_MPS

SURGE_ROLES = ("gnss_vel",) + COMMAND_ROLES
"""Streams the surge samples come from: a gap in any of them makes the samples inside it unknown."""
TWO_WAY_WARNING = 0.3
"""Below this share of the speed range crossed both ways, the report warns: the mass rests on Fc's form."""


def model_dict(fit: FitResult, effective_mass_kg: float | None = None) -> dict[str, Any]:
    """The identified model as plain data: ``{"resistance": {...}, "effective_mass_kg": m}`` (SI fit).

    ``resistance`` is :meth:`PowerSeriesResistance.to_dict` (valid to the fit's top speed, quadratic law
    beyond); ``effective_mass_kg`` (hull + surge added mass) only when known.
    """
    model: dict[str, Any] = {"resistance": fit.resistance_model().to_dict()}
    if effective_mass_kg is not None:
        model["effective_mass_kg"] = float(effective_mass_kg)
    return model


def write_model_yaml(path: Path, model: dict[str, Any], comment: str = "") -> None:
    """Write ``model`` (:func:`model_dict`) as YAML to ``path`` atomically; ``comment`` lines go on top."""
    header = "".join(f"# {line}\n" for line in comment.splitlines())
    atomic_write_text(path, header + yaml.safe_dump(model, sort_keys=False))


def _nrms(a: np.ndarray, b: np.ndarray) -> float:
    """RMS of a − b relative to the RMS of b."""
    return float(np.sqrt(np.mean((a - b) ** 2)) / np.sqrt(np.mean(b**2)))


def trial_samples(trial: Trial) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Time (s), surge thrust Σ T·cos δ (N) and GNSS speed over ground (m/s) of a trial's known samples.

    Samples before the first command or velocity fix and inside the reported gaps of any stream it uses (GNSS
    velocity, the outboards' thrust and angle commands) are unknown and skipped; a NaN anywhere else is a
    non-finite value in the recording itself and refused (InputError).
    """
    source = trial.metadata.source
    for role, what in (("thrust_left", "left outboard's thrust"), ("thrust_right", "right outboard's thrust"),
                       ("gnss_vel", "GNSS velocity")):
        if role in trial.metadata.missing:
            raise InputError(f"{source}: no {what} ({role}) in the trial: the identifier needs the surge thrust of "
                             "both outboards and the speed over ground")
    t, thrust, speed = trial.t_s, trial.surge_thrust_N, trial.speed_mps
    known = np.isfinite(thrust) & np.isfinite(speed)
    if not np.any(known):
        raise InputError(f"{source}: no sample has both a thrust command and a GNSS velocity "
                         "(commands and GNSS do not overlap in time)")
    in_gap = np.zeros(t.size, dtype=bool)
    for role, start_s, end_s in trial.metadata.gaps:
        if role in SURGE_ROLES:
            in_gap |= (t > start_s) & (t < end_s)
    bad = ~known & ~in_gap & (t >= t[np.argmax(known)])
    if np.any(bad):
        first = int(np.argmax(bad))
        name = "surge thrust" if not np.isfinite(thrust[first]) else "speed over ground"
        raise InputError(f"{source}: {int(bad.sum())} sample(s) are NaN outside the reported gaps (first: "
                         f"{name} at t = {t[first]:.1f} s): the recording holds non-finite values")
    return t[known], thrust[known], speed[known]


def replay_online(
    t_s: np.ndarray,
    thrust_N: np.ndarray,  # noqa: N803 (unit suffix)
    speed_mps: np.ndarray,
    identifier: OnlineThrustSpeedIdentifier,
) -> OnlineThrustSpeedIdentifier:
    """Feed a trial's samples to ``identifier`` one by one in timestamp order, then close its last segment.

    The replay of ``boat-twin identify TRIAL``: the same :meth:`~OnlineThrustSpeedIdentifier.update` calls the
    identifier node makes live. Returns ``identifier``.
    """
    for sample in zip(np.asarray(t_s).tolist(), np.asarray(thrust_N).tolist(), np.asarray(speed_mps).tolist(),
                      strict=True):
        identifier.update(*sample)
    identifier.finish()
    return identifier


def identify_arrays(
    t_s: Any,
    thrust_N: Any,  # noqa: N803 (unit suffix)
    speed_mps: Any,
    *,
    order: int | None = None,
    max_order: int = 6,
    monotone: bool = False,
    through_origin: bool = True,
    criteria: SteadyCriteria | None = None,
    window: DynamicWindow | None = None,
    memory_s: float = 3600.0,
) -> dict[str, Any]:
    """Identify a trial from its arrays: time (s), total thrust (N), speed through water or over ground (m/s).

    Steady points (detector), steady fits of N = 1..``max_order`` with CV/BIC selection (or ``order``),
    mass + Fc from transients (own order selection), and the online identifier replayed over the same
    samples with its agreement with batch. Steady fits impose Fc(0) = 0 unless ``through_origin`` is False
    (trial steady points start above rest: a free c_0 would be an extrapolation). Returns the ``--json``
    contract (SI): ``steady_points``, ``rejected_segments``, ``fits``, ``selected_order``,
    ``selection_reason``, ``dynamic``, ``online``, ``model`` (for :func:`write_model_yaml`) and ``warnings``.
    A trial whose transients cannot give the mass still yields the steady model; ``dynamic`` then holds
    ``{"error": why}``.
    """
    t, f, v = check_samples(t_s, thrust_N, speed_mps)
    criteria = criteria or SteadyCriteria()
    if np.ptp(f) <= max(
        criteria.thrust_tolerance_N, criteria.thrust_tolerance_rel * float(np.max(np.abs(f)))
    ):
        raise InputError(
            f"thrust is constant ({np.mean(f):.1f} N) over the whole trial: Fc(v) and the mass are "
            "unidentifiable from one thrust level; record thrust steps"
        )
    segments = detect_steady_segments(t, f, v, criteria)
    points = [s for s in segments if s.accepted]
    rejected = [s for s in segments if not s.accepted]
    needed = (order or 1) + 2
    if len(points) < needed:
        why = "; ".join(f"{s.thrust_N:.0f} N at {s.start_s:.0f} s: {s.reason}" for s in rejected[:3])
        raise InputError(
            f"{len(points)} steady point(s) found, order {order or 1} needs at least {needed} (N + 2): "
            f"hold more thrust levels until the speed settles ({criteria.window_s:g} s without a trend)"
            + (f"; rejected: {why}" if why else "")
        )
    speed = np.array([s.speed_mps for s in points])
    thrust = np.array([s.thrust_N for s in points])
    if order is None:
        selection = select_order(speed, thrust, max_order, monotone, through_origin=through_origin)
        fits: tuple[FitResult, ...] = selection.fits
        chosen, reason = selection.selected_order, selection.reason
    else:
        fits = (fit_power_series(speed, thrust, order, monotone, through_origin),)
        chosen, reason = order, f"N = {order}: given"
    fit = next(fr for fr in fits if fr.order == chosen)
    warnings = []
    if not fit.monotone:
        bands = ", ".join(f"{lo:.2f}-{hi:.2f}" for lo, hi in fit.nonmonotone_bands)
        warnings.append(
            f"the selected fit decreases at {bands} m/s: steady speed not unique there (use --monotone)"
        )
    if fit.coefficients[0] < 0.0:
        warnings.append(
            f"Fc(0) = {fit.coefficients[0]:.3g} N < 0: the model creeps at zero thrust (use --monotone)"
        )
    try:
        dyn = identify_dynamic(t, f, v, None, window)
        dynamic: dict[str, Any] = dyn.to_dict()
        if dyn.two_way_fraction < TWO_WAY_WARNING:
            warnings.append(
                f"only {dyn.two_way_fraction:.0%} of the speed range was crossed both accelerating and "
                "decelerating: the mass rests on the polynomial form of Fc; add thrust steps down as well"
            )
    except InputError as err:
        dyn = None
        dynamic = {"error": str(err)}
    online = OnlineThrustSpeedIdentifier(
        chosen,
        dyn.order if dyn else chosen,
        memory_s=memory_s,
        through_origin=through_origin,
        criteria=criteria,
        window=window,
    )
    snap = replay_online(t, f, v, online).snapshot()
    grid = np.linspace(speed.min(), speed.max(), 200)
    agreement: dict[str, Any] = {}
    if snap["coefficients"] is not None:
        agreement["curve_nrms"] = _nrms(
            np.polynomial.polynomial.polyval(grid, snap["coefficients"]), fit.predict(grid)
        )
    if dyn is not None and snap["dynamic"] is not None:
        agreement["mass_rel"] = snap["dynamic"]["mass_kg"] / dyn.mass_kg - 1.0
    snap["agreement_with_batch"] = agreement
    return {
        "steady_points": [
            {
                "speed_mps": s.speed_mps,
                "thrust_N": s.thrust_N,
                "duration_s": s.duration_s,
                "start_s": s.start_s,
                "end_s": s.end_s,
                "speed_stderr_mps": s.speed_stderr_mps,
            }
            for s in points
        ],
        "rejected_segments": [s.to_dict() for s in rejected],
        "fits": [fr.to_dict() for fr in fits],
        "selected_order": chosen,
        "selection_reason": reason,
        "dynamic": dynamic,
        "online": snap,
        "model": model_dict(fit, dyn.mass_kg if dyn else None),
        "warnings": warnings,
    }


def write_trial_report(
    out_dir: Path,
    result: dict[str, Any],
    t_s: np.ndarray,
    thrust_N: np.ndarray,  # noqa: N803 (unit suffix)
    speed_mps: np.ndarray,
    resimulation: Resimulation | None = None,
) -> list[Path]:
    """Write identify.json, model.yaml, trial.png, resistance.png (and resimulation.png: measured vs
    re-simulated speed, when ``resimulation`` is given) for an :func:`identify_arrays` result."""
    out = ensure_out_dir(out_dir)
    written = [out / "identify.json", out / "model.yaml", out / "trial.png", out / "resistance.png"]
    if resimulation is not None:
        written.append(out / "resimulation.png")
        atomic_save_figure(written[-1], resimulation_figure(resimulation))
    atomic_write_text(written[0], to_json(result) + "\n")
    write_model_yaml(written[1], result["model"], f"boat-twin identify: order {result['selected_order']}, SI")
    fig = Figure(figsize=(9, 6))
    ax_v, ax_f = fig.subplots(2, 1, sharex=True)
    ax_v.plot(t_s, speed_mps, lw=0.6, color="0.4", label="speed")
    for seg in result["steady_points"]:
        ax_v.axvspan(seg["end_s"] - seg["duration_s"], seg["end_s"], color="tab:green", alpha=0.25)
    for seg in result["rejected_segments"]:
        ax_v.axvspan(seg["start_s"], seg["end_s"], color="tab:red", alpha=0.15)
    ax_v.set_ylabel("speed, m/s")
    ax_v.set_title("settled tails (green), rejected segments (red)")
    ax_f.plot(t_s, thrust_N, color="tab:blue")
    ax_f.set_ylabel("total thrust, N")
    ax_f.set_xlabel("time, s")
    atomic_save_figure(written[2], fig)
    fig = Figure(figsize=(7, 5))
    ax = fig.subplots()
    pts = result["steady_points"]
    sv = np.array([p["speed_mps"] for p in pts])
    grid = np.linspace(0.0, sv.max(), 300)
    ax.plot(sv, [p["thrust_N"] for p in pts], "ko", label="steady points")
    fit = next(f for f in result["fits"] if f["order"] == result["selected_order"])
    ax.plot(
        grid,
        np.polynomial.polynomial.polyval(grid, fit["coefficients"]),
        label=f"steady LSQ, N = {fit['order']}",
    )
    if "coefficients" in result["dynamic"]:
        c = result["dynamic"]["coefficients"]
        ax.plot(grid, np.polynomial.polynomial.polyval(grid, c), "--", label="from transients")
    if result["online"]["coefficients"] is not None:
        ax.plot(
            grid,
            np.polynomial.polynomial.polyval(grid, result["online"]["coefficients"]),
            ":",
            label="online RLS",
        )
    ax.set_xlabel("speed, m/s")
    ax.set_ylabel("resistance Fc, N")
    ax.legend()
    atomic_save_figure(written[3], fig)
    return written


def _table_report(result: dict[str, Any], si_fit: FitResult) -> str:
    """Human-readable report of the dyda2021 reproduction (kn, kgf)."""
    paper = result["paper"]
    fits = {f["order"]: f for f in result["fits"]}
    sel = result["selected_order"]
    lines = [
        "Dyda & Chumakova (2021), Table 1: 37 rows; v in knots, F in kgf (the paper prints no units; "
        "see README).",
        "",
        "Printed model values against the printed coefficients:",
    ]
    for n in PAPER_ORDERS:
        tab = paper["tables"][str(n)]
        dev = tab["max_rel_dev_without_misprints"]
        text = f"  N = {n} (Table {tab['table']}): max relative deviation {dev:.1e}"
        for bad in tab["misprints"]:
            text += (
                f"; misprint at v = {bad['speed_kn']:g} kn: printed {bad['printed_kgf']:.7f}, "
                f"the coefficients give {bad['recomputed_kgf']:.7f}"
            )
        lines.append(text)
    lines += [
        "",
        f"Fisher statistic by the paper's formula (m = {paper['fisher_formula']['m']}, n = "
        f"{paper['fisher_formula']['n']} in (n - m - 1), sums over all "
        f"{paper['fisher_formula']['rows_summed']} rows):",
        "  N   Table 7   recomputed   agrees (±0.05)",
    ]
    for n in PAPER_ORDERS:
        agrees = "yes" if paper["fisher_agrees"][str(n)] else "NO"
        lines.append(f"  {n}   {PAPER_FISHER[n]:7.2f}   {paper['fisher'][str(n)]:10.2f}   {agrees}")
    lines += [
        "",
        "Paper's fits against the least-squares optimum (kgf; CV = leave-one-out):",
        "  N   paper RMSE   LSQ RMSE   LSQ CV RMSE   LSQ BIC   Fisher (LSQ)   monotone",
    ]
    for n in sorted(set(PAPER_ORDERS) | {sel}):
        fr = fits[n]
        paper_rmse = f"{paper['rmse'][str(n)]:10.3f}" if str(n) in paper["rmse"] else f"{'-':>10}"
        cv = f"{fr['cv_rmse']:11.3f}" if fr["cv_rmse"] is not None else f"{'inf':>11}"
        mark = "*" if n == sel else " "
        lines.append(
            f"  {n}{mark}  {paper_rmse}   {fr['rmse']:8.3f}   {cv}   {fr['bic']:7.2f}   {fr['fisher']:12.1f}"
            f"   {'yes' if fr['monotone'] else 'no'}"
        )
    lines += ["", f"Order selection: {result['selection_reason']}.", ""]
    fr = fits[sel]
    lines.append(
        f"Selected fit, N = {sel}{' (monotone constraint)' if fr['monotone_constraint'] else ''}, "
        "c_i in kgf/kn^i with 95 % intervals:"
    )
    for i, (c, (lo, hi)) in enumerate(zip(fr["coefficients"], fr["ci95"], strict=True)):
        lines.append(f"  c{i} = {c: .6e}   [{lo: .4e}, {hi: .4e}]")
    if fr["nonmonotone_bands"]:
        bands = ", ".join(f"{lo:.2f}-{hi:.2f} kn" for lo, hi in fr["nonmonotone_bands"])
        lines.append(f"Fc decreases at {bands}: use --monotone for a simulator model.")
    else:
        lines.append(f"Fc is non-decreasing over {fr['domain'][0]:g}-{fr['domain'][1]:g} kn.")
    if fr["coefficients"][0] < 0.0:
        lines.append(
            f"Fc(0) = c0 = {fr['coefficients'][0]:.3g} kgf < 0: a simulator would creep at zero thrust; "
            "use --monotone or --through-origin for a simulator model."
        )
    lines += [
        f"SI (N/(m/s)^i): {', '.join(f'{c:.6e}' for c in si_fit.coefficients)}",
        f"Extrapolation: valid up to {si_fit.domain[1]:.3f} m/s ({fr['domain'][1]:g} kn); the simulator "
        "model "
        "continues "
        "beyond as Fc(v_max)·(v/v_max)², never with the polynomial.",
    ]
    return "\n".join(lines) + "\n"


def _table_figures(result: dict[str, Any]) -> tuple[Figure, Figure]:
    """Table 1 with the paper's and the least-squares fits; residuals of both."""
    speed, thrust = dyda2021_table1()
    grid = np.linspace(0.0, speed.max(), 300)
    fits = {f["order"]: f for f in result["fits"]}
    orders = sorted(set(PAPER_ORDERS) | {result["selected_order"]})
    fig = Figure(figsize=(11, 4.5))
    ax_paper, ax_lsq = fig.subplots(1, 2, sharey=True)
    res = Figure(figsize=(11, 4.5))
    rx_paper, rx_lsq = res.subplots(1, 2, sharey=True)
    for n in PAPER_ORDERS:
        ax_paper.plot(
            grid, np.polynomial.polynomial.polyval(grid, PAPER_COEFFICIENTS[n]), label=f"paper N = {n}"
        )
        rx_paper.plot(speed, thrust - paper_model_values(n), "o-", ms=3, label=f"paper N = {n}")
    for n in orders:
        c = fits[n]["coefficients"]
        ax_lsq.plot(grid, np.polynomial.polynomial.polyval(grid, c), label=f"LSQ N = {n}")
        rx_lsq.plot(
            speed, thrust - np.polynomial.polynomial.polyval(speed, c), "o-", ms=3, label=f"LSQ N = {n}"
        )
    for ax, title in ((ax_paper, "paper's coefficients"), (ax_lsq, "least-squares optimum")):
        ax.plot(speed, thrust, "ko", ms=4, label="Table 1")
        ax.set_title(title)
        ax.set_xlabel("speed v, kn")
        ax.legend()
    ax_paper.set_ylabel("thrust F, kgf")
    for ax in (rx_paper, rx_lsq):
        ax.axhline(0.0, color="0.5", lw=0.8)
        ax.set_xlabel("speed v, kn")
        ax.legend()
    rx_paper.set_ylabel("residual F - F_m, kgf")
    return fig, res


def _run_table(args: argparse.Namespace) -> int:
    result = reproduce(args.monotone, args.order, args.max_order, args.through_origin)
    speed_si, thrust_si = dyda2021_table1_si()
    si_fit = fit_power_series(
        speed_si, thrust_si, result["selected_order"], args.monotone, args.through_origin
    )
    result["si"] = {
        "order": si_fit.order,
        "coefficients": si_fit.coefficients.tolist(),
        "stderr": si_fit.stderr.tolist(),
        "max_speed_mps": si_fit.domain[1],
        "units": {
            "speed": "m/s",
            "force": "N",
            "coefficients": "N/(m/s)^i",
            "knot_mps": KNOT_MPS,
            "kgf_N": KGF_N,
        },
    }
    report = _table_report(result, si_fit)
    if args.out is not None:
        out = ensure_out_dir(args.out)
        atomic_write_text(out / "identify.json", to_json(result) + "\n")
        atomic_write_text(out / "report.txt", report)
        write_model_yaml(
            out / "model.yaml",
            model_dict(si_fit),
            f"Dyda & Chumakova (2021) Table 1 read as kn/kgf, least squares N = {si_fit.order}, SI units",
        )
        fits_fig, resid_fig = _table_figures(result)
        atomic_save_figure(out / "fits.png", fits_fig)
        atomic_save_figure(out / "residuals.png", resid_fig)
    sys.stdout.write(to_json(result) + "\n" if args.json else report)
    return 0


def run(args: argparse.Namespace) -> int:
    """Handler of ``boat-twin identify``."""
    if args.order is not None and not 1 <= args.order <= MAX_ORDER:
        raise InputError(f"--order must be from 1 to {MAX_ORDER}, got {args.order}")
    if not 1 <= args.max_order <= MAX_ORDER:
        raise InputError(f"--max-order must be from 1 to {MAX_ORDER}, got {args.max_order}")
    if args.table is not None and args.trial is not None:
        raise InputError("give a TRIAL or --table, not both")
    if args.table is not None:
        return _run_table(args)
    if args.trial is None:
        raise InputError("nothing to identify: give a TRIAL (bag, .mcap, .tlog, .BIN) or --table dyda2021")
    return _run_trial(args)


def _run_trial(args: argparse.Namespace) -> int:
    """A recorded trial: replay it through the online identifier, batch fits, dynamic mass, re-simulation with
    the identified model (closing the loop), report."""
    from boat_twin.io.sources import read_trial_file

    sys.stderr.write(f"reading {args.trial} ...\n")
    remap = dict(_role_topic(item) for item in args.topic)
    trial = read_trial_file(args.trial, remap=remap, namespace=args.namespace, calibration=args.calibration)
    sys.stderr.write(trial.metadata.summary_line() + "\n")
    t_s, thrust, speed = trial_samples(trial)
    result = identify_arrays(t_s, thrust, speed, order=args.order, max_order=min(args.max_order, 6),
                             monotone=args.monotone)
    result["trial"] = {"source": str(args.trial), "metadata": trial.metadata.summary_line(),
                       "gaps": trial.metadata.gaps, "missing": trial.metadata.missing}
    sys.stderr.write("re-simulating the trial's commands with the identified model ...\n")
    try:
        resim: Resimulation | None = resimulate(trial, result["model"])
        result["resimulation"] = resim.to_dict()
    except InputError as err:  # the identification stands; say why the loop could not be closed
        resim = None
        result["resimulation"] = {"error": str(err)}
    if args.out is not None:
        write_trial_report(args.out, result, t_s, thrust, speed, resim)
    if args.json:
        sys.stdout.write(to_json(result) + "\n")
        return 0
    fit = next(f for f in result["fits"] if f["order"] == result["selected_order"])
    dyn = result.get("dynamic", {})
    lines = [
        f"trial {args.trial}: {len(result['steady_points'])} steady points, "
        f"{len(result.get('rejected_segments', []))} segments rejected",
        f"selected order N = {result['selected_order']} ({result.get('selection_reason', '')})",
        "Fc(v) coefficients c0..cN, N/(m/s)^i: " + ", ".join(f"{c:.4g}" for c in fit["coefficients"]),
        f"RMSE {fit['rmse']:.2f} N",
        f"effective mass {dyn['mass_kg']:.0f} kg, 95% CI [{dyn['mass_ci95_kg'][0]:.0f}, {dyn['mass_ci95_kg'][1]:.0f}]"
        if "mass_kg" in dyn else f"effective mass: {dyn.get('error', 'not identified')}",
    ]
    for seg in result.get("rejected_segments", []):
        lines.append(f"rejected {seg['start_s']:.1f}-{seg['end_s']:.1f} s at {seg['thrust_N']:.0f} N: {seg['reason']}")
    lines.append(_resimulation_line(result["resimulation"]))
    lines += [f"warning: {w}" for w in result.get("warnings", [])]
    sys.stdout.write("\n".join(lines) + "\n")
    return 0


def _resimulation_line(resim: dict[str, Any]) -> str:
    """One report line: the speed error of the re-simulated trial (or why there is none)."""
    if "error" in resim:
        return f"re-simulation: not done ({resim['error']})"
    mass = "identified" if resim["mass_identified"] else "default boat's"
    relative = f" = {resim['speed_nrmse']:.1%} of the mean speed {resim['mean_speed_mps']:.2f} m/s" \
        if resim["speed_nrmse"] is not None else ""
    return (
        f"re-simulated with the identified model ({mass} mass {resim['effective_mass_kg']:.0f} kg, calm water): "
        f"speed RMSE {resim['speed_rmse_mps']:.3f} m/s{relative} over {resim['duration_s']:.0f} s "
        f"(bias {resim['speed_bias_mps']:+.3f} m/s, max {resim['speed_max_abs_error_mps']:.2f} m/s; "
        f"GNSS speed noise {resim['speed_noise_mps']:.3f} m/s)"
    )


def _role_topic(item: str) -> tuple[str, str]:
    role, sep, topic = item.partition("=")
    if not sep or not role or not topic:
        raise InputError(f"--topic {item!r}: expected ROLE=/topic/name")
    return role, topic


def register(subparsers: Any) -> None:
    """Add the ``identify`` verb."""
    p = subparsers.add_parser(
        "identify",
        help="identify m·dv/dt = F - Fc(v): resistance curve and effective mass",
        description="Identify the longitudinal model m·dv/dt = F - Fc(v), Fc(v) = sum c_i·v^i "
        "(Dyda & Chumakova 2021). Internally SI; the built-in table is reported in its own units (kn, kgf).",
    )
    p.add_argument("trial", nargs="?", type=Path, help=TRIAL_HELP)
    add_trial_options(p)
    p.add_argument(
        "--table",
        choices=["dyda2021"],
        help="built-in steady-state table: dyda2021 = Dyda & Chumakova (2021) Table 1, v in kn, F in kgf",
    )
    p.add_argument(
        "--order", type=int, help="power-series order N (default: chosen by leave-one-out CV and BIC)"
    )
    p.add_argument(
        "--max-order", type=int, default=8, help="highest order N tried by the selection (default 8)"
    )
    p.add_argument(
        "--monotone",
        action="store_true",
        help="constrain Fc to be non-decreasing from 0 to the top speed and Fc(0) >= 0",
    )
    p.add_argument(
        "--through-origin", action="store_true", help="impose Fc(0) = c0 = 0 (no resistance at rest)"
    )
    p.add_argument("--json", action="store_true", help="machine-readable result on stdout")
    p.add_argument(
        "--out",
        type=Path,
        metavar="DIR",
        help="write report.txt, identify.json, model.yaml (SI) and PNG plots here",
    )
    p.set_defaults(handler=run)
