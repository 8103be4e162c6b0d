"""PNG plots of a trial and of a simulated run (matplotlib figures without pyplot: no display needed)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from boat_twin.files import atomic_save_figure
from boat_twin.io.trial import Trial
from boat_twin.vessel.truth import TruthSeries

SMOOTHING_S = 5.0
"""Length of the moving mean drawn over the gyro's yaw rate, s: 50 samples at 10 Hz cut white noise ~7x."""
TRACK_TO_SCALE_MAX_RATIO = 4.0
"""A track is drawn to scale (equal axes) unless one extent exceeds the other this many times; a straight run
is drawn with its cross-track axis stretched instead (and says so), not as a line in an empty square."""


def _moving_mean(values: np.ndarray, samples: int) -> np.ndarray:
    """Centred moving mean over ``samples`` points, NaN-aware (a window with no finite value gives NaN)."""
    finite = np.isfinite(values)
    kernel = np.ones(max(samples, 1))
    total = np.convolve(np.where(finite, values, 0.0), kernel, mode="same")
    count = np.convolve(finite.astype(float), kernel, mode="same")
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / count, np.nan)


def plot_trial(trial: Trial, path: Path, title: str) -> None:
    """:func:`trial_figure` as a PNG at ``path``."""
    atomic_save_figure(path, trial_figure(trial, title))


def trial_figure(trial: Trial, title: str) -> Figure:
    """Track (ENU), speed over ground with the surge thrust, and IMU yaw rate (raw and its moving mean)."""
    fig = Figure(figsize=(15, 4.5), layout="constrained")
    track, speed, yaw = fig.subplots(1, 3)
    period_s = float(np.median(np.diff(trial.t_s))) if len(trial) > 1 else 1.0
    smoothing = round(SMOOTHING_S / period_s)
    track.plot(trial.east_m, trial.north_m, ".", ms=2, color="0.7", label="GNSS fixes")
    track.plot(_moving_mean(trial.east_m, smoothing), _moving_mean(trial.north_m, smoothing), lw=1.2,
               color="tab:blue", label=f"{SMOOTHING_S:g} s moving mean")
    start = np.flatnonzero(np.isfinite(trial.east_m) & np.isfinite(trial.north_m))
    if start.size:
        track.plot(trial.east_m[start[0]], trial.north_m[start[0]], "o", color="tab:green", label="start")
    track.legend(loc="best", fontsize=8)
    spans = [np.nanmax(v) - np.nanmin(v) if np.isfinite(v).any() else 0.0 for v in (trial.east_m, trial.north_m)]
    to_scale = max(spans) <= TRACK_TO_SCALE_MAX_RATIO * max(min(spans), 1.0)
    track.set(xlabel="east, m", ylabel="north, m",
              title="track (GNSS, local ENU)" if to_scale else "track (GNSS, local ENU; axes not to scale)")
    if to_scale:
        track.set_aspect("equal", adjustable="datalim")
    speed.plot(trial.t_s, trial.speed_mps, lw=1, label="speed over ground (GNSS)")
    speed.set(xlabel="time, s", ylabel="speed, m/s", title="speed and thrust")
    thrust = speed.twinx()
    thrust.plot(trial.t_s, trial.surge_thrust_N, color="tab:red", lw=1, label="surge thrust (commands)")
    thrust.set_ylabel("surge thrust (commands), N", color="tab:red")
    mean_yaw = _moving_mean(trial.yaw_rate_radps, smoothing)
    raw_reach = float(np.nanmax(np.abs(trial.yaw_rate_radps))) if np.isfinite(trial.yaw_rate_radps).any() else 0.0
    mean_reach = float(np.nanmax(np.abs(mean_yaw))) if np.isfinite(mean_yaw).any() else 0.0
    if raw_reach <= 3.0 * mean_reach:  # turns: the raw signal shows them
        yaw.plot(trial.t_s, trial.yaw_rate_radps, lw=0.5, color="0.75", label="gyro z (raw)")
        yaw.plot(trial.t_s, mean_yaw, lw=1.2, color="tab:blue", label=f"{SMOOTHING_S:g} s moving mean")
    else:  # a straight run: raw noise would fill the panel and hide the mean, which is drawn alone
        noise = float(np.nanstd(trial.yaw_rate_radps - mean_yaw))
        yaw.plot(trial.t_s, mean_yaw, lw=1.0, color="tab:blue",
                 label=f"{SMOOTHING_S:g} s moving mean (raw noise σ = {noise:.1e} rad/s, not drawn)")
    yaw.axhline(0.0, color="k", lw=0.5)
    yaw.set(xlabel="time, s", ylabel="yaw rate, rad/s", title="yaw rate (UM7 gyro z)")
    yaw.legend(loc="upper right", fontsize=8)
    fig.suptitle(title)
    return fig


def manoeuvre_figure(truth: TruthSeries, figures: dict[str, Any] | None, execute_t_s: float | None,
                     title: str) -> Figure:
    """A simulated run: its x-y track to scale and its heading; for a turning circle or zigzag (``figures``:
    :func:`~boat_twin.vessel.manoeuvres.manoeuvre_figures`, first execute at ``execute_t_s``) with the IMO figures
    marked: advance, transfer and tactical diameter on the track and the heading turned since the execute
    (90° and 180°); the executes, ±ψ and the overshoots on the zigzag's heading deviation."""
    fig = Figure(figsize=(12, 5), layout="constrained")
    track, heading = fig.subplots(1, 2)
    track.plot(truth.east_m, truth.north_m, lw=1.2, color="tab:blue", label="track (centre of gravity)")
    track.plot(truth.east_m[0], truth.north_m[0], "o", color="tab:green", label="start")
    track.set(xlabel="east, m", ylabel="north, m", title="track (local ENU, to scale)")
    track.set_aspect("equal", adjustable="datalim")
    yaw = np.unwrap(truth.yaw_rad)
    if figures is None or execute_t_s is None:
        heading.plot(truth.t_s, np.degrees(yaw), lw=1.2, label="ENU yaw (counter-clockwise from east)")
        heading.set(xlabel="time, s", ylabel="heading (ENU yaw, unwrapped), deg", title="heading")
    else:
        at = {name: float(np.interp(execute_t_s, truth.t_s, values))
              for name, values in (("east", truth.east_m), ("north", truth.north_m), ("yaw", yaw))}
        track.plot(at["east"], at["north"], "s", color="k", label=f"execute (t = {execute_t_s:.1f} s)")
        turned = np.degrees(yaw - at["yaw"])
        if figures["manoeuvre"] == "turning circle":
            _mark_turning(track, heading, truth, turned, at, figures)
        elif figures["manoeuvre"].startswith("zigzag"):
            _mark_zigzag(heading, truth.t_s, turned, figures)
    track.legend(loc="best", fontsize=8)
    heading.legend(loc="upper center", bbox_to_anchor=(0.5, -0.12), ncols=2, fontsize=8)
    fig.suptitle(title)
    return fig


def _mark_turning(track: Any, heading: Any, truth: TruthSeries, turned_deg: np.ndarray, at: dict[str, float],
                  figures: dict[str, Any]) -> None:
    """Advance, transfer (at 90° turned) and tactical diameter (at 180°) on the track; the heading as the angle
    turned since the execute, with 90° and 180° marked."""
    sign = 1.0 if figures["side"] == "port" else -1.0
    psi = np.radians(at["yaw"])
    ahead = np.array([np.cos(psi), np.sin(psi)])
    towards = sign * np.array([-np.sin(psi), np.cos(psi)])
    origin = np.array([at["east"], at["north"]])
    length = figures["length_m"]
    if figures["advance_m"] is not None:
        point = origin + figures["advance_m"] * ahead + figures["transfer_m"] * towards
        foot = origin + figures["advance_m"] * ahead
        track.plot(*np.column_stack([origin, foot]), "--", color="tab:red", lw=1,
                   label=f"advance {figures['advance_m']:.1f} m ({figures['advance_L']:.2f} L; IMO ≤ "
                         f"{figures['advance_limit_L']:g} L)")
        track.plot(*np.column_stack([foot, point]), ":", color="tab:red", lw=1,
                   label=f"transfer {figures['transfer_m']:.1f} m ({figures['transfer_m'] / length:.2f} L)")
    if figures["tactical_diameter_m"] is not None:  # from the original course to the track at 180° turned
        first = np.flatnonzero(sign * turned_deg >= 180.0)[0]
        t180 = float(np.interp(180.0, sign * turned_deg[first - 1:first + 1], truth.t_s[first - 1:first + 1]))
        point = np.array([np.interp(t180, truth.t_s, truth.east_m), np.interp(t180, truth.t_s, truth.north_m)])
        foot = origin + float((point - origin) @ ahead) * ahead
        track.plot(*np.column_stack([foot, point]), "-", marker="|", color="tab:purple", lw=1,
                   label=f"tactical diameter {figures['tactical_diameter_m']:.1f} m "
                         f"({figures['tactical_diameter_L']:.2f} L; IMO ≤ {figures['tactical_diameter_limit_L']:g} L)")
    heading.plot(truth.t_s, sign * turned_deg, lw=1.2, label="heading turned since the execute")
    heading.axhline(90.0, color="tab:red", ls="--", lw=0.8, label="90°: advance and transfer")
    heading.axhline(180.0, color="tab:purple", ls="--", lw=0.8, label="180°: tactical diameter")
    heading.set(xlabel="time, s", ylabel="heading turned, deg", title=f"turning circle to {figures['side']}")


def _mark_zigzag(heading: Any, t_s: np.ndarray, deviation_deg: np.ndarray, figures: dict[str, Any]) -> None:
    """The heading deviation from the original course with ±ψ, the executes and the first two overshoots."""
    switch = float(figures["manoeuvre"].split("/")[1])
    heading.plot(t_s, deviation_deg, lw=1.2, label="heading deviation from the original course")
    for level in (switch, -switch):
        heading.axhline(level, color="0.6", ls="--", lw=0.8)
    for k, t in enumerate(figures["execute_t_s"]):
        heading.axvline(t, color="0.8", lw=0.8, label="executes" if k == 0 else None)
    first, check = figures["first_overshoot_deg"], figures["time_to_check_yaw_s"]
    if first is not None and check is not None:
        t = figures["execute_t_s"][1] + check
        side = float(np.sign(np.interp(t, t_s, deviation_deg)))
        heading.plot(t, side * (switch + first), "v" if side > 0 else "^", color="tab:red",
                     label=_overshoot_label("first", first, figures["first_overshoot_limit_deg"]))
    second = figures["second_overshoot_deg"]
    if second is not None:
        heading.plot([], [], " ", label=_overshoot_label("second", second, figures["second_overshoot_limit_deg"]))
    heading.set(xlabel="time, s", ylabel="heading deviation, deg", title=figures["manoeuvre"])


def _overshoot_label(which: str, value_deg: float, limit_deg: float | None) -> str:
    return f"{which} overshoot {value_deg:.1f}°" + ("" if limit_deg is None else f" (IMO ≤ {limit_deg:.3g}°)")
