"""Figures that show the misfit (issue 43): trial.png does not paint the segments without a steady point as
rejected data (the fit reads them), the diagnosis figures' legends stay clear of their titles, and a heading
residual is not drawn across its ±π wrap."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import to_rgba

from boat_twin.diagnose.report import SIGNALS, residual_figure, signal_figure, window_series
from boat_twin.ident.report import trial_figure


def _windows(k: int = 3, n: int = 50) -> tuple[SimpleNamespace, SimpleNamespace]:
    """Three 5 s windows whose heading residual runs through +π (wrapping to −π) in the second."""
    t = np.arange(k)[None, :] * 6.0 + np.arange(n)[:, None] * 0.1
    measured = {s: np.zeros((n, k)) for s in SIGNALS}
    predicted = {s: np.zeros((n, k)) for s in SIGNALS}
    measured["heading_rad"] = np.linspace(2.6, 3.7, n * k).reshape(k, n).T  # wraps past π in window 2
    return SimpleNamespace(t_s=t, measured=measured), SimpleNamespace(signals=predicted)


def test_a_heading_is_broken_where_it_wraps_not_drawn_across() -> None:
    windows, prediction = _windows()
    residual = np.angle(np.exp(1j * windows.measured["heading_rad"]))  # wrapped as the residual is
    t, v = window_series(windows, residual, angle=True)
    steps = np.abs(np.diff(v))
    assert np.nanmax(steps) < 0.1  # no segment spans the wrap
    assert np.count_nonzero(np.isnan(v)) == 3 + 1  # a break after each window, and one at the wrap
    _, plain = window_series(windows, residual)
    assert np.nanmax(np.abs(np.diff(plain))) > 6.0  # without the break: a line across ±π
    figure = residual_figure(windows, prediction, prediction)
    heading = figure.axes[SIGNALS.index("heading_rad")]
    drawn = heading.get_lines()[0].get_ydata()
    assert np.nanmax(np.abs(np.diff(drawn))) < 0.1


def test_diagnosis_legends_stay_clear_of_the_title() -> None:
    windows, prediction = _windows()
    for figure in (residual_figure(windows, prediction, prediction),
                   signal_figure(windows, prediction, prediction, ["heading_rad", "yaw_rate_radps"])):
        title = figure.suptitle("diagnose a_rather_long_trial_name.csv")
        canvas = FigureCanvasAgg(figure)
        canvas.draw()
        renderer = canvas.get_renderer()
        (legend,) = figure.legends
        box, top = legend.get_window_extent(renderer), title.get_window_extent(renderer)
        assert box.y1 <= top.y0 or box.x1 <= top.x0 or box.x0 >= top.x1  # no overlap
        assert all(box.y1 <= ax.get_window_extent(renderer).y0 + 1 for ax in figure.axes)  # below the plots


def test_trial_figure_does_not_paint_segments_without_a_steady_point_as_rejected() -> None:
    t = np.arange(0.0, 120.0, 0.1)
    record = SimpleNamespace(t_s=t, speed_mps=np.minimum(t, 1.5), thrust_N=np.full(t.size, 40.0), coupling_N=None)
    result = {"output_error": {"selected": {}},
              "steady_points": [{"end_s": 30.0, "duration_s": 20.0}],
              "rejected_segments": [{"start_s": 30.0, "end_s": 120.0, "reason": "held 90 s, shorter than ..."}]}
    figure = trial_figure(result, [record])
    ax = figure.axes[0]
    spans = list(ax.patches)
    red = to_rgba("tab:red")
    assert not any(np.allclose(p.get_facecolor()[:3], red[:3]) for p in spans)
    hatched = [p for p in spans if p.get_hatch()]
    assert len(hatched) == 1 and hatched[0].get_facecolor()[3] == 0.0  # outlined, not filled
    labels = [text.get_text() for text in ax.get_legend().get_texts()]
    assert labels == ["steady point (its settled tail)",
                      "no steady point (too short or not settled: in the fit all the same)"]
    assert "rejected" not in ax.get_title()
