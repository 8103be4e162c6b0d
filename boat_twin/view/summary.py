"""One page per trial: the report's answer at a glance — the track map (measured against predicted), the signals
that carry the verdict over time, and the verdict, the model and the warnings in words. ``diagnose --out`` writes
diagnosis_summary.png, ``follow --out`` follow_summary.png; the other figures hold the detail."""

from __future__ import annotations

import textwrap
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from boat_twin.diagnose.pipeline import TrialDiagnosis
from boat_twin.diagnose.report import text_report, window_series
from boat_twin.view.track_map import (
    DIAGNOSIS_BASELINE,
    DIAGNOSIS_PREDICTED,
    FOLLOW_PREDICTED,
    diagnosis_tracks,
    draw_track,
)

if TYPE_CHECKING:  # the live twin (and scipy.stats with it): follow's page only, imported by it
    from boat_twin.shadow.follow import FollowResult

PAGE_IN = (11.69, 8.27)
"""A4 landscape, inches."""
TEXT_COLUMNS = 150
"""Characters a line of the page's text holds before it wraps."""
MAX_WARNINGS = 6
"""Warnings shown on the page; the rest are counted (all are in the report's JSON)."""
DIAGNOSIS_LINES = ("verdict", "unexplained", "ambiguous", "withheld", "measured", "horizon", " " * 12)
"""The lines of :func:`~boat_twin.diagnose.report.text_report` the page repeats (a continuation line starts with
12 blanks); the candidates' table stays in the text report and diagnosis_evidence.png."""
RATIO_KEYS = {"speed_innovation_ratio": "speed", "yaw_rate_innovation_ratio": "yaw rate"}
"""The follow timeline's innovation ratios the page draws → their names."""
MISFIT_RATIO = 1.5
"""An innovation ratio above this: the twin misfits the signal (the live twin's rule, docs/live-twin.md)."""


def diagnosis_summary_figure(done: TrialDiagnosis, title: str) -> Figure:
    """``diagnose``: the track with each window's replay, speed over ground and yaw rate measured against the
    model as given and with the named effects, and the verdict."""
    fig, track_ax, (speed_ax, rate_ax), text_ax = _page(title)
    measured, extended, baseline = diagnosis_tracks(done)
    draw_track(track_ax, measured, extended, DIAGNOSIS_PREDICTED, baseline, DIAGNOSIS_BASELINE)
    windows, before, after = done.windows, done.baseline_prediction, done.extended_prediction
    series = {"speed": lambda s: np.hypot(s["vel_east_mps"], s["vel_north_mps"]),
              "rate": lambda s: np.degrees(s["yaw_rate_radps"])}
    for ax, key, label in ((speed_ax, "speed", "speed over ground, m/s"), (rate_ax, "rate", "yaw rate, deg/s")):
        ax.plot(*window_series(windows, series[key](windows.measured)), ".", ms=1.5, color="0.6", label="measured")
        ax.plot(*window_series(windows, series[key](before.signals)), lw=2.5, color="C0", alpha=0.45,
                label="model as given")
        ax.plot(*window_series(windows, series[key](after.signals)), lw=0.9, color="C3", label="named effects in")
        ax.set_ylabel(label, fontsize=8)
    speed_ax.legend(loc="upper right", fontsize="x-small", markerscale=4)
    rate_ax.set_xlabel("trial time, s")
    result = done.result
    base, ext = result["baseline"]["rmse"], result["extended"]["rmse"]
    lines = [line for line in text_report(result).splitlines() if line.startswith(DIAGNOSIS_LINES)]
    if not lines:
        lines = ["verdict     no significant discrepancy a catalogue effect explains"]
    lines.append("RMSE        " + ", ".join(f"{s} {base[s]:.3g} → {ext[s]:.3g}" for s in ("speed_mps", "position_m")
                                            if s in base and s in ext) + " (model as given → named effects in)")
    _write(text_ax, lines, result.get("warnings", []))
    return fig


def follow_summary_figure(done: FollowResult, title: str) -> Figure:
    """``follow``: the track as measured and as the twin predicted each fix, the speed innovations in their ±2σ
    band, every signal's innovation ratio per minute with the causes held, and the final model."""
    fig, track_ax, (innovation_ax, ratio_ax), text_ax = _page(title)
    track = done.track
    draw_track(track_ax, track[:, 1:3], [track[:, 3:5]], FOLLOW_PREDICTED)
    speed = done.innovations.get("speed_mps", done.speed_innovations)
    if speed.size:
        t, value, stdev = speed.T
        innovation_ax.plot(t, value, ".", ms=1, color="tab:blue", label="speed innovation")
        innovation_ax.fill_between(t, -2 * stdev, 2 * stdev, color="tab:gray", alpha=0.3, label="±2σ stated")
        innovation_ax.legend(loc="upper right", fontsize="x-small")
    innovation_ax.set_ylabel("speed innovation, m/s", fontsize=8)
    entries = done.timeline
    times = [e["t_s"] for e in entries]
    for i, (key, name) in enumerate(RATIO_KEYS.items()):
        ratios = [np.nan if e.get(key) is None else e[key] for e in entries]
        ratio_ax.plot(times, ratios, "o-", ms=3, color=f"C{i + 3}", label=name)
    ratio_ax.axhline(MISFIT_RATIO, color="k", ls="--", lw=1, label=f"{MISFIT_RATIO:g}× (misfit above)")
    held = [e["t_s"] for e in entries if e["causes"] or e["unexplained"]]
    if held:
        ratio_ax.plot(held, [0.05] * len(held), "v", color="tab:red", ms=5, label="a cause held")
    ratio_ax.set_ylim(0.0, max(ratio_ax.get_ylim()[1], 1.2 * MISFIT_RATIO))
    ratio_ax.set_ylabel("innovation ratio, -", fontsize=8)
    ratio_ax.set_xlabel("trial time, s")
    ratio_ax.legend(loc="upper right", fontsize="x-small", ncols=2)
    _write(text_ax, _follow_lines(done), done.warnings)
    return fig


def _follow_lines(done: FollowResult) -> list[str]:
    """The follow's answer in words: the final model with its intervals and what the rolling diagnosis held."""
    from boat_twin.shadow.follow import final_model_text

    final = done.final
    lines = [final_model_text(final)] if "model" in final else []
    held = [e for e in done.timeline if e["causes"] or e["unexplained"]]
    causes = sorted({c for e in held for c in e["causes"]})
    lines.append(f"timeline    {len(done.timeline)} entries; a cause held in {len(held)}: "
                 + (", ".join(causes) or "none")
                 + ("; (unexplained) in " + str(sum(bool(e['unexplained']) for e in held)) if held else ""))
    end_causes = final.get("causes", [])
    lines.append("at the end  " + (", ".join(end_causes) if end_causes else "no cause held")
                 + (" (unexplained: structure no catalogue cause explains)" if final.get("unexplained") else ""))
    return lines


def _page(title: str) -> tuple[Figure, Axes, tuple[Axes, Axes], Axes]:
    """The page's grid: the track map left, two time plots right, the text across the bottom."""
    fig = Figure(figsize=PAGE_IN, layout="constrained")
    fig.suptitle(title, fontsize=11)
    grid = fig.add_gridspec(3, 2, height_ratios=(1.0, 1.0, 0.55), width_ratios=(1.0, 1.25))
    track_ax = fig.add_subplot(grid[0:2, 0])
    upper = fig.add_subplot(grid[0, 1])
    lower = fig.add_subplot(grid[1, 1], sharex=upper)
    text_ax = fig.add_subplot(grid[2, :])
    text_ax.axis("off")
    return fig, track_ax, (upper, lower), text_ax


def _write(ax: Axes, lines: list[str], warnings: list[str]) -> None:
    """The verdict's lines, then the warnings (the first :data:`MAX_WARNINGS`, the rest counted)."""
    shown = [f"warning     {w}" for w in warnings[:MAX_WARNINGS]]
    if len(warnings) > MAX_WARNINGS:
        shown.append(f"warning     ... and {len(warnings) - MAX_WARNINGS} more (the report's JSON 'warnings')")
    if not warnings:
        shown.append("warnings    none")
    wrapped = [part for line in lines + shown
               for part in textwrap.wrap(line, TEXT_COLUMNS, subsequent_indent=" " * 12) or [""]]
    ax.text(0.0, 1.0, "\n".join(wrapped), transform=ax.transAxes, va="top", ha="left", family="monospace",
            fontsize=7.5)
