"""What ``follow`` prints and draws (issue 43): every signal's innovation ratio (not only the speed's), in words what
the ratios, ``(unexplained)`` and an interval-less (held or configured) value mean, and figures over the whole
trial that show a fit without an interval.

The trial is test_csv_units' skid-steer log (a 30 kg boat) followed by the default 6 m twin: far off, in speed and
in yaw rate."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import pytest
import yaml
from test_csv_units import MAPPING, skid_steer, write_log

from boat_twin.cli import main
from boat_twin.cli.follow import EXPLAINED, UNEXPLAINED, _text
from boat_twin.config import TwinConfig
from boat_twin.io.sources import read_trial_file
from boat_twin.shadow.follow import follow_trial
from boat_twin.shadow.plots import cause_figure, innovation_figure, model_figure


@pytest.fixture(scope="module")
def log(tmp_path_factory):
    root = tmp_path_factory.mktemp("follow")
    write_log(root / "skid.csv", skid_steer())
    (root / "map.yaml").write_text(yaml.safe_dump(MAPPING))
    return root


def test_follow_prints_every_signals_ratio_and_says_what_they_mean(log, capsys) -> None:
    assert main(["follow", str(log / "skid.csv"), "--columns", str(log / "map.yaml"), "--out", str(log / "o")]) == 0
    text = capsys.readouterr().out
    result = json.loads((log / "o" / "follow.json").read_text())
    header, *rows = text.splitlines()
    assert "speed innov./noise" in header and "yaw rate innov./noise" in header
    for entry in result["timeline"]:
        row = next(r for r in rows if r.split()[0] == f"{entry['t_s']:.0f}")
        assert row.split()[1:3] == [f"{entry['speed_innovation_ratio']:.2f}",
                                    f"{entry['yaw_rate_innovation_ratio']:.2f}"]
        assert entry["yaw_rate_innovation_ratio"] > 1.5  # the default twin misfits the small boat's turns
    assert EXPLAINED in text
    final = next(r for r in rows if r.startswith("final model:"))
    assert "nan" not in final and "configured, not fitted yet; no interval" in final


def test_unexplained_and_a_held_value_are_said_in_words() -> None:
    entry = {"t_s": 60.0, "speed_innovation_ratio": 2.0, "yaw_rate_innovation_ratio": 9.0, "mass_kg": 30.0,
             "resistance_factor": 1.2, "causes": [], "unexplained": True}
    surge = {"mass_kg": 30.0, "mass_ci95_kg": [math.nan, math.nan], "mass_held": True, "resistance_factor": 1.2,
             "resistance_factor_ci95": [1.1, 1.3]}
    text = _text({"timeline": [entry], "final": {**entry, "model": {"surge": surge}}})
    assert "   2.00" in text and "   9.00" in text and "(unexplained)" in text and UNEXPLAINED in text
    assert "mass 30 kg (held: the data did not fix it, the value before is kept; no interval), resistance " \
           "×1.200 [1.100, 1.300]" in text


def test_follow_figures_span_the_trial_draw_every_signal_and_a_held_fit(log) -> None:
    trial = read_trial_file(log / "skid.csv", columns=log / "map.yaml")
    done = follow_trial(trial, TwinConfig())
    end_s = done.final["t_s"]
    assert end_s == pytest.approx(trial.t_s[-1], abs=0.2)
    innovations = innovation_figure(done)
    labels = [ax.get_ylabel() for ax in innovations.axes]
    assert labels == ["speed innovation, m/s", "yaw rate innovation, deg/s", "innovation ratio, -"]
    ratio_lines = [line.get_label() for line in innovations.axes[-1].get_lines()]
    assert sum(label.startswith(("speed:", "yaw rate:")) for label in ratio_lines) == 2
    assert cause_figure(done).axes[0].get_xlim() == pytest.approx((0.0, end_s))
    held = {"mass_kg": 40.0, "mass_ci95_kg": [math.nan, math.nan], "resistance_factor": 1.1,
            "resistance_factor_ci95": [1.0, 1.2]}
    models = [{**m, "latest_fit": held} for m in done.models]
    figure = model_figure(replace(done, models=models), 1300.0)
    mass_axes = figure.axes[0]
    assert mass_axes.get_xlim() == pytest.approx((0.0, end_s))
    assert "latest fit, held (no interval)" in [line.get_label() for line in mass_axes.get_lines()]
    adopted = next(line for line in mass_axes.get_lines() if line.get_label().startswith("adopted"))
    assert adopted.get_xdata()[-1] == pytest.approx(end_s)  # the model drawn to the trial's end
