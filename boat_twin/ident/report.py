"""Reports of the identification: text, the written files (JSON, model YAML) and the figures (PNG)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from boat_twin.data import dyda2021_table1
from boat_twin.data.dyda2021 import PAPER_COEFFICIENTS, PAPER_FISHER, PAPER_ORDERS
from boat_twin.files import atomic_save_figure, atomic_write_text, ensure_out_dir, to_json
from boat_twin.ident.paper import paper_model_values
from boat_twin.ident.pipeline import IdentifyResult, write_model_yaml
from boat_twin.ident.resimulate import Resimulation, resimulation_figure
from boat_twin.ident.steady import FitResult


def write_trial_report(
    out_dir: Path,
    result: IdentifyResult,
    t_s: np.ndarray,
    thrust_N: np.ndarray,
    speed_mps: np.ndarray,
    resimulation: Resimulation | None = None,
    true_resistance_N: Callable[[np.ndarray], np.ndarray] | None = None,
    *,
    title: str | None = None,
) -> list[Path]:
    """Write identify.json, model.yaml, trial.png, resistance.png (and resimulation.png: measured vs
    re-simulated speed, when ``resimulation`` is given) for an :func:`identify_arrays` result, each figure titled
    ``title`` (the trial it shows). ``true_resistance_N`` (speed m/s → N): the true curve, drawn when known (a
    simulated trial)."""
    out = ensure_out_dir(out_dir)
    written = [out / "identify.json", out / "model.yaml", out / "trial.png", out / "resistance.png"]
    if resimulation is not None:
        written.append(out / "resimulation.png")
        atomic_save_figure(written[-1], resimulation_figure(resimulation), title)
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
    atomic_save_figure(written[2], fig, title)
    atomic_save_figure(written[3], resistance_figure(result, true_resistance_N), title)
    return written


def unvisited_bands(speeds_mps: np.ndarray) -> list[tuple[float, float]]:
    """Speed intervals (m/s) with no steady point inside: gaps between neighbouring steady speeds wider than
    twice their median spacing. The fitted curve there is an interpolation the data do not check."""
    speeds = np.sort(np.asarray(speeds_mps, dtype=float))
    if speeds.size < 3:
        return []
    gaps = np.diff(speeds)
    wide = np.flatnonzero(gaps > 2.0 * np.median(gaps))
    return [(float(speeds[i]), float(speeds[i + 1])) for i in wide]


def resistance_figure(result: IdentifyResult,
                      true_resistance_N: Callable[[np.ndarray], np.ndarray] | None = None) -> Figure:
    """Steady points and the identified curves Fc(v) (drawn so that coinciding curves all show), the true curve
    when known, and the speed bands with no steady point."""
    fig = Figure(figsize=(7, 5), layout="constrained")
    ax = fig.subplots()
    pts = result["steady_points"]
    sv = np.array([p["speed_mps"] for p in pts])
    grid = np.linspace(0.0, sv.max(), 300)
    for k, (lo, hi) in enumerate(unvisited_bands(sv)):
        ax.axvspan(lo, hi, color="0.92", label="no steady point: curves interpolate" if k == 0 else None)
    if true_resistance_N is not None:
        ax.plot(grid, true_resistance_N(grid), color="k", lw=1.0, label="true Fc (the simulated boat)")
    fit = next(f for f in result["fits"] if f["order"] == result["selected_order"])
    ax.plot(grid, np.polynomial.polynomial.polyval(grid, fit["coefficients"]), color="C0", lw=4.0, alpha=0.45,
            label=f"steady least squares, N = {fit['order']}")
    if "coefficients" in result["dynamic"]:
        c = result["dynamic"]["coefficients"]
        ax.plot(grid, np.polynomial.polynomial.polyval(grid, c), "--", color="C1", lw=1.5, label="from transients")
    if result["online"]["coefficients"] is not None:
        ax.plot(grid, np.polynomial.polynomial.polyval(grid, result["online"]["coefficients"]), ":", color="C2",
                lw=2.0, label="online recursive least squares")
    ax.plot(sv, [p["thrust_N"] for p in pts], "ko", ms=5, mfc="white", label="steady points", zorder=5)
    ax.set_xlabel("speed, m/s")
    ax.set_ylabel("resistance Fc, N")
    ax.legend(fontsize=8)
    return fig


def table_report(result: dict[str, Any], si_fit: FitResult) -> str:
    """Human-readable report of the dyda2021 reproduction (kn, kgf)."""
    paper = result["paper"]
    fits = {f["order"]: f for f in result["fits"]}
    sel = result["selected_order"]
    lines = [
        "Dyda & Chumakova (2021), Table 1: 37 rows; v in knots, F in kgf (the paper prints no units; "
        "see docs/model.md).",
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
    for n in sorted((set(PAPER_ORDERS) & set(fits)) | {sel}):  # --max-order may leave the paper's high orders out
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


def table_figures(result: dict[str, Any]) -> tuple[Figure, Figure]:
    """Table 1 with the paper's and the least-squares fits; residuals of both."""
    speed, thrust = dyda2021_table1()
    grid = np.linspace(0.0, speed.max(), 300)
    fits = {f["order"]: f for f in result["fits"]}
    orders = sorted((set(PAPER_ORDERS) & set(fits)) | {result["selected_order"]})
    fig = Figure(figsize=(11, 4.5), layout="constrained")
    ax_paper, ax_lsq = fig.subplots(1, 2, sharey=True)
    res = Figure(figsize=(11, 4.5), layout="constrained")
    rx_paper, rx_lsq = res.subplots(1, 2, sharey=True)
    for n in PAPER_ORDERS:
        ax_paper.plot(
            grid, np.polynomial.polynomial.polyval(grid, PAPER_COEFFICIENTS[n]), label=f"paper N = {n}"
        )
        rx_paper.plot(speed, thrust - paper_model_values(n), "o-", ms=3, label=f"paper N = {n}")
    for k, n in enumerate(orders):  # each order drawn thinner than the one before: close curves all show
        c = fits[n]["coefficients"]
        ax_lsq.plot(grid, np.polynomial.polynomial.polyval(grid, c), lw=1.0 + 1.0 * (len(orders) - 1 - k),
                    alpha=0.8, label=f"least squares N = {n}")
        rx_lsq.plot(
            speed, thrust - np.polynomial.polynomial.polyval(speed, c), "o-", ms=3, label=f"least squares N = {n}"
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


def resimulation_line(resim: dict[str, Any]) -> str:
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
