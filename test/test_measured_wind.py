"""A measured true wind (an anemometer's ``wind`` topic) is read into the Trial and used by the diagnosis as a
known input: the twin replays with it, and the wind is named with its measured size when it explains what the
twin without it gets wrong (issue 36, item 3)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from boat_twin.cli import main
from boat_twin.config import TwinConfig
from boat_twin.diagnose.pipeline import diagnose_trial
from boat_twin.io.bags import read_trial, write_bag
from boat_twin.io.messages import float64, header, vector3_stamped

WIND = (-6.0, 3.0)
"""The hidden wind over ground (east, north), m/s: 6.7 m/s from the east-south-east."""


@pytest.fixture(scope="module")
def windy_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 240 s random-command trial of the default boat in that wind, with the simulator's anemometer."""
    work = tmp_path_factory.mktemp("wind")
    (work / "windy.yaml").write_text(f"environment: {{wind_east_mps: {WIND[0]}, wind_north_mps: {WIND[1]}}}\n")
    bag = work / "windy.mcap"
    assert main(["simulate", "random", "--config", str(work / "windy.yaml"), "--duration", "240", "--seed", "5",
                 "--out", str(bag)]) == 0
    return bag


def test_the_anemometer_is_read_into_the_trial(windy_bag: Path) -> None:
    trial = read_trial(windy_bag)
    assert trial.wind_east_mps is not None and trial.wind_north_mps is not None
    assert np.nanmean(trial.wind_east_mps) == pytest.approx(WIND[0])
    assert np.nanmean(trial.wind_north_mps) == pytest.approx(WIND[1])
    assert "wind" not in trial.metadata.missing and "wind" in trial.metadata.counts


def test_a_measured_wind_is_a_known_input_and_is_named_with_its_size(windy_bag: Path) -> None:
    trial = read_trial(windy_bag)
    done = diagnose_trial(trial, TwinConfig())  # the twin itself is configured for calm air
    wind = done.result["measured_wind"]
    assert wind["named"] and wind["delta_bic"] < -100
    assert wind["speed_mps"] == pytest.approx(math.hypot(*WIND))
    assert wind["from_deg"] == pytest.approx(math.degrees(math.atan2(-WIND[0], -WIND[1])) % 360)
    assert done.result["verdict"] == [] and done.result["unexplained"] is False
    trial.wind_east_mps = trial.wind_north_mps = None  # the same recording without its anemometer
    blind = diagnose_trial(trial, TwinConfig())
    assert "measured_wind" not in blind.result
    assert blind.result["verdict"] or blind.result["unexplained"]  # the wind is a misfit the twin must find


def test_a_wind_topic_read_back_from_a_bag_the_test_writes(tmp_path: Path) -> None:
    """A recording made apart from the simulator: commands, a GNSS velocity and an anemometer written here."""
    from boat_twin.io.messages import TS

    twist = TS.types["geometry_msgs/msg/TwistStamped"]
    vec = TS.types["geometry_msgs/msg/Vector3"]
    messages = []
    for i in range(50):
        stamp = i * 100_000_000
        messages.append(("thrusters/left/thrust", stamp, float64(50.0)))
        messages.append(("gnss/vel", stamp, twist(header=header(stamp, "gnss_link"), twist=TS.types[
            "geometry_msgs/msg/Twist"](linear=vec(x=1.0, y=0.0, z=0.0), angular=vec(x=0.0, y=0.0, z=0.0)))))
        if i % 10 == 0:
            messages.append(("wind", stamp, vector3_stamped(header(stamp, "map"), (2.0, -1.0, 0.0))))
    bag = tmp_path / "anemometer.mcap"
    write_bag(bag, sorted(messages, key=lambda m: m[1]))
    trial = read_trial(bag)
    assert trial.wind_east_mps is not None
    assert np.nanmean(trial.wind_east_mps) == pytest.approx(2.0) and np.nanmean(trial.wind_north_mps) == \
        pytest.approx(-1.0)


def test_a_csv_anemometer_in_knots_from_a_bearing_is_the_wind_over_ground(tmp_path: Path) -> None:
    """A logger's columns: wind speed in knots and the direction it comes from (meteorological, degrees)."""
    from boat_twin.io.csv_trial import read_csv_trial

    rows = ["t,lat,lon,thr,ws,wd"] + [f"{i * 0.1:.1f},59.9,10.7{i:03d},40,10,90" for i in range(60)]
    (tmp_path / "log.csv").write_text("\n".join(rows) + "\n")
    (tmp_path / "map.yaml").write_text("columns:\n  time: t\n  lat: lat\n  lon: lon\n  thrust_left: thr\n"
                                       "  wind_speed: {column: ws, unit: kn}\n  wind_from: wd\n")
    trial = read_csv_trial(tmp_path / "log.csv", tmp_path / "map.yaml")
    assert trial.wind_east_mps is not None and trial.wind_north_mps is not None
    assert np.nanmean(trial.wind_east_mps) == pytest.approx(-10 * 0.514444, rel=1e-4)  # from the east: blows west
    assert np.nanmean(trial.wind_north_mps) == pytest.approx(0.0, abs=1e-9)


def test_a_wind_speed_without_its_bearing_is_refused_in_one_line(tmp_path: Path) -> None:
    from boat_twin.errors import InputError
    from boat_twin.io.csv_trial import read_csv_trial

    (tmp_path / "log.csv").write_text("t,lat,lon,thr,ws\n0,59.9,10.7,40,10\n0.1,59.9,10.7,40,10\n")
    (tmp_path / "map.yaml").write_text("columns: {time: t, lat: lat, lon: lon, thrust_left: thr, wind_speed: ws}\n")
    with pytest.raises(InputError, match="'wind_speed' and 'wind_from' go together"):
        read_csv_trial(tmp_path / "log.csv", tmp_path / "map.yaml")


def test_the_live_twins_rolling_diagnosis_takes_the_measured_wind(windy_bag: Path) -> None:
    """The anemometer's samples reach the live twin's rolling diagnosis (the offline diagnosis' own function):
    it replays with the measured wind and names no wind of its own, where the calm twin misfits."""
    from boat_twin.io.samples import trial_samples
    from boat_twin.shadow.session import Shadow, ShadowSettings

    trial = read_trial(windy_bag)
    shadow = Shadow(TwinConfig(), ShadowSettings(adapt=False))
    runs = []
    for kind, t, values in trial_samples(trial):
        shadow.add(kind, t, values)
        if shadow.rolling.latest is not None and (not runs or runs[-1] is not shadow.rolling.latest):
            runs.append(shadow.rolling.latest)
    shadow.flush()
    end = float(trial.t_s[-1])
    recent = shadow.recent.trial(end - 130.0, end)
    assert recent.wind_east_mps is not None and recent.wind_north_mps is not None
    assert np.nanmean(recent.wind_east_mps) == pytest.approx(WIND[0])
    assert np.nanmean(recent.wind_north_mps) == pytest.approx(WIND[1])
    done = [run for run in runs if not run.error]
    assert done and all("wind" not in [c.name for c in run.causes + run.withheld] for run in done), \
        [(run.t_s, [c.name for c in run.causes]) for run in runs]
