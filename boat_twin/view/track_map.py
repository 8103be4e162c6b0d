"""The track map of a report: the measured GNSS track and the model's predicted one in the local ENU frame (x east,
y north, m), on equal axes, start and end marked. ``follow``'s twin predicts each fix from the one before it;
``diagnose``'s replay predicts each 20 s window open loop from its first sample (one predicted segment a window,
placed where the window's measured track is)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from boat_twin.diagnose.pipeline import TrialDiagnosis
from boat_twin.drawn_line import drawn

if TYPE_CHECKING:  # the live twin (and scipy.stats with it): follow's map only
    from boat_twin.shadow.follow import FollowResult

MEASURED_COLOR, PREDICTED_COLOR, BASELINE_COLOR = "tab:blue", "tab:orange", "tab:gray"
def track_figure(measured_m: np.ndarray, predicted_m: list[np.ndarray], title: str, predicted_label: str,
                 baseline_m: list[np.ndarray] | None = None, baseline_label: str = "") -> Figure:
    """``measured_m`` (n, 2) east, north; ``predicted_m`` segments (k, 2) each (``baseline_m`` likewise, dashed)."""
    fig = Figure(figsize=(8, 8))
    draw_track(fig.subplots(), measured_m, predicted_m, predicted_label, baseline_m, baseline_label)
    fig.axes[0].set_title(title)
    fig.tight_layout()
    return fig


def draw_track(ax: Axes, measured_m: np.ndarray, predicted_m: list[np.ndarray], predicted_label: str,
               baseline_m: list[np.ndarray] | None = None, baseline_label: str = "") -> None:
    """The track map on ``ax`` (arguments as :func:`track_figure`'s)."""
    known = measured_m[np.all(np.isfinite(measured_m), axis=1)]
    measured_line = drawn(measured_m)
    ax.plot(measured_line[:, 0], measured_line[:, 1], "-", color=MEASURED_COLOR, lw=1.5, label="measured (GNSS)")
    for segments, color, style, label in ((baseline_m or [], BASELINE_COLOR, "--", baseline_label),
                                          (predicted_m, PREDICTED_COLOR, "-", predicted_label)):
        if segments:  # one line broken between the segments (a line each: 60 artists for 10 minutes of windows)
            joined = drawn(np.concatenate([np.vstack([segment, np.full((1, 2), np.nan)]) for segment in segments]))
            ax.plot(joined[:, 0], joined[:, 1], style, color=color, lw=1.0, label=label)
    if known.size:
        ax.plot(*known[0], "o", color="tab:green", ms=9, label="start")
        ax.plot(*known[-1], "s", color="tab:red", ms=9, label="end")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("east, m (local ENU)")
    ax.set_ylabel("north, m (local ENU)")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize="small")


FOLLOW_PREDICTED = "predicted by the twin (each fix from the one before)"
DIAGNOSIS_PREDICTED, DIAGNOSIS_BASELINE = ("predicted, named effects in (each window open loop)",
                                           "predicted, the model as given")


def follow_track_figure(result: FollowResult, title: str) -> Figure:
    """``follow``: each fix as measured and as the twin predicted it (the position innovations' two sides)."""
    track = result.track
    return track_figure(track[:, 1:3], [track[:, 3:5]], title, FOLLOW_PREDICTED)


def diagnosis_track_figure(done: TrialDiagnosis, title: str) -> Figure:
    """``diagnose``: the measured track and each window's open-loop replay, the model as presented (with the named
    effects) and, dashed, the model before them."""
    measured, extended, baseline = diagnosis_tracks(done)
    return track_figure(measured, extended, title, DIAGNOSIS_PREDICTED, baseline, DIAGNOSIS_BASELINE)


def diagnosis_tracks(done: TrialDiagnosis) -> tuple[np.ndarray, list[np.ndarray], list[np.ndarray]]:
    """The measured track (n, 2) and the windows' predicted segments, named effects in and the model as given."""
    windows = done.windows

    def segments(position: np.ndarray) -> list[np.ndarray]:
        return [position[:, w] for w in range(position.shape[1])]

    measured = windows.position.transpose(1, 0, 2).reshape(-1, 2)
    return measured, segments(done.extended_prediction.position), segments(done.baseline_prediction.position)
