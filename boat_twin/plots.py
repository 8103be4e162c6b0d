"""PNG plots of a trial (matplotlib, Agg backend: no display needed)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from boat_twin.files import atomic_save_figure  # noqa: E402
from boat_twin.io.trial import Trial  # noqa: E402


def plot_trial(trial: Trial, path: Path, title: str) -> None:
    """Track (ENU), speed over ground with the surge thrust, and IMU yaw rate, in one PNG."""
    fig, (track, speed, yaw) = plt.subplots(1, 3, figsize=(15, 4.5))
    track.plot(trial.east_m, trial.north_m, lw=1)
    track.set(xlabel="east (m)", ylabel="north (m)", title="track (GNSS, local ENU)")
    track.set_aspect("equal", adjustable="datalim")
    speed.plot(trial.t_s, trial.speed_mps, lw=1, label="speed over ground (GNSS)")
    speed.set(xlabel="time (s)", ylabel="speed (m/s)", title="speed and thrust")
    thrust = speed.twinx()
    thrust.plot(trial.t_s, trial.surge_thrust_N, color="tab:red", lw=1, label="surge thrust (commands)")
    thrust.set_ylabel("thrust (N)", color="tab:red")
    yaw.plot(trial.t_s, trial.yaw_rate_radps, lw=1)
    yaw.set(xlabel="time (s)", ylabel="yaw rate (rad/s)", title="yaw rate (UM7 gyro z)")
    fig.suptitle(title)
    fig.tight_layout()
    atomic_save_figure(path, fig)
    plt.close(fig)
