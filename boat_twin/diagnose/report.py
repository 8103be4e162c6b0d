"""The diagnosis of a trial as the ``--json`` contract, a short readable report and PNG plots."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, TypedDict

import numpy as np

from boat_twin.diagnose.search import (
    BIC_THRESHOLD,
    MIN_HELDOUT_GAIN,
    MIN_MISFIT_SHARE,
    TIMING_ALIASES,
    Candidate,
    Fit,
    Selection,
    ci95,
)
from boat_twin.diagnose.structure import MISFIT_FACTOR, Signature, SignatureResult
from boat_twin.diagnose.table import TableDiagnosis
from boat_twin.drawn_line import drawn_series
from boat_twin.twin.replay import SIGNALS, Prediction, Windows, measured_signals, residual

if TYPE_CHECKING:  # matplotlib is imported by the figures only: `diagnose --json` draws none
    from matplotlib.figure import Figure

UNITS = {"vel_east_mps": "m/s", "vel_north_mps": "m/s", "yaw_rate_radps": "rad/s", "heading_rad": "rad",
         "accel_x_mps2": "m/s²", "speed_mps": "m/s", "position_m": "m"}
"""Unit of every reported signal."""
NAMES = {"vel_east_mps": "east velocity (GNSS)", "vel_north_mps": "north velocity (GNSS)",
         "yaw_rate_radps": "yaw rate (gyro)", "heading_rad": "heading (IMU)",
         "accel_x_mps2": "longitudinal acceleration (IMU, window mean removed)"}
"""Axis label of every compared signal (its unit follows, "name, unit")."""


class CandidateResult(TypedDict):
    """One effect tried in one round of the forward selection."""

    effect: str
    parameters: dict[str, float]
    """Fitted parameters, named with their units (EffectSpec.parameter_names)."""
    delta_bic: float
    """BIC of the model with this effect minus BIC without it (negative: better)."""
    round: int
    heldout_gain: float | None
    """1 − held-out SSE with / without; None when it failed the in-sample conditions and was not judged."""
    named: bool
    on_bound: bool
    takes_over: bool
    outranked: bool
    """A better-fitting candidate of its round fails only the size floor (a cause too small to name)."""
    not_judged: list[str]
    """Why it was not judged on held-out time: the in-sample conditions it fails, in words (empty: judged)."""
    claims: list[str]
    """The signals carrying its held-out gain."""
    misfit_share: float | None
    """Share of those signals' misfit above the noise floor that it removes (the share rule)."""
    worsens: list[str]
    """The signals whose held-out misfit it raises by more than MAX_MISFIT_RISE (not named: a stand-in)."""
    beyond_normal: bool
    """The misfit it claims exceeds what the twin normally has (always true without a model error)."""


class VerdictResult(TypedDict):
    """One named effect: final parameters, their 95 % intervals and the held-out gain per signal."""

    effect: str
    parameters: dict[str, float]
    ci95: dict[str, list[float]]
    gain: dict[str, float]


class WithheldResult(TypedDict):
    """A cause the catalogue accepted that leaves real, structured misfit in what it explains: not the verdict
    (:func:`~boat_twin.diagnose.search.withheld`)."""

    effect: str
    parameters: dict[str, float]
    ci95: dict[str, list[float]]
    claims: list[str]
    """The signals carrying its held-out gain."""
    misfit_share: float
    """Share of those signals' misfit above the noise floor it removed when it joined (held out)."""
    misfit_left: dict[str, float]
    """Per claimed signal, the residual RMS over its noise floor after every accepted cause."""
    reason: str


class AmbiguousResult(TypedDict):
    """Causes the trial cannot tell apart: none of them named."""

    effects: list[str]
    parameters: dict[str, dict[str, float]]
    round: int
    reason: str


class _DiagnosisResultBase(TypedDict):
    trial: str
    windows: dict[str, float]
    """count (number of replay windows), length_s, and compared_fraction (the share of the windows' samples within
    their predictability horizons, :func:`~boat_twin.diagnose.initial_state.predictable`: 1 unless the replay
    diverges from any initial state the sensors allow, as on a long straight run astern)."""
    noise: dict[str, float]
    """Measured noise floor per signal (white-noise stdev), SI."""
    baseline: dict[str, dict[str, float]]
    """{"rmse": signal → RMSE} of the model as given."""
    extended: dict[str, dict[str, float]]
    """{"rmse": signal → RMSE} of the model with the named effects."""
    candidates: list[CandidateResult]
    verdict: list[VerdictResult]
    withheld: list[WithheldResult]
    """Causes the catalogue accepted but not presented: structure left in what they explain (empty: none)."""
    ambiguous: AmbiguousResult | None
    unexplained: bool
    """True when structure is left after every cause the catalogue accepted (a signal above the misfit factor
    times its noise, or a residual the situation predicts), withheld ones included."""
    signature: list[SignatureResult]
    """Per unexplained signal: misfit, held-out R², correlated regressors, worst time (Signature.to_dict)."""
    extended_model: str | None
    """Path of the written extended twin config, when one was written."""


class MeasuredWind(TypedDict):
    """The measured true wind of a diagnosis (``diagnose.pipeline.measured_wind_dict``)."""

    east_mps: float
    north_mps: float
    speed_mps: float
    from_deg: float
    """Where the air comes from, clockwise from true north, degrees."""
    delta_bic: float
    """ΔBIC of the twin replayed with it against the twin as configured."""
    named: bool
    """It explains a misfit of the twin without it (ΔBIC below the naming threshold)."""


class DiagnosisResult(_DiagnosisResultBase, total=False):
    """The ``--json`` contract of ``boat-twin diagnose TRIAL`` (SI units), as :func:`result_dict` builds it."""

    evaluations: int
    """Model replays the search ran."""
    measured_wind: MeasuredWind
    """The recording's measured wind, a known input of the replay (only where it has an anemometer)."""
    model_error: dict[str, Any]
    """The twin's model error the misfits were measured with (only where its config holds one: twin.yaml's
    ``model_error`` section, :class:`~boat_twin.model_error.ModelError`)."""
    warnings: list[str]
    """What the diagnosis did not take from the trial as given (commands not to trust, what reading lost:
    :func:`~boat_twin.diagnose.pipeline.diagnose_trial`); empty: nothing."""


def signal_rmse(windows: Windows, prediction: Prediction) -> dict[str, float]:
    """RMS of measured − predicted per signal the trial has (heading wrapped; the longitudinal acceleration less
    each window's mean), speed over ground and horizontal position, SI."""
    out = {}
    for s in measured_signals(windows):
        out[s] = float(np.sqrt(np.nanmean(residual(s, windows.measured[s], prediction.signals[s]) ** 2)))
    measured_speed = np.hypot(windows.measured["vel_east_mps"], windows.measured["vel_north_mps"])
    predicted_speed = np.hypot(prediction.signals["vel_east_mps"], prediction.signals["vel_north_mps"])
    out["speed_mps"] = float(np.sqrt(np.nanmean((measured_speed - predicted_speed) ** 2)))
    miss = np.linalg.norm(windows.position - prediction.position, axis=-1)
    out["position_m"] = float(np.sqrt(np.nanmean(miss**2)))
    return out


def _signal_gain(new: Fit, old: Fit) -> dict[str, float]:
    """Held-out gain per signal: 1 − held-out SSE(new) / held-out SSE(old)."""
    return {s: float(1.0 - new.heldout_sse[i] / old.heldout_sse[i]) for i, s in enumerate(SIGNALS)
            if old.heldout_sse[i] > 0.0}


def _candidate_dict(candidate: Candidate, round_index: int) -> CandidateResult:
    _, values, _ = candidate.fit.split()[-1]
    return {"effect": candidate.effect.name, "parameters": candidate.effect.named(values),
            "delta_bic": candidate.delta_bic, "round": round_index + 1,
            # null: it failed the in-sample conditions, so it was not judged on held-out time
            "heldout_gain": candidate.heldout_gain if np.isfinite(candidate.heldout_gain) else None,
            "named": candidate.named, "on_bound": candidate.at_bound, "takes_over": candidate.takes_over,
            "outranked": candidate.outranked, "not_judged": candidate.failed_conditions,
            # the signals carrying its held-out gain and the share of their excess over the noise it removes
            "claims": list(candidate.claims), "misfit_share": candidate.share if np.isfinite(candidate.share) else None,
            "worsens": list(candidate.worsens), "beyond_normal": candidate.beyond_normal}


def ambiguity(selection: Selection) -> AmbiguousResult | None:
    """The candidates this trial cannot tell apart (none of them named), with why; None when there are none."""
    if not selection.ambiguous:
        return None
    return {"effects": [c.effect.name for c in selection.ambiguous],
            "parameters": {c.effect.name: c.effect.named(c.fit.split()[-1][1]) for c in selection.ambiguous},
            "round": len(selection.rounds),
            "reason": AMBIGUITY_REASONS[selection.ambiguity or ("timing" if selection.ambiguous[0].effect.name
                                                                 in TIMING_ALIASES else "wind")]}


AMBIGUITY_REASONS = {
    "wind": "the trial holds one heading: a wind is a constant force in the body frame there, as the other cause "
            "is; a trial that turns through many headings tells them apart",
    "held_out": "the held-out windows do not prefer one (held-out gains within 1 % of each other, or the other "
                "higher): over many headings a wind drifts the boat much as a current sets it, or as the other "
                "cause's force does",
    "timing": "both move the measured response later by about as much (no evidence against either: ΔBIC within "
              "10): a command delay moves every response, a GNSS latency only the GNSS's, an engine lag only the "
              "thrust's; a trial that steers as well as steps the thrust tells them apart",
}
"""Why a trial's candidates were reported as ``ambiguous``, by the rule that found them (:mod:`search`)."""


def _final_values(selection: Selection, candidate: Candidate) -> tuple[dict[str, float], dict[str, list[float]]]:
    """A named candidate's parameters in the final model and their 95 % intervals, named with their units."""
    values, stderr = next((v, s) for e, v, s in selection.final.split() if e.name == candidate.effect.name)
    lo, hi = ci95(values, stderr)
    return candidate.effect.named(values), {
        n: [float(a), float(b)] for n, a, b in zip(candidate.effect.parameter_names, lo, hi, strict=True)}


def verdict(selection: Selection, withheld: list[Candidate] | None = None) -> list[VerdictResult]:
    """The named effects not ``withheld`` with their final parameters, 95 % intervals and held-out gain per
    signal."""
    out: list[VerdictResult] = []
    previous = selection.baseline
    held_back = {id(c) for c in withheld or []}
    for candidate in selection.named:
        if id(candidate) not in held_back:
            parameters, interval = _final_values(selection, candidate)
            out.append({"effect": candidate.effect.name, "parameters": parameters, "ci95": interval,
                        "gain": _signal_gain(candidate.fit, previous)})
        previous = candidate.fit
    return out


def withheld_dicts(selection: Selection, withheld: list[Candidate],
                   signatures: list[Signature]) -> list[WithheldResult]:
    """The ``withheld`` causes with their parameters, what they explain and the misfit they leave there."""
    left = {s.signal: s for s in signatures}
    out: list[WithheldResult] = []
    for candidate in withheld:
        parameters, interval = _final_values(selection, candidate)
        misfit_left = {s: left[s].misfit for s in candidate.claims if s in left}
        worst = max(misfit_left, key=lambda s: misfit_left[s], default="")
        out.append({"effect": candidate.effect.name, "parameters": parameters, "ci95": interval,
                    "claims": list(candidate.claims), "misfit_share": float(candidate.share),
                    "misfit_left": misfit_left, "reason": _withheld_reason(candidate, left, worst)})
    return out


def _withheld_reason(candidate: Candidate, left: dict[str, Signature], worst: str) -> str:
    """Why ``candidate`` is withheld: what it leaves in ``worst``, the claimed signal the structure test flags
    with the largest misfit (``left``: the final model's signatures), or the live twin's evidence ('' : none)."""
    if not worst:
        return ("structure is left while the model misfits (the live twin's innovations): a part of something "
                "outside the catalogue")
    signature = left[worst]
    what = (f"{signature.misfit:.1f}x its noise, with structure (above {MISFIT_FACTOR:g}x)"
            if signature.misfit > MISFIT_FACTOR else
            f"structured (held-out R² {signature.heldout_r2:.2f} on the boat's situation, beyond what the twin "
            "normally leaves)")
    return (f"it removes {candidate.share:.0%} of its signals' misfit (the rule asks {MIN_MISFIT_SHARE:.0%}) but "
            f"leaves {worst} {what}: it explains a part of something outside the catalogue")


def result_dict(windows: Windows, selection: Selection, baseline: Prediction, extended: Prediction,
                signatures: list[Signature], extended_model: str | None, sigma: dict[str, float],
                withheld: list[Candidate] | None = None) -> DiagnosisResult:
    """The ``--json`` contract (SI units); ``withheld``: named candidates not presented as the verdict
    (:func:`~boat_twin.diagnose.search.withheld`), ``extended`` the prediction of the model without them."""
    candidates = [_candidate_dict(c, i) for i, r in enumerate(selection.rounds) for c in r]
    return {
        "trial": windows.trial.metadata.source,
        "windows": {"count": int(windows.t_s.shape[1]), "length_s": float(windows.t_s.shape[0] * windows.dt_s)},
        "noise": {s: sigma[s] for s in measured_signals(windows)},
        "baseline": {"rmse": signal_rmse(windows, baseline)},
        "extended": {"rmse": signal_rmse(windows, extended)},
        "candidates": candidates,
        "verdict": verdict(selection, withheld),
        "withheld": withheld_dicts(selection, withheld or [], signatures),
        "ambiguous": ambiguity(selection),
        "unexplained": bool(signatures),
        "signature": [s.to_dict() for s in signatures],
        "extended_model": extended_model,
    }


def text_report(result: DiagnosisResult) -> str:
    """What was wrong, where, the cause, its size ± uncertainty, the gain per signal."""
    lines = [f"trial       {result['trial']}: {result['windows']['count']} windows of "
             f"{result['windows']['length_s']:g} s replayed from the sensors"]
    compared = result["windows"].get("compared_fraction", 1.0)
    if compared < 1.0:
        lines.append(f"horizon     {100 * compared:.0f} % of the windows' time compared: past each window's "
                     "predictability horizon the replay diverges from any initial state the sensors allow")
    base, ext = result["baseline"]["rmse"], result["extended"]["rmse"]
    lines.append("signal            baseline RMSE   extended RMSE")
    for s in [s for s in ("speed_mps", *SIGNALS, "position_m") if s in base]:
        lines.append(f"  {s:16s} {base[s]:10.4f}      {ext[s]:10.4f}  {UNITS[s]}")
    wind = result.get("measured_wind")
    if wind is not None:
        lines.append(f"measured    wind {wind['speed_mps']:.3g} m/s from {wind['from_deg']:.0f}° (the recording's "
                     "anemometer, mean): a known input of the replay, window by window; "
                     + (f"named: it explains a misfit of the twin without it (ΔBIC {wind['delta_bic']:.1f})"
                        if wind["named"] else f"the twin without it fits as well (ΔBIC {wind['delta_bic']:+.1f})"))
    if not result["verdict"] and result["unexplained"]:
        lines.append("verdict     UNEXPLAINED: the model is off the data and no catalogue effect explains it "
                     "(see the unexplained lines below" + (", and the partial causes withheld)"
                                                           if result.get("withheld") else ")"))
    elif not result["verdict"] and compared < 1.0:
        lines.append("verdict     no significant discrepancy a catalogue effect explains, in the "
                     f"{100 * compared:.0f} % of the time the replay can predict: the rest is not judged "
                     "(not an all-clear)")
    elif not result["verdict"]:
        lines.append("verdict     no significant discrepancy a catalogue effect explains")
    elif result["unexplained"]:
        lines.append("verdict     PARTLY UNEXPLAINED: the effects below leave structure no catalogue effect explains")
    for v in result["verdict"]:
        parts = [f"{k} = {val:.4g} [{v['ci95'][k][0]:.4g}, {v['ci95'][k][1]:.4g}]" for k, val in
                 v["parameters"].items()]
        gains = ", ".join(f"{s} {g:+.0%}" for s, g in v["gain"].items() if abs(g) >= 0.005)
        lines.append(f"verdict     {v['effect']}: " + "; ".join(parts))
        lines.append(f"            held-out gain: {gains}")
    for w in result.get("withheld", []):
        parts = [f"{k} = {val:.4g} [{w['ci95'][k][0]:.4g}, {w['ci95'][k][1]:.4g}]" for k, val in
                 w["parameters"].items()]
        lines.append(f"withheld    {w['effect']} (not the verdict): " + "; ".join(parts))
        lines.append(f"            {w['reason']}")
    if result["ambiguous"]:
        amb = result["ambiguous"]
        lines.append(f"ambiguous   {' or '.join(amb['effects'])} (round {amb['round']}, neither named): "
                     f"{amb['reason']}")
    first = [c for c in result["candidates"] if c["round"] == 1]
    lines.append("candidates (round 1)  ΔBIC      held-out gain")
    for c in sorted(first, key=lambda c: c["delta_bic"]):
        why = "; ".join(c["not_judged"])
        gain = f"{c['heldout_gain']:+8.1%}" if c["heldout_gain"] is not None else (
            f"not judged: {why}" if why else "not judged")
        if c["worsens"]:
            gain += f" (worsens {', '.join(c['worsens'])})"
        if not c["beyond_normal"]:
            gain += " (the twin's normal misfit)"
        lines.append(f"  {c['effect']:18s} {c['delta_bic']:10.1f}  {gain}")
    if result["unexplained"]:
        for sig in result["signature"]:
            lines.append(f"unexplained {sig['signal']}: residual {sig['misfit']:.1f}x its noise floor, held-out R² "
                         f"{sig['heldout_r2']:.2f}, correlated with "
                         f"{', '.join(sig['correlated_with'])}; worst around t = {sig['worst_time_s']:.0f} s")
    if result["extended_model"]:
        lines.append(f"model       {result['extended_model']}")
    return "\n".join(lines)


def window_series(windows: Windows, values: np.ndarray, angle: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Windows joined along trial time, NaN between them so lines break; an ``angle`` (rad) also breaks where it
    jumps by more than π (wrapped across ±π: not a change of the signal, and no line is drawn across it). Drawn
    with a bounded subset that keeps every break on hours of windows (:func:`boat_twin.drawn_line.drawn`)."""
    t = np.vstack([windows.t_s, np.full((1, windows.t_s.shape[1]), np.nan)]).T.ravel()
    v = np.vstack([values, np.full((1, values.shape[1]), np.nan)]).T.ravel()
    if angle:
        with np.errstate(invalid="ignore"):
            wraps = np.flatnonzero(np.abs(np.diff(v)) > np.pi) + 1
        t, v = np.insert(t, wraps, np.nan), np.insert(v, wraps, np.nan)
    t, v = drawn_series(t, v)
    return t, v


def _same_prediction(baseline: Prediction, extended: Prediction, signals: list[str] | tuple[str, ...]) -> bool:
    """No effect named: the extended model is the baseline (one line is drawn, not two on top of each other)."""
    return all(np.array_equal(baseline.signals[s], extended.signals[s], equal_nan=True) for s in signals)


def signal_figure(windows: Windows, baseline: Prediction, extended: Prediction, signals: list[str]) -> Figure:
    """Measured vs baseline vs extended prediction for each signal concerned (the baseline drawn wide and light
    under the extended model, so that both show where they agree)."""
    from matplotlib.figure import Figure

    same = _same_prediction(baseline, extended, signals)
    fig = Figure(figsize=(10, 2.6 * len(signals)), layout="constrained")
    for ax, s in zip(fig.subplots(len(signals), 1, squeeze=False, sharex=True)[:, 0], signals, strict=True):
        angle = UNITS[s] == "rad"
        ax.plot(*window_series(windows, windows.measured[s]), ".", ms=1.5, color="0.6", label="measured")
        if same:
            ax.plot(*window_series(windows, baseline.signals[s], angle), lw=1.2, color="C0",
                    label="model (no effect named: extended = baseline)")
        else:
            ax.plot(*window_series(windows, baseline.signals[s], angle), lw=3.0, color="C0", alpha=0.45,
                    label="baseline model")
            ax.plot(*window_series(windows, extended.signals[s], angle), lw=1.0, color="C3", label="extended model")
        ax.set_ylabel(f"{NAMES[s]}, {UNITS[s]}")
    ax.set_xlabel("trial time, s")
    # below the plots: above them it would cover the figure's title (the trial, set when saved)
    fig.legend(*ax.get_legend_handles_labels(), loc="outside lower center", ncols=3, fontsize=8, markerscale=4)
    return fig


def residual_figure(windows: Windows, baseline: Prediction, extended: Prediction) -> Figure:
    """Residuals (measured − predicted) of every signal before and after the extension."""
    from matplotlib.figure import Figure

    signals = measured_signals(windows)
    same = _same_prediction(baseline, extended, signals)
    fig = Figure(figsize=(10, 2.25 * len(signals)), layout="constrained")
    for ax, s in zip(fig.subplots(len(signals), 1, sharex=True)[:], signals, strict=True):
        angle = UNITS[s] == "rad"  # a heading residual, wrapped to ±π: broken where it wraps
        if same:
            ax.plot(*window_series(windows, residual(s, windows.measured[s], baseline.signals[s]), angle), lw=0.6,
                    color="C0", label="model (no effect named: extended = baseline)")
        else:
            ax.plot(*window_series(windows, residual(s, windows.measured[s], baseline.signals[s]), angle), lw=1.6,
                    color="C0", alpha=0.45, label="baseline")
            ax.plot(*window_series(windows, residual(s, windows.measured[s], extended.signals[s]), angle), lw=0.6,
                    color="C3", label="extended")
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_ylabel(f"{NAMES[s]}\nresidual, {UNITS[s]}", fontsize=8)
    ax.set_xlabel("trial time, s")
    fig.legend(*ax.get_legend_handles_labels(), loc="outside lower center", ncols=2, fontsize=8)
    return fig


def evidence_figure(result: DiagnosisResult) -> Figure:
    """ΔBIC and held-out gain of every candidate in round 1, with the decision thresholds."""
    from matplotlib.figure import Figure

    first = sorted([c for c in result["candidates"] if c["round"] == 1], key=lambda c: c["delta_bic"])
    names = [c["effect"] for c in first]
    from matplotlib.ticker import FuncFormatter

    fig = Figure(figsize=(10, 1.2 + 0.4 * max(len(first), 2)), layout="constrained")
    ax_bic, ax_gain = fig.subplots(1, 2, sharey=True)
    colors = ["C3" if c["named"] else "C0" for c in first]
    ax_bic.barh(names, [c["delta_bic"] for c in first], color=colors)
    ax_bic.axvline(BIC_THRESHOLD, color="k", ls="--", lw=0.8)
    ax_bic.set_xscale("symlog", linthresh=10.0)  # linear within ±10 (the threshold), logarithmic beyond
    ax_bic.xaxis.set_major_formatter(FuncFormatter(lambda x, _: f"{x:g}"))
    ax_bic.set_title(f"ΔBIC against the baseline: lower is better\n(dashed: {BIC_THRESHOLD:g}, needed to name; "
                     "red: named)", fontsize=9)
    ax_bic.set_xlabel("ΔBIC (symmetric log: linear within ±10, logarithmic beyond)", fontsize=8)
    gains = [np.nan if c["heldout_gain"] is None else 100 * c["heldout_gain"] for c in first]
    ax_gain.barh(names, gains, color=colors)
    ax_gain.axvline(100 * MIN_HELDOUT_GAIN, color="k", ls="--", lw=0.8)
    ax_gain.axvline(0.0, color="k", lw=0.5)
    ax_gain.set_title(f"held-out gain, %: higher is better\n(dashed: {100 * MIN_HELDOUT_GAIN:g} %, needed to "
                      "name; no bar: not judged)", fontsize=9)
    if all(np.isnan(gains)):
        ax_gain.set_xlim(-10.0, 10.0)
        ax_gain.text(0.5, 0.5, "no candidate judged on held-out data:\nnone passed the in-sample conditions\n"
                     "(ΔBIC below the threshold and a plausible size)", transform=ax_gain.transAxes, ha="center",
                     va="center", fontsize=9, bbox={"facecolor": "white", "edgecolor": "0.7"})
    ax_gain.set_xlabel("held-out gain, %", fontsize=8)
    ax_gain.tick_params(labelleft=False)
    return fig


def concerned_signals(result: DiagnosisResult) -> list[str]:
    """Signals the named effects improved by ≥ 5 % (all when none did)."""
    gains = [v["gain"] for v in result["verdict"]]
    concerned = [s for s in SIGNALS if any(g.get(s, 0.0) >= 0.05 for g in gains)]
    return concerned or [s for s in SIGNALS if s in result["noise"]]


def table_text(result: dict[str, Any], diag: TableDiagnosis) -> str:
    """The text report of a table diagnosis."""
    base = result["baseline"]["rmse"]["thrust_kgf"]
    ext = result["extended"]["rmse"]["thrust_kgf"]
    lines = [f"table       Dyda & Chumakova (2021) Table 1, 37 rows (kn, kgf); baseline: the paper's N = "
             f"{result['baseline']['model_order']} fit",
             f"RMSE        baseline {base:.2f} kgf, extended {ext:.2f} kgf",
             f"candidate   resistance_shape: {diag.knots.size} knots, ΔBIC {diag.delta_bic:.1f}, "
             f"leave-one-out gain {diag.cv_gain:+.1%}"]
    if result["verdict"]:
        params = result["verdict"][0]["parameters"]
        lines.append(f"verdict     resistance_shape; regime change (plateau between displacement and planing): "
                     f"{params.get('plateau_kn', ['?', '?'])[0]}–{params.get('plateau_kn', ['?', '?'])[1]} kn; "
                     f"model differs significantly over {params.get('band_kn')} kn")
    else:
        lines.append("verdict     no significant discrepancy")
    lines.append(f"residuals   runs test p = {result['residual_runs_p']:.2f}"
                 + (" (structure left: unexplained)" if result["unexplained"] else " (no structure left)"))
    if result["extended_model"]:
        lines.append(f"model       {result['extended_model']}")
    return "\n".join(lines)


def table_figure(diag: TableDiagnosis) -> Figure:
    """Table 1 with the paper's fit and the extended one; residuals of both."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8, 6), layout="constrained")
    ax, ax_r = fig.subplots(2, 1, sharex=True, height_ratios=(2, 1))
    ax.plot(diag.speed, diag.force, "o", ms=4, label="Table 1")
    ax.plot(diag.speed, diag.baseline, label="paper's fit")
    ax.plot(diag.speed, diag.extended, label="extended (resistance_shape)")
    if diag.plateau:
        ax.axvspan(*diag.plateau, color="0.9", label="plateau (regime change)")
    ax.set_ylabel("thrust, kgf")
    ax.legend()
    ax_r.plot(diag.speed, diag.force - diag.baseline, "o-", ms=3, label="baseline")
    ax_r.plot(diag.speed, diag.force - diag.extended, "o-", ms=3, label="extended")
    ax_r.axhline(0.0, color="k", lw=0.5)
    ax_r.set_xlabel("speed, kn")
    ax_r.set_ylabel("residual, kgf")
    ax_r.legend()
    return fig
