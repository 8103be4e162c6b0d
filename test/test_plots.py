"""The figures say what they show: tracks to scale unless a straight run would be a line in an empty square, no
curve hidden under another, no empty panel, plain tick labels, the true curve and the unvisited speeds marked."""

from dataclasses import dataclass

import numpy as np
import pytest
from matplotlib.colors import to_rgba

from boat_twin.diagnose.report import evidence_figure
from boat_twin.ident.report import resistance_figure, unvisited_bands
from boat_twin.plots import manoeuvre_figure, trial_figure


@dataclass
class _Trial:
    """What trial_figure reads of a Trial (10 Hz)."""

    t_s: np.ndarray
    east_m: np.ndarray
    north_m: np.ndarray
    speed_mps: np.ndarray
    surge_thrust_N: np.ndarray
    yaw_rate_radps: np.ndarray

    def __len__(self) -> int:
        return self.t_s.size


def _trial(east_m, north_m, yaw_rate_radps) -> _Trial:
    t = np.arange(east_m.size) / 10.0
    return _Trial(t, east_m, north_m, np.full(t.size, 3.0), np.full(t.size, 300.0), yaw_rate_radps)


def test_a_straight_run_is_stretched_and_says_so_a_turn_is_drawn_to_scale() -> None:
    rng = np.random.default_rng(0)
    t = np.arange(6000) / 10.0
    straight = trial_figure(_trial(3.0 * t, rng.normal(0.0, 2.0, t.size), rng.normal(0.0, 1e-3, t.size)), "s")
    track = straight.axes[0]
    assert track.get_aspect() == "auto" and "not to scale" in track.get_title()
    angle = 0.05 * t
    circle = trial_figure(_trial(60.0 * np.sin(angle), 60.0 * (1 - np.cos(angle)), np.full(t.size, 0.05)), "c")
    assert circle.axes[0].get_aspect() == 1.0 and "not to scale" not in circle.axes[0].get_title()


def test_yaw_rate_of_a_straight_run_shows_its_mean_not_a_block_of_noise() -> None:
    rng = np.random.default_rng(1)
    t = np.arange(6000) / 10.0
    fig = trial_figure(_trial(3.0 * t, np.zeros(t.size), rng.normal(0.0, 1e-3, t.size)), "s")
    yaw = fig.axes[2]
    (line,) = [ln for ln in yaw.get_lines() if np.size(ln.get_xdata()) == t.size]  # the zero line has 2 points
    assert np.nanstd(line.get_ydata()) < 0.3e-3  # the 5 s mean: noise cut ~7x
    assert "not drawn" in line.get_label()


def test_unvisited_bands_are_the_wide_gaps_between_steady_speeds() -> None:
    speeds = np.array([0.51, 1.04, 1.54, 2.06, 2.83, 6.16, 6.94, 7.72, 8.23, 9.26])
    assert unvisited_bands(speeds) == [(2.83, 6.16)]
    assert unvisited_bands(np.linspace(1.0, 9.0, 9)) == []


def _result() -> dict:
    """An identify result whose model, steady polynomial and truth are one curve: 100·v + 5·v² N."""
    speeds = np.array([0.5, 1.0, 1.5, 2.0, 6.0, 6.5, 7.0])
    grid = np.linspace(0.0, 7.0, 11)
    table = {"speed_mps": grid.tolist(), "force_N": (100 * grid + 5 * grid**2).tolist(),
             "ci95_low_N": (95 * grid).tolist(), "ci95_high_N": (105 * grid + 6 * grid**2).tolist()}
    selected = {"model": "spline-5", "top_speed_mps": 7.0, "resistance_table": table}
    return {"steady_points": [{"speed_mps": v, "thrust_N": 100 * v + 5 * v * v} for v in speeds],
            "fits": [{"order": 2, "coefficients": [0.0, 100.0, 5.0]}], "selected_order": 2,
            "output_error": {"selected": selected, "baseline": {"coefficients": [100.0, 5.0]}},
            "model": {"resistance": {"model": "table", "speed_mps": table["speed_mps"], "force_N": table["force_N"]}}}


def test_resistance_figure_draws_the_truth_the_band_and_coinciding_curves_visibly() -> None:
    fig = resistance_figure(_result(), lambda v: 100 * v + 5 * v * v)  # type: ignore[arg-type]
    ax = fig.axes[0]
    labels = [ln.get_label() for ln in ax.get_lines()]
    assert "true Fc (the simulated boat)" in labels
    assert any(p.get_label().startswith("no steady point") for p in ax.patches)
    assert any(c.get_label().startswith("95 % interval") for c in ax.collections)
    model = next(ln for ln in ax.get_lines() if ln.get_label().startswith("output error"))
    baseline = next(ln for ln in ax.get_lines() if ln.get_label().startswith("baseline"))
    steady = next(ln for ln in ax.get_lines() if ln.get_label().startswith("steady points' polynomial"))
    # the same curve three times: each in its own colour and dash, so all show
    styles = {(to_rgba(ln.get_color()), ln.get_linestyle()) for ln in (model, baseline, steady)}
    assert len(styles) == 3


def _candidate(effect: str, delta_bic: float, gain: float | None, named: bool = False) -> dict:
    return {"round": 1, "effect": effect, "delta_bic": delta_bic, "heldout_gain": gain, "named": named}


@pytest.mark.parametrize("judged", [False, True])
def test_evidence_figure_has_plain_ticks_and_no_empty_panel(judged: bool) -> None:
    candidates = [_candidate("gyro_bias", -3000.0 if judged else 6.0, 0.4 if judged else None, named=judged),
                  _candidate("mass_error", -5.0, None), _candidate("tow_load", 12.0, None)]
    fig = evidence_figure({"candidates": candidates})
    fig.canvas.draw()
    ax_bic, ax_gain = fig.axes
    ticks = [t.get_text() for t in ax_bic.get_xticklabels() if t.get_text()]
    assert ticks and not any("^" in t or "$" in t for t in ticks), ticks
    assert "linear within ±10, logarithmic beyond" in ax_bic.get_xlabel() and ax_gain.get_xlabel()
    message = [t.get_text() for t in ax_gain.texts]
    assert bool(message) is not judged  # the panel explains itself when no bar can be drawn


def _windows_and_predictions(same: bool):
    from types import SimpleNamespace

    from boat_twin.twin.replay import SIGNALS, Prediction

    t = np.arange(200.0).reshape(100, 2, order="F")  # two windows of 100 samples
    rng = np.random.default_rng(2)
    measured = {s: rng.normal(size=t.shape) for s in SIGNALS}
    baseline = Prediction({s: np.zeros(t.shape) for s in SIGNALS}, np.zeros((*t.shape, 2)))
    extended = baseline if same else Prediction({s: np.full(t.shape, 0.5) for s in SIGNALS}, baseline.position)
    return SimpleNamespace(t_s=t, measured=measured), baseline, extended


@pytest.mark.parametrize("same", [True, False])
def test_diagnosis_figures_never_draw_a_line_hidden_under_another(same: bool) -> None:
    from boat_twin.diagnose.report import residual_figure, signal_figure

    windows, baseline, extended = _windows_and_predictions(same)
    for fig in (signal_figure(windows, baseline, extended, ["vel_east_mps"]),
                residual_figure(windows, baseline, extended)):
        models = [ln for ax in fig.axes for ln in ax.get_lines() if ln.get_linestyle() == "-" and
                  np.size(ln.get_xdata()) > 2]  # model lines (not the measured dots, not the zero line)
        per_axis = len(models) // len(fig.axes)
        assert per_axis == (1 if same else 2)
        if not same:  # the baseline underneath is wider than the extended model on top
            assert models[0].get_linewidth() > models[1].get_linewidth()


@pytest.mark.parametrize("scenario", ["turning-circle", "zigzag-10-10"])
def test_a_simulated_manoeuvre_is_drawn_to_scale_with_its_imo_figures(scenario: str, tmp_path) -> None:
    from boat_twin.cli import main
    from boat_twin.vessel.manoeuvres import execute_time_s, manoeuvre_figures
    from boat_twin.vessel.params import VesselParams
    from boat_twin.vessel.scenarios import make_scenario
    from boat_twin.vessel.simulate import simulate

    params = VesselParams()
    run = make_scenario(scenario, params, np.random.default_rng(0))
    truth = simulate(params, run).truth()
    figures = manoeuvre_figures(run, truth, params.length_m)
    fig = manoeuvre_figure(truth, figures, execute_time_s(run), f"simulate {scenario}")
    fig.canvas.draw()
    track, heading = fig.axes[:2]
    assert track.get_aspect() == 1.0 and fig.get_suptitle() == f"simulate {scenario}"
    labels = " ".join(t.get_text() for ax in (track, heading) for t in ax.get_legend().get_texts())
    if scenario == "turning-circle":
        for text in ("advance", "transfer", "tactical diameter", f"{figures['tactical_diameter_L']:.2f} L"):
            assert text in labels, labels
        turned = heading.get_lines()[0].get_ydata()
        assert turned[-1] > 360.0 and np.all(np.diff(turned) >= -1e-9)  # the angle turned, never wrapped
    else:
        assert f"first overshoot {figures['first_overshoot_deg']:.1f}°" in labels and "IMO ≤" in labels
    png = tmp_path / "run.png"
    assert main(["simulate", scenario, "--no-noise", "--duration", "40", "--plot", str(png)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert main(["simulate", scenario, "--duration", "40", "--plot", str(png)]) == 2  # exists: --force needed
    assert main(["simulate", scenario, "--duration", "40", "--plot", str(tmp_path / "run.pdf")]) == 2


def test_a_saved_figure_carries_its_trial_as_title(tmp_path) -> None:
    from matplotlib.figure import Figure

    from boat_twin.files import atomic_save_figure

    fig = Figure()
    fig.subplots()
    atomic_save_figure(tmp_path / "a.png", fig, "diagnose trial.mcap")
    assert fig.get_suptitle() == "diagnose trial.mcap" and (tmp_path / "a.png").stat().st_size > 0
