"""The bag player and the identifier node on a boat file's own actuator topics (issue 36): a single-screw ship's
commands played on thrusters/main/cmd (rev/s) and rudders/rudder/angle with its measured wind on ``wind``, and
the identifier listening there, as the simulator and the shadow node do (one helper: nodes.conventions)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
import rosnodes
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import TwistStamped, Vector3Stamped
from rclpy.qos import QoSProfile
from std_msgs.msg import Float64

from boat_twin.cli import main

BOAT = Path(__file__).resolve().parents[1] / "config" / "boats" / "single_screw_rudder.yaml"
WIND = (-5.0, 2.0)


def _windy_boat(tmp_path: Path) -> Path:
    """The single-screw ship's boat file with a wind in its environment."""
    path = tmp_path / "windy_ship.yaml"
    path.write_text(BOAT.read_text() + f"environment: {{wind_east_mps: {WIND[0]}, wind_north_mps: {WIND[1]}}}\n")
    return path


def test_the_bag_player_plays_a_boat_files_actuators_and_its_wind(tmp_path: Path) -> None:
    boat = _windy_boat(tmp_path)
    bag = tmp_path / "zigzag.mcap"
    assert main(["simulate", "zigzag-10-10", "--config", str(boat), "--duration", "20", "--out", str(bag)]) == 0
    got: dict[str, list] = {"thrusters/main/cmd": [], "rudders/rudder/angle": [], "wind": [], "gnss/vel": []}
    with rosnodes.probe() as probe:
        for topic, cls in (("thrusters/main/cmd", Float64), ("rudders/rudder/angle", Float64),
                           ("wind", Vector3Stamped), ("gnss/vel", TwistStamped)):
            probe.node.create_subscription(cls, topic, got[topic].append, QoSProfile(depth=500))
        player = rosnodes.NodeProcess("bag_player", {"trial": str(bag), "rate": 5.0, "config_file": str(boat)},
                                      tmp_path)
        topics: set[str] = set()

        def finished() -> bool:
            topics.update(name for name, _ in probe.node.get_topic_names_and_types())
            return player.process.poll() is not None

        assert probe.spin_until(finished, rosnodes.START_TIMEOUT_S), player.stderr
        probe.spin_for(0.5)
    assert player.wait(1.0) == 0, player.stderr
    assert all(got.values()), {k: len(v) for k, v in got.items()}
    assert max(m.data for m in got["thrusters/main/cmd"]) > 5.0  # rev/s, not N
    assert max(abs(m.data) for m in got["rudders/rudder/angle"]) == pytest.approx(math.radians(10.0))
    assert (got["wind"][-1].vector.x, got["wind"][-1].vector.y) == pytest.approx(WIND)
    assert "/thrusters/left/thrust" not in topics and "/thrusters/main/cmd" in topics


def test_the_identifier_listens_on_a_boat_files_actuators(tmp_path: Path) -> None:
    diagnostics: list = []
    with rosnodes.nodes(("identifier", {"config_file": str(BOAT)}), log_dir=tmp_path) as (ident,), \
            rosnodes.probe() as probe:
        node = probe.node
        node.create_subscription(DiagnosticArray, "/diagnostics", diagnostics.append, 10)
        screw = node.create_publisher(Float64, "thrusters/main/cmd", 10)
        rudder = node.create_publisher(Float64, "rudders/rudder/angle", 10)
        assert probe.spin_until(lambda: screw.get_subscription_count() > 0 and rudder.get_subscription_count() > 0
                                and diagnostics, rosnodes.START_TIMEOUT_S)

        def held() -> list:
            return {kv.key: json.loads(kv.value) for kv in diagnostics[-1].status[0].values}["held_commands"]

        screw.publish(Float64(data=12.5))
        rudder.publish(Float64(data=0.1))
        assert probe.spin_until(lambda: held() == [12.5, 0.0, 0.1, 0.0], 10.0), held()  # one screw: no second
        assert "Traceback" not in ident.stderr
