"""Reports of the identification: text, the written files (JSON, model YAML) and the figures (PNG)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.collections import PolyCollection
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from boat_twin.config import TwinConfig, save_config
from boat_twin.data import dyda2021_table1
from boat_twin.data.dyda2021 import PAPER_COEFFICIENTS, PAPER_FISHER, PAPER_ORDERS
from boat_twin.drawn_line import drawn_series
from boat_twin.files import atomic_save_figure, atomic_write_text, ensure_out_dir, to_json
from boat_twin.ident.output_error import SurgeRecord
from boat_twin.ident.paper import paper_model_values
from boat_twin.ident.resimulate import Resimulation, resimulation_figure
from boat_twin.ident.results import (
    NOT_PHYSICAL_NEXT,
    IdentifyResult,
    TrialIdentifyResult,
    TrialsIdentification,
    write_model_yaml,
)
from boat_twin.ident.steady import FitResult
from boat_twin.model_error import ModelError
from boat_twin.sensors.gnss import GnssConfig
from boat_twin.vessel.params import VesselParams
from boat_twin.vessel.resistance import resistance_from_dict


def write_trial_report(
    out_dir: Path,
    result: IdentifyResult,
    records: Sequence[SurgeRecord],
    resimulation: Resimulation | None = None,
    true_resistance_N: Callable[[np.ndarray], np.ndarray] | None = None,
    *,
    title: str | None = None,
) -> list[Path]:
    """Write identify.json, model.yaml, trial.png (:func:`trial_figure` of ``records``, the records the fit read:
    :attr:`~boat_twin.ident.results.Identification.records`), resistance.png (and resimulation.png: measured vs
    re-simulated speed, when ``resimulation`` is given) for an identification's ``--json`` result, each figure
    titled ``title`` (the trial it shows). ``true_resistance_N`` (speed m/s → N): the true curve, drawn when known
    (a simulated trial)."""
    out = ensure_out_dir(out_dir)
    written = [out / "identify.json", out / "model.yaml", out / "trial.png", out / "resistance.png"]
    if resimulation is not None:
        written.append(out / "resimulation.png")
        atomic_save_figure(written[-1], resimulation_figure(resimulation), title)
    atomic_write_text(written[0], to_json(result) + "\n")
    write_model_yaml(written[1], result["model"],
                     f"boat-twin identify: output-error fit ({result['output_error']['selected']['model']}), SI")
    atomic_save_figure(written[2], trial_figure(result, records), title)
    atomic_save_figure(written[3], resistance_figure(result, true_resistance_N), title)
    return written


def trial_figure(result: IdentifyResult, records: Sequence[SurgeRecord]) -> Figure:
    """The records the output-error fit read, each on the pooled time axis: the speed (a trial's surge along the
    heading at the time it describes) with the steady-point view's settled tails (green) and the segments that
    gave no steady point (hatched grey: the output-error fit reads every sample, theirs too), the
    thrust held over each interval (a trial's delivered along the hull) and, where the fit scaled one, the
    coupling force c·m₂₂·v·r (with a measured wind: the wind's force, its drag coefficient fitted)."""
    fig = Figure(figsize=(9, 6))
    ax_v, ax_f = fig.subplots(2, 1, sharex=True)
    scale = result["output_error"]["selected"].get("coupling_scale", 1.0)
    coupled = False
    for k, rec in enumerate(records):
        ax_v.plot(*drawn_series(rec.t_s, rec.speed_mps), lw=0.6, color="0.4")
        ax_f.plot(*drawn_series(rec.t_s, rec.thrust_N), color="tab:blue", drawstyle="steps-post",
                  label="thrust" if k == 0 else None)
        if rec.coupling_N is not None:
            label = (f"measured wind's force k·(|Va|·ua + |V|·u), k = {scale:.3g} N·s²/m²" if "wind_drag" in result
                     else f"coupling c·m22·v·r, c = {scale:.2f}")
            ax_f.plot(*drawn_series(rec.t_s, scale * rec.coupling_N), lw=0.8, color="tab:orange",
                      drawstyle="steps-post", label=None if coupled else label)
            coupled = True
    _spans(ax_v, [(seg["end_s"] - seg["duration_s"], seg["end_s"]) for seg in result["steady_points"]],
           label="steady point (its settled tail)", facecolor="tab:green", alpha=0.25, lw=0.0)
    _spans(ax_v, [(seg["start_s"], seg["end_s"]) for seg in result["rejected_segments"]],  # in the fit too: no alarm
           label="no steady point (too short or not settled: in the fit all the same)", facecolor="none",
           edgecolor="0.6", hatch="//", lw=0.0)
    ax_v.set_ylabel("speed as fitted, m/s")
    ax_v.set_title("the record fitted, every sample; the steady-point view shaded", fontsize=10)
    if result["steady_points"] or result["rejected_segments"]:
        ax_v.legend(fontsize=7, loc="best")
    ax_f.set_ylabel("surge force, N")
    ax_f.set_xlabel("time, s")
    if coupled:
        ax_f.legend(fontsize=8)
    return fig


def _spans(ax: Axes, spans: list[tuple[float, float]], label: str, **style: Any) -> None:
    """Time spans (start, end) in s shaded over the axes' height as one artist (an hours-long trial has hundreds:
    one patch each made the legend's placement search and the renderer hold them all several times over)."""
    if spans:
        ax.add_collection(PolyCollection([[(a, 0.0), (a, 1.0), (b, 1.0), (b, 0.0)] for a, b in spans],
                                         transform=ax.get_xaxis_transform(), **style))
        ax.add_patch(Rectangle((spans[0][0], 0.0), 0.0, 0.0, label=label, **style))  # the legend's entry


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
    """The identified Fc(u) (output error) with its 95 % band, the baseline fitted the same way, the steady
    points and their polynomial (a view), the true curve when known, and the speed bands no steady point visits."""
    fig = Figure(figsize=(7, 5), layout="constrained")
    ax = fig.subplots()
    oe = result["output_error"]
    selected, baseline = oe["selected"], oe["baseline"]
    pts = result["steady_points"]
    sv = np.array([p["speed_mps"] for p in pts])
    grid = np.linspace(0.0, selected["top_speed_mps"], 300)
    for k, (lo, hi) in enumerate(unvisited_bands(sv)):
        ax.axvspan(lo, hi, color="0.92", label="no steady point" if k == 0 else None)
    if true_resistance_N is not None:
        ax.plot(grid, true_resistance_N(grid), color="k", lw=1.0, label="true Fc (the simulated boat)")
    table = selected["resistance_table"]
    ax.fill_between(table["speed_mps"], table["ci95_low_N"], table["ci95_high_N"], color="C0", alpha=0.25,
                    label="95 % interval (cluster-robust)")
    model = resistance_from_dict(result["model"]["resistance"])
    ax.plot(grid, model.force_N(grid), color="C0", lw=2.0, label=f"output error, {selected['model']} (the model)")
    a, b = baseline["coefficients"]
    ax.plot(grid, a * grid + b * grid**2, "--", color="C1", lw=1.5, label="baseline a·u + b·u|u|, output error")
    if result["selected_order"] is not None:
        fit = next(f for f in result["fits"] if f["order"] == result["selected_order"])
        top = np.linspace(0.0, sv.max(), 200)
        ax.plot(top, np.polynomial.polynomial.polyval(top, fit["coefficients"]), ":", color="C2", lw=1.5,
                label=f"steady points' polynomial, N = {fit['order']} (a view)")
    if pts:
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
    """One report line: the speed error of the re-simulated trial (or why there is none). A mass that is not
    identified leads the line."""
    if "error" in resim:
        return f"re-simulation: not done ({resim['error']})"
    source = resim["mass_source"]
    relative = f" = {resim['speed_nrmse']:.1%} of the mean speed {resim['mean_speed_mps']:.2f} m/s" \
        if resim["speed_nrmse"] is not None else ""
    head = "re-simulated with the identified model" if source == "identified" else \
        f"MASS {source.upper()}: re-simulated with it"
    return (
        f"{head} (effective mass {resim['effective_mass_kg']:.0f} kg, {source}; calm water): "
        f"speed RMSE {resim['speed_rmse_mps']:.3f} m/s{relative} over {resim['duration_s']:.0f} s "
        f"(bias {resim['speed_bias_mps']:+.3f} m/s, max {resim['speed_max_abs_error_mps']:.2f} m/s; "
        f"GNSS speed noise {resim['speed_noise_mps']:.3f} m/s)"
    )


def count(n: int, noun: str) -> str:
    """``1 segment``, ``2 segments``."""
    return f"{n} {noun}{'' if n == 1 else 's'}"


def thrust_scale_line(scale: dict[str, Any]) -> str:
    """The thrust's scale with the mass held at the boat file's (selected fit, baseline), in one line."""
    def interval(fit: dict[str, Any]) -> str:
        lo, hi = (f"{v:.3g}" if v is not None else "unbounded" for v in fit["ci95"])
        return f"{fit['scale']:.3g} [{lo}, {hi}]" + ("" if fit["identified"] else " NOT IDENTIFIED")
    return (f"thrust scale k with the effective mass held at the boat file's {scale['mass_held_kg']:.4g} kg, "
            f"95% CI: {interval(scale['selected'])} (baseline {interval(scale['baseline'])}); the surge alone "
            "cannot tell a heavier boat from a weaker thrust: the model keeps the fitted mass and k = 1")


def model_lines(result: IdentifyResult) -> list[str]:
    """The identified model in words: the selected output-error fit against the baseline, the curve with its
    intervals, the mass (or why there is none), the steady points' polynomial as a view, and anything not
    physical — the latter first."""
    oe = result["output_error"]
    sel, base = oe["selected"], oe["baseline"]
    cv = {c["model"]: c["cv_rmse_mps"] for c in oe["candidates"]}
    lines = [f"NOT PHYSICAL, no twin: {problem}" for problem in result["physical_problems"]]
    if lines:
        lines.append(NOT_PHYSICAL_NEXT)
    lines.append(f"model: output error, {sel['model']} ({oe['selection_reason']}; cross-validation: {oe['folds']})")
    table = sel["resistance_table"]
    picks = [i for i in (2, 4, 6, 8, 10) if i < len(table["speed_mps"])]
    lines.append("Fc(u), N [95% interval]: " + ", ".join(
        f"{table['force_N'][i]:.4g} [{table['ci95_low_N'][i]:.4g}, {table['ci95_high_N'][i]:.4g}] at "
        f"{table['speed_mps'][i]:.2f} m/s" for i in picks))
    if sel["mass_fixed"]:
        lines.append(f"effective mass NOT IDENTIFIED by the data: held at {sel['mass_kg']:.0f} kg from the boat file")
    elif oe["mass_identified"]:
        lo, hi = sel["mass_ci95_kg"]
        lines.append(f"effective mass {sel['mass_kg']:.0f} kg, 95% CI [{lo:.0f}, {hi:.0f}] (cluster-robust, "
                     f"{sel['clusters']} blocks of {sel['cluster_s']:.3g} s)")
    else:
        lines.append(f"effective mass NOT IDENTIFIED: {oe['mass_note']}")
    if "thrust_scale" in oe:
        lines.append(thrust_scale_line(oe["thrust_scale"]))
    a, b = base["coefficients"]
    lines.append(f"baseline m·du/dt = T - a·u - b·u|u| (output error): a = {a:.4g} N·s/m, b = {b:.4g} N·s²/m², "
                 f"mass {base['mass_kg']:.0f} kg; held-out RMSE {cv['baseline']:.3g} m/s, selected "
                 f"{cv[sel['model']]:.3g} m/s")
    wind: Any = dict(result).get("wind_drag")  # a trials' result (TrialIdentifyResult) only
    if wind is not None:  # a measured wind: a known input, its drag coefficient fitted
        (lo, hi), (blo, bhi) = wind["selected"]["ci95_Ns2pm2"], wind["baseline"]["ci95_Ns2pm2"]
        lines.append(f"measured wind (an anemometer on {wind['trials']} trial(s), a known input): drag coefficient "
                     f"k = {wind['selected']['coefficient_Ns2pm2']:.4g} N·s²/m², 95% CI [{lo:.4g}, {hi:.4g}] "
                     f"(frontal windage {wind['selected']['frontal_windage_area_m2']:.3g} m² with C_a 0.8); "
                     f"baseline {wind['baseline']['coefficient_Ns2pm2']:.4g} [{blo:.4g}, {bhi:.4g}]")
    if result["selected_order"] is not None:
        fit = next(f for f in result["fits"] if f["order"] == result["selected_order"])
        lines.append(f"steady points' polynomial (a view, not the model): N = {fit['order']}, c0..cN N/(m/s)^i: "
                     + ", ".join(f"{c:.4g}" for c in fit["coefficients"]))
    return lines


def antenna_height_m(vessel: VesselParams) -> float:
    """The twin's GNSS antenna height above the waterline, m: the default boat's (1.5 m on its 6 m) carried to
    the boat's length (a 1.2 m boat's antenna is not 1.5 m up)."""
    return GnssConfig.antenna_height_m * vessel.length_m / VesselParams().length_m


def identified_twin(found: TrialsIdentification, model_error: ModelError | None = None) -> TwinConfig | None:
    """The twin ``identify`` writes as twin.yaml (None: no vessel was built): the identified vessel, the GNSS at
    the first trial's origin and an antenna :func:`antenna_height_m` up, ``model_error`` when measured."""
    if found.vessel is None:
        return None
    lat, lon, alt = found.origin or (GnssConfig.origin_lat_deg, GnssConfig.origin_lon_deg, GnssConfig.origin_alt_m)
    gnss = GnssConfig(origin_lat_deg=lat, origin_lon_deg=lon, origin_alt_m=alt,
                      antenna_height_m=antenna_height_m(found.vessel))
    return TwinConfig(vessel=found.vessel, gnss=gnss, model_error=model_error or ModelError())


def write_identify_report(out: Path, result: TrialIdentifyResult, found: TrialsIdentification, sources: str,
                          boat_file: str | None, named: Path | None = None,
                          true_resistance_N: Callable[[np.ndarray], np.ndarray] | None = None,
                          model_error: ModelError | None = None) -> None:
    """The report of :func:`~boat_twin.ident.pipeline.identify_trials` (``result``, the contract of ``found``) on
    the trials read from ``sources`` into ``out``: twin.yaml (when a mass is known; geometry from ``boat_file`` or
    the default boat; the GNSS origin the first trial's), identify.json, model.yaml and the figures of the records
    the fit read (resimulation.png for a single trial; ``true_resistance_N``, speed m/s → N, drawn when known).
    ``named``: the directory the texts name (default ``out``; a report set's final name when ``out`` is its
    staging copy). ``model_error``: the twin's measured model error (twin.yaml's ``model_error`` section)."""
    ensure_out_dir(out)
    twin = identified_twin(found, model_error)
    if twin is not None:
        save_config(twin, out / "twin.yaml",
                    f"boat_twin twin of the boat identified from {sources}\n"
                    f"geometry: {boat_file or 'the default boat carried to the identified mass'}; where each fact "
                    "came from: identify.json 'twin'\n"
                    f"load with: boat-twin simulate ... --config {(named or out) / 'twin.yaml'}")
    write_trial_report(out, result, found.identification.records,
                       found.trials[0].resimulation if len(found.trials) == 1 else None, true_resistance_N,
                       title=f"identify {sources}")
