"""Reports say what was assumed or lost, and show the track (issue 39): a recording missing 33 s of every topic
(as a damaged MCAP chunk loses them) and its IMU altogether is followed, diagnosed and identified; each report's
``warnings`` names the missing signal and the span, the ``--each`` rows count them, a run without boat facts says
what it assumed; the track map draws the measured fixes against the twin's predictions on equal axes."""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pytest

from boat_twin.config import TwinConfig
from boat_twin.diagnose.hidden import scenario
from boat_twin.io import messages
from boat_twin.io.bags import read_trial, write_bag
from boat_twin.twin.sea_trial import run_sea_trial, trial_messages

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from boat_twin.io.trial import Trial
    from boat_twin.shadow.follow import FollowResult

LOST_S = (100.0, 133.0)
"""The span every topic loses, s of trial time."""
BOAT_TWIN = Path(sys.executable).with_name("boat-twin")


def _recording(path: Path, imu: bool) -> Path:
    """240 s of random commands without ``LOST_S`` (and without its IMU unless ``imu``)."""
    base = TwinConfig()
    run = run_sea_trial(base, scenario("random", base.vessel, np.random.default_rng(5), 240.0), 5)
    kept = (m for m in trial_messages(run, truth=False)
            if not LOST_S[0] * 1e9 <= m[1] < LOST_S[1] * 1e9 and (imu or m[0] != messages.TOPIC_IMU_DATA))
    write_bag(path, kept)
    return path


@pytest.fixture(scope="module")
def damaged(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _recording(tmp_path_factory.mktemp("damaged") / "damaged.mcap", imu=False)


def test_the_reader_says_which_signal_is_missing_and_which_span_it_lost(damaged: Path) -> None:
    lines = read_trial(damaged).metadata.warnings()
    assert any("imu: not in the trial (signal missing)" in line for line in lines), lines
    spans = [line for line in lines if "gnss_vel: 1 span(s) without samples" in line]
    assert len(spans) == 1, lines
    assert "the longest 33." in spans[0] and "t = 99." in spans[0], spans  # the fix before it to the one after


def test_a_whole_recording_reads_without_warnings() -> None:
    assert read_trial(Path(__file__).resolve().parents[1] / "bags" / "thrust_steps_sample").metadata.warnings() == []


def test_follow_and_its_each_row_report_the_loss_and_the_assumed_boat(damaged: Path, tmp_path: Path) -> None:
    done = subprocess.run([str(BOAT_TWIN), "follow", str(damaged), "--json"], capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stderr
    warnings = json.loads(done.stdout)["warnings"]
    assert any("imu: not in the trial" in w for w in warnings), warnings
    assert any("gnss_fix: 1 span(s) without samples" in w for w in warnings), warnings
    assert any(w.startswith("no --config or --model: the built-in boat") for w in warnings), warnings
    from boat_twin.cli.options import assumed_config
    from boat_twin.fleet.jobs import FollowJob

    assumed = tuple(assumed_config(argparse.Namespace(config=None, model=None)))
    row = FollowJob(assumed=assumed)(damaged, tmp_path / "each")  # as follow --each without --config runs it
    written = json.loads((tmp_path / "each" / "follow.json").read_text())["warnings"]
    assert row["warnings"] == len(written) >= 4 and written == warnings  # the row as the single run
    assert (tmp_path / "each" / "follow_track.png").stat().st_size > 10_000


def test_identify_reports_the_loss_and_that_no_boat_facts_were_given(damaged: Path) -> None:
    from boat_twin.ident.pipeline import ASSUMED_BOAT, identify_trials

    result, _ = identify_trials([read_trial(damaged)])
    assert ASSUMED_BOAT in result["warnings"]
    assert any("gnss_vel: 1 span(s) without samples" in w for w in result["warnings"]), result["warnings"]
    with_boat, _ = identify_trials([read_trial(damaged)], boat={"mass_kg": 1300.0})
    assert ASSUMED_BOAT not in with_boat["warnings"]


def test_diagnose_and_its_each_row_report_the_loss(tmp_path: Path) -> None:
    from boat_twin.diagnose.pipeline import diagnose_trial
    from boat_twin.fleet.jobs import DiagnoseJob

    gapped = _recording(tmp_path / "gapped.mcap", imu=True)  # the diagnosis needs the IMU
    done = diagnose_trial(read_trial(gapped), TwinConfig())
    warnings = done.result["warnings"]
    assert any("gnss_fix: 1 span(s) without samples" in w for w in warnings), warnings
    assert any("imu: 1 span(s) without samples" in w for w in warnings), warnings
    row = DiagnoseJob(assumed=("assumed: the test's boat",))(gapped, tmp_path / "each")
    assert row["warnings"] == len(warnings) + 1 >= 4
    assert json.loads((tmp_path / "each" / "diagnosis.json").read_text())["warnings"][-1] == "assumed: the test's boat"
    assert (tmp_path / "each" / "diagnosis_track.png").stat().st_size > 10_000
    assert (tmp_path / "each" / "diagnosis_summary.png").stat().st_size > 10_000
    from boat_twin.diagnose.report import text_report
    from boat_twin.view.summary import diagnosis_summary_figure

    fig = diagnosis_summary_figure(done, "summary")
    track_ax, speed_ax = fig.axes[0], fig.axes[1]
    assert track_ax.get_aspect() == 1.0
    measured = {line.get_label(): line for line in speed_ax.get_lines()}["measured"].get_xydata()
    shown = measured[np.isfinite(measured[:, 1])]
    windows = done.windows
    speed = np.hypot(windows.measured["vel_east_mps"], windows.measured["vel_north_mps"])
    np.testing.assert_allclose(np.sort(shown[:, 1]), np.sort(speed[np.isfinite(speed)]))
    page = _page_text(fig)
    verdicts = [line for line in text_report(done.result).splitlines() if line.startswith("verdict")]
    assert all(line in page for line in verdicts) and verdicts
    assert all(w[:60] in page.replace("\n", " ") for w in warnings[:6]), page


@pytest.fixture(scope="module")
def followed(tmp_path_factory: pytest.TempPathFactory) -> tuple[Trial, FollowResult]:
    """The gapped recording with its IMU (the twin needs the IMU to start), followed."""
    from boat_twin.shadow.follow import follow_trial

    trial = read_trial(_recording(tmp_path_factory.mktemp("gapped") / "gapped.mcap", imu=True))
    return trial, follow_trial(trial, TwinConfig())


def _page_text(fig: Figure) -> str:
    """Every text a figure's axes hold."""
    return "\n".join(t.get_text() for ax in fig.axes for t in ax.texts)


def test_the_track_map_is_measured_against_predicted_on_equal_axes_with_start_and_end(
        followed: tuple[Trial, FollowResult]) -> None:
    from boat_twin.view.track_map import follow_track_figure

    trial, done = followed
    t, measured, predicted = done.track[:, 0], done.track[:, 1:3], done.track[:, 3:5]
    fixes = np.isfinite(trial.east_m)
    assert t.size > 0.8 * np.count_nonzero(fixes)  # one row per fix once synchronised
    assert not np.any((t >= LOST_S[0]) & (t < LOST_S[1]))  # nothing where the recording lost every topic
    error_m = np.hypot(*(measured - predicted).T)
    assert np.median(error_m) < 3.0  # the twin predicts each fix within the GNSS noise
    ax = follow_track_figure(done, "track").axes[0]
    assert ax.get_aspect() == 1.0
    lines = {line.get_label(): line for line in ax.get_lines()}
    np.testing.assert_allclose(lines["start"].get_xydata()[0], measured[0])
    np.testing.assert_allclose(lines["end"].get_xydata()[0], measured[-1])
    np.testing.assert_allclose(lines["measured (GNSS)"].get_xydata(), measured)


def test_the_follow_summary_page_shows_track_ratios_model_and_warnings(followed: tuple[Trial, FollowResult]) -> None:
    from boat_twin.shadow.follow import final_model_text
    from boat_twin.view.summary import follow_summary_figure

    _, done = followed
    fig = follow_summary_figure(done, "summary")
    track_ax, _, ratio_ax = fig.axes[:3]
    assert track_ax.get_aspect() == 1.0
    speed = {line.get_label(): line for line in ratio_ax.get_lines()}["speed"].get_xydata()
    np.testing.assert_allclose(speed[:, 0], [e["t_s"] for e in done.timeline])
    np.testing.assert_allclose(speed[:, 1], [np.nan if e["speed_innovation_ratio"] is None
                                             else e["speed_innovation_ratio"] for e in done.timeline])
    page = _page_text(fig).replace("\n", " ")
    assert final_model_text(done.final)[:40] in page
    assert f"{len(done.timeline)} entries" in page
    assert done.warnings and all(w[:60] in page for w in done.warnings[:6]), page


def test_a_mass_held_at_the_end_of_a_follow_is_a_warning(followed: tuple[Trial, FollowResult]) -> None:
    """A live fit that could not fix the mass (one speed in the horizon) holds it: the report says so."""
    from dataclasses import replace

    from boat_twin.shadow.follow import follow_warnings
    from boat_twin.shadow.session import Shadow

    trial, _ = followed
    config = TwinConfig()
    shadow = Shadow(config)
    assert not any("the mass was held" in w for w in follow_warnings(trial, config, shadow))
    shadow.adapter.current = replace(shadow.adapter.current, mass_held=True)
    held = [w for w in follow_warnings(trial, config, shadow) if "the mass was held" in w]
    assert held == [f"the mass was held at {config.vessel.mass_kg:.0f} kg at the end: the data since the last "
                    "adopted fit did not fix it (the resistance was fitted with it held; no interval on the mass)"]


def test_an_hours_long_track_is_drawn_with_a_bounded_subset_that_keeps_its_ends_and_never_bridges_a_gap() -> None:
    from boat_twin.drawn_line import drawn

    short = np.column_stack([np.arange(100.0), np.arange(100.0)])
    assert drawn(short, limit=1000) is short  # a track within the limit is drawn as it is
    track = np.column_stack([np.arange(216_000.0), np.zeros(216_000)])
    gaps = [5_003, 5_004, 100_001, 215_998]  # a gap of two fixes, one of one, one near the end
    track[gaps] = np.nan
    line = drawn(track, limit=20_000)
    assert line.shape[0] <= 20_000 + 3 * len(gaps) + 1
    np.testing.assert_array_equal(line[[0, -1]], track[[0, -1]])
    x = line[:, 0]
    assert np.count_nonzero(np.isnan(x)) == len(gaps)  # every break drawn
    finite = np.isfinite(x)
    steps = np.flatnonzero(finite[:-1] & finite[1:])
    for gap in gaps:  # no drawn step joins the fixes on either side of a gap
        assert not np.any((x[steps] < gap) & (x[steps + 1] > gap))


def test_identify_s_figures_of_an_hours_long_record_draw_bounded_lines() -> None:
    """The trial and re-simulation figures of a 6-hour record (216,000 samples) draw every line with at most
    about DRAWN_POINTS points, its first and last sample kept (the 6-hour identify's peak memory was the
    legend's and the renderer's copies of the whole lines)."""
    from boat_twin.drawn_line import DRAWN_POINTS
    from boat_twin.ident.output_error import SurgeRecord
    from boat_twin.ident.report import trial_figure
    from boat_twin.ident.resimulate import Resimulation, resimulation_figure

    t = np.arange(216_000) * 0.1
    speed = 3.0 + np.sin(t / 60.0)
    record = SurgeRecord(t, 500.0 + 100.0 * np.sign(np.sin(t / 300.0)), speed)
    result = {"output_error": {"selected": {}}, "steady_points": [], "rejected_segments": []}
    resim = Resimulation(t_s=t, measured_mps=speed, simulated_mps=speed + 0.01, speed_noise_mps=0.02,
                         effective_mass_kg=1000.0, mass_source="identified")
    for fig in (trial_figure(result, [record]), resimulation_figure(resim)):
        lines = [line for ax in fig.axes for line in ax.get_lines() if len(line.get_xdata()) > 2]
        assert len(lines) >= 2
        for line in lines:
            x = np.asarray(line.get_xdata())
            assert x.size <= DRAWN_POINTS + 1
            assert (x[0], x[-1]) == (t[0], t[-1])


def test_diagnose_s_signal_lines_of_six_hours_of_windows_are_bounded_and_break_between_windows() -> None:
    """1,080 replay windows of 201 samples (6 hours): the signal figures' joined line keeps a break after every
    window and at most about DRAWN_POINTS points besides the breaks and their neighbours; 30 windows (a
    10-minute trial) are drawn whole."""
    from types import SimpleNamespace

    from boat_twin.diagnose.report import window_series
    from boat_twin.drawn_line import DRAWN_POINTS

    for count, whole in ((30, True), (1080, False)):
        t = np.arange(count)[None, :] * 20.0 + np.arange(201)[:, None] * 0.1  # (samples, windows), as Windows.t_s
        t_drawn, v_drawn = window_series(SimpleNamespace(t_s=t), np.sin(t))
        assert np.count_nonzero(np.isnan(v_drawn)) == count
        assert (t_drawn.size == count * 202) is whole
        assert t_drawn.size <= DRAWN_POINTS + 3 * count + 1
