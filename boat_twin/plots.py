"""PNG plots of a trial (matplotlib figures without pyplot: no display needed)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from boat_twin.files import atomic_save_figure
from boat_twin.io.trial import Trial

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
