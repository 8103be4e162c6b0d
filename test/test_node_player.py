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


def test_a_boat_files_thrusters_are_played_on_their_own_topics_and_stopped_at_their_neutral(tmp_path) -> None:
    import yaml

    boat = yaml.safe_load((rosnodes.ROOT / "config" / "boats" / "skid_steer_catamaran.yaml").read_text())
    pwm = {"command": [1100.0, 1450.0, 1550.0, 1900.0], "thrust_N": [-15.0, 0.0, 0.0, 25.0], "unit": "pwm_us"}
    for thruster in boat["vessel"]["propulsion"]["thrusters"]:
        thruster["table"] = pwm
    config = tmp_path / "pwm_boat.yaml"
    config.write_text(yaml.safe_dump(boat))
    commands = tmp_path / "commands.csv"
    commands.write_text("t,thrust_left_N,thrust_right_N,angle_left_rad,angle_right_rad\n"
                        "0,1700,1650,0,0\n8.5,1800,1750,0,0\n10.5,1800,1750,0,0\n")
    heard: dict[str, list[float]] = {"port": [], "starboard": []}
    with rosnodes.probe() as probe:
        for name, values in heard.items():
            probe.node.create_subscription(Float64, f"thrusters/{name}/cmd", lambda m, v=values: v.append(m.data),
                                           QoSProfile(depth=50))
        player = rosnodes.NodeProcess("player", {"commands_file": str(commands), "config_file": str(config)},
                                      tmp_path)
        assert probe.spin_until(lambda: player.process.poll() is not None, rosnodes.START_TIMEOUT_S)
        probe.spin_for(0.5)
    assert player.wait(1.0) == 0, player.stderr
    for name, (ahead, more) in (("port", (1700.0, 1800.0)), ("starboard", (1650.0, 1750.0))):
        values = heard[name]
        changes = [v for i, v in enumerate(values) if i == 0 or v != values[i - 1]]
        # the file's columns on the boat file's thrusters in its order; stopped at the dead band's middle
        assert changes[-2:] == [more, 1500.0] and set(changes[:-2]) <= {ahead}, (name, values)
