"""Reports say what was assumed or lost, and show the track (issue 39): a recording missing 33 s of every topic
(as a damaged MCAP chunk loses them) and its IMU altogether is followed, diagnosed and identified; each report's
``warnings`` names the missing signal and the span, the ``--each`` rows count them, a run without boat facts says
what it assumed; the track map draws the measured fixes against the twin's predictions on equal axes."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from boat_twin.config import TwinConfig
from boat_twin.diagnose.hidden import scenario
from boat_twin.io import messages
from boat_twin.io.bags import read_trial, write_bag
from boat_twin.twin.sea_trial import run_sea_trial, trial_messages

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
    from boat_twin.fleet.jobs import FollowJob

    row = FollowJob()(damaged, tmp_path / "each")
    assert row["warnings"] == len(json.loads((tmp_path / "each" / "follow.json").read_text())["warnings"]) >= 4
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
    warnings = diagnose_trial(read_trial(gapped), TwinConfig()).result["warnings"]
    assert any("gnss_fix: 1 span(s) without samples" in w for w in warnings), warnings
    assert any("imu: 1 span(s) without samples" in w for w in warnings), warnings
    row = DiagnoseJob()(gapped, tmp_path / "each")
    assert row["warnings"] == len(warnings) >= 3
    assert (tmp_path / "each" / "diagnosis_track.png").stat().st_size > 10_000


def test_the_track_map_is_measured_against_predicted_on_equal_axes_with_start_and_end(tmp_path: Path) -> None:
    from boat_twin.shadow.follow import follow_trial
    from boat_twin.view.track_map import follow_track_figure

    trial = read_trial(_recording(tmp_path / "gapped.mcap", imu=True))  # the twin needs the IMU to start
    done = follow_trial(trial, TwinConfig())
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
