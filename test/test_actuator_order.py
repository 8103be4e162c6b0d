"""A boat file's thrusters fill the command slots in the file's own order, not in the order of their names: the bag
reader, the command line's trial reading and the MAVLink calibration map alike (issue 36)."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import yaml

from boat_twin.config import load_twin_config
from boat_twin.io.messages import actuator_order, command_topics

BOATS = Path(__file__).resolve().parents[1] / "config" / "boats"


def _starboard_first(tmp_path: Path) -> Path:
    """The skid-steer catamaran with its thrusters listed starboard first, under names that sort the other way."""
    data = yaml.safe_load((BOATS / "skid_steer_catamaran.yaml").read_text())
    thrusters = data["vessel"]["propulsion"]["thrusters"]
    thrusters[0]["name"], thrusters[1]["name"] = "port", "stbd"
    data["vessel"]["propulsion"]["thrusters"] = [thrusters[1], thrusters[0]]
    path = tmp_path / "boat.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_a_bag_of_a_boat_files_thrusters_reads_back_into_the_boat_files_slots(tmp_path: Path) -> None:
    from boat_twin.cli import main
    from boat_twin.cli.options import read_options_from_args, trial_from_args
    from boat_twin.io.bags import read_trial

    boat = _starboard_first(tmp_path)
    propulsion = load_twin_config(boat).vessel.propulsion
    assert actuator_order(propulsion) == ("stbd", "port")
    assert command_topics(propulsion)["thrust_left"] == "thrusters/stbd/cmd"
    bag = tmp_path / "zigzag.mcap"  # a skid-steer zigzag: the two thrusters' commands differ
    assert main(["simulate", "zigzag-10-10", "--config", str(boat), "--duration", "20", "--out", str(bag)]) == 0
    ours = read_trial(bag, order=actuator_order(propulsion))
    assert ours.metadata.topics["thrust_left"] == "/thrusters/stbd/cmd"
    assert ours.metadata.topics["thrust_right"] == "/thrusters/port/cmd"
    by_name = read_trial(bag)  # without the boat file: name order, the two swapped
    assert by_name.metadata.topics["thrust_left"] == "/thrusters/port/cmd"
    assert not np.allclose(ours.thrust_left_N, ours.thrust_right_N)
    np.testing.assert_array_equal(ours.thrust_left_N, by_name.thrust_right_N)
    args = argparse.Namespace(config=boat, model=None)
    cli = trial_from_args(bag, args)  # identify/diagnose/follow --config
    np.testing.assert_array_equal(cli.thrust_left_N, ours.thrust_left_N)
    each = read_options_from_args(args)  # what --each hands every batch job
    assert each.order == ("stbd", "port")
    np.testing.assert_array_equal(each.read(bag).thrust_left_N, ours.thrust_left_N)


def test_a_calibration_naming_the_thrusters_fills_the_boat_files_slots() -> None:
    from boat_twin.io.mavlink_calibration import calibration_from_dict

    table = {"source": "SERVO1", "table": [[1100, -1.0], [1900, 1.0]]}
    data = {"commands": {"thrusters/stbd/cmd": table, "thrusters/port/cmd": table}}
    assert calibration_from_dict(data, order=("stbd", "port")).actuators["thrust_left"] == "thrusters/stbd/cmd"
    assert calibration_from_dict(data).actuators["thrust_left"] == "thrusters/port/cmd"
