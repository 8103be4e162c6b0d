"""The ``player`` node as a process: plays a command CSV on the thruster topics in time order, then exits."""

from __future__ import annotations

import time

import pytest
import rosnodes
from rclpy.qos import QoSProfile
from std_msgs.msg import Float64


def test_player_plays_a_command_file_in_time_and_ends_by_itself(tmp_path) -> None:
    commands = tmp_path / "commands.csv"
    commands.write_text("t,thrust_left_N,thrust_right_N,angle_left_rad,angle_right_rad\n"
                        "0,100,100,0,0\n8.5,300,250,0.1,0.1\n10.5,250,250,0,0\n12.5,0,0,0,0\n13.5,0,0,0,0\n")
    heard: list[tuple[float, float]] = []
    with rosnodes.probe() as probe:
        probe.node.create_subscription(Float64, "thrusters/left/thrust",
                                       lambda m: heard.append((time.monotonic(), m.data)), QoSProfile(depth=50))
        player = rosnodes.NodeProcess("player", {"commands_file": str(commands)}, tmp_path)
        assert probe.spin_until(lambda: player.process.poll() is not None, rosnodes.START_TIMEOUT_S)
        probe.spin_for(0.5)
    assert player.wait(1.0) == 0, player.stderr
    values = [v for _, v in heard]
    changes = [v for i, v in enumerate(values) if i == 0 or v != values[i - 1]]
    # the file's rows in order, each held until the next (the first may go out before the probe is discovered:
    # it holds 8.5 s, as the player-stop test's profile does, for a loaded machine's discovery)
    assert changes[-3:] == [300.0, 250.0, 0.0] and set(changes[:-3]) <= {100.0}, values
    first = {v: t for t, v in reversed(heard)}
    assert first[250.0] - first[300.0] == pytest.approx(2.0, abs=0.3)  # row times on the node's (wall) clock
    assert "played to its end" in player.stderr


def test_a_closed_loop_scenario_is_refused_in_one_line(tmp_path) -> None:
    proc = rosnodes.NodeProcess("player", {"scenario": "zigzag-20-20"}, tmp_path)
    assert proc.wait(rosnodes.START_TIMEOUT_S) == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "steers on the boat's heading" in lines[0], lines
