"""Every example configuration shipped in config/ loads with the loader its recipe uses."""

from pathlib import Path

import pytest
import yaml

from boat_twin.cable.case import load_case
from boat_twin.config import TwinConfig, load_twin_config
from boat_twin.io.mavlink import load_calibration
from boat_twin.link.mavlink_boat import servo_calibration

CONFIG = Path(__file__).resolve().parents[1] / "config"
LOADERS = {
    "config": lambda path: load_twin_config(path, None, None),  # --config of simulate / diagnose
    "boats": lambda path: load_twin_config(path, None, None),  # --config, or --boat of identify
    "cable": load_case,  # cable --case
    "mavlink": load_calibration,  # --calibration of identify / diagnose / convert
    "ros": lambda path: ros_parameters(path),  # --params-file of ROS 2 nodes (robot_localization)
}
"""Directory of config/ → the loader of its files."""
SHIPPED = sorted(CONFIG.rglob("*.yaml"))


def ros_parameters(path: Path) -> dict:
    """A ROS 2 parameter file: node name -> {ros__parameters: {...}}; its parameters by node."""
    data = yaml.safe_load(path.read_text())
    assert isinstance(data, dict) and all(set(v) == {"ros__parameters"} for v in data.values()), path
    return {node: v["ros__parameters"] for node, v in data.items()}


def test_robot_localization_fuses_the_twins_topics_about_its_own_origin() -> None:
    nodes = ros_parameters(CONFIG / "ros" / "robot_localization.yaml")
    gnss = load_twin_config(CONFIG / "boat.yaml", None, None).gnss
    navsat = nodes["navsat_transform"]
    assert navsat["datum"] == [gnss.origin_lat_deg, gnss.origin_lon_deg, 0.0] and navsat["wait_for_datum"]
    assert navsat["magnetic_declination_radians"] == 0.0 and navsat["yaw_offset"] == 0.0  # true heading, ENU
    assert navsat["use_local_cartesian"]
    for name in ("ekf_filter_node_odom", "ekf_filter_node_map"):
        ekf = nodes[name]
        assert ekf["twist0"] == "gnss/vel_cov" and ekf["imu0"] == "imu/data" and ekf["two_d_mode"]
        assert ekf["twist0_config"][6:8] == [True, True] and ekf["imu0_remove_gravitational_acceleration"]
        assert len(ekf["imu0_config"]) == len(ekf["twist0_config"]) == 15
    assert nodes["ekf_filter_node_map"]["odom0"] == "odometry/gps"


def test_config_holds_examples_for_every_recipe() -> None:
    names = {path.relative_to(CONFIG).as_posix() for path in SHIPPED}
    assert {"boat.yaml", "cable/default.yaml", "mavlink/twin.yaml", "mavlink/ardupilot_two_outboards.yaml"} <= names
    assert {path.parent.name for path in SHIPPED} <= set(LOADERS), "a config/ directory without a loader here"


@pytest.mark.parametrize("path", SHIPPED, ids=[p.relative_to(CONFIG).as_posix() for p in SHIPPED])
def test_shipped_config_loads(path: Path) -> None:
    assert LOADERS[path.parent.name](path) is not None


def test_twin_calibration_is_the_twins_own_servo_layout_for_the_default_boat() -> None:
    """config/mavlink/twin.yaml (the MAVLink recipe's --calibration) is what the link writes for config/boat.yaml."""
    shipped = yaml.safe_load((CONFIG / "mavlink" / "twin.yaml").read_text())["commands"]
    assert shipped == servo_calibration(TwinConfig().vessel)["commands"]
    assert shipped == servo_calibration(load_twin_config(CONFIG / "boat.yaml", None, None).vessel)["commands"]
