"""Nothing keeps a boat running that nobody drives: the simulator's command watchdog zeroes the thrust when
the commands stop, and the ``player`` sends zero thrust however it stops (its end, SIGTERM, Ctrl-C)."""

from __future__ import annotations

import json
import math
import signal
import time

import pytest
import rosnodes
from diagnostic_msgs.msg import DiagnosticArray
from nav_msgs.msg import Odometry
from rclpy.qos import QoSProfile, qos_profile_sensor_data
from std_msgs.msg import Float64

THRUST_TOPICS = ("thrusters/left/thrust", "thrusters/right/thrust")
TIMEOUT_S = 0.5


def test_the_watchdog_zeroes_the_thrust_once_the_commands_stop(tmp_path) -> None:
    params = {"noise": False, "command_timeout_s": TIMEOUT_S}
    with rosnodes.nodes(("simulator", params), log_dir=tmp_path) as (sim,), rosnodes.probe() as probe:
        node = probe.node
        speeds: list[tuple[float, float]] = []
        statuses: list = []
        node.create_subscription(Odometry, "odom/truth", lambda m: speeds.append(
            (time.monotonic(), math.hypot(m.twist.twist.linear.x, m.twist.twist.linear.y))), qos_profile_sensor_data)
        node.create_subscription(DiagnosticArray, "/diagnostics", lambda m: statuses.extend(m.status), 10)
        thrust = [node.create_publisher(Float64, topic, 10) for topic in THRUST_TOPICS]
        assert probe.spin_until(lambda: speeds and all(p.get_subscription_count() for p in thrust),
                                rosnodes.START_TIMEOUT_S)
        last_sent = 0.0

        def push() -> None:
            nonlocal last_sent
            for publisher in thrust:
                publisher.publish(Float64(data=800.0))
            last_sent = time.monotonic()

        probe.spin_for(3.0, push)
        assert speeds[-1][1] > 0.3, speeds[-1]  # the commands reached the boat
        probe.spin_for(3.0)  # nobody commands any more
        stderr = sim.stderr
    peak_wall, peak = max(speeds, key=lambda item: item[1])
    # thrust at zero from the first tick after the timeout (+ one tick, + the engines' and the probe's lags)
    assert peak_wall < last_sent + TIMEOUT_S + 1.0, (peak_wall - last_sent, peak)
    assert speeds[-1][1] < peak - 0.05, (speeds[-1], peak)  # coasting down, not held at 800 N
    assert stderr.count("thrust set to zero") == 1, stderr  # one warning per lapse
    assert f"no thruster command for {TIMEOUT_S:g} s" in stderr
    commands = [s for s in statuses if s.name == "simulator: commands"]
    lapsed = {kv.key: json.loads(kv.value) for kv in commands[-1].values}
    assert lapsed["held_commands"][:2] == [0.0, 0.0] and lapsed["lapses"] == 1, lapsed
    assert lapsed["command_age_s"] > TIMEOUT_S
    assert "Traceback" not in stderr


def thrust_heard(probe: rosnodes.Probe) -> dict[str, list[float]]:
    heard: dict[str, list[float]] = {topic: [] for topic in THRUST_TOPICS}
    for topic in THRUST_TOPICS:
        probe.node.create_subscription(Float64, topic, lambda m, t=topic: heard[t].append(m.data),
                                       QoSProfile(depth=100))
    return heard


def test_the_player_sends_zero_thrust_when_its_profile_ends(tmp_path) -> None:
    commands = tmp_path / "commands.csv"
    # the profile runs on the player's clock from its start, whatever discovery takes: its last command is held
    # 8.5 s (on a loaded CI machine the probe heard nothing before the end of a 1.5 s hold, only the final zero)
    commands.write_text("t,thrust_left_N,thrust_right_N,angle_left_rad,angle_right_rad\n"
                        "0,300,300,0,0\n1.5,400,350,0.1,0.1\n10,400,350,0.1,0.1\n")
    with rosnodes.probe() as probe:
        heard = thrust_heard(probe)
        player = rosnodes.NodeProcess("player", {"commands_file": str(commands)}, tmp_path)
        assert probe.spin_until(lambda: player.process.poll() is not None, rosnodes.START_TIMEOUT_S)
        probe.spin_for(0.5)
    assert player.wait(1.0) == 0, player.stderr
    assert 400.0 in heard[THRUST_TOPICS[0]] and 350.0 in heard[THRUST_TOPICS[1]], heard
    assert [values[-1] for values in heard.values()] == [0.0, 0.0], heard
    assert "zero thrust sent" in player.stderr and "Traceback" not in player.stderr


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_the_player_sends_zero_thrust_when_it_is_stopped(tmp_path, signum) -> None:
    commands = tmp_path / "commands.csv"
    commands.write_text("t,thrust_left_N,thrust_right_N,angle_left_rad,angle_right_rad\n0,500,500,0,0\n600,500,500,0,0\n")
    with rosnodes.probe() as probe:
        heard = thrust_heard(probe)
        player = rosnodes.NodeProcess("player", {"commands_file": str(commands)}, tmp_path)
        try:
            assert probe.spin_until(lambda: all(v and v[-1] == 500.0 for v in heard.values()),
                                    rosnodes.START_TIMEOUT_S), heard
            player.process.send_signal(signum)
            assert probe.spin_until(lambda: player.process.poll() is not None, 10.0)
            probe.spin_for(0.5)
        finally:
            player.stop()
    assert player.wait(1.0) == 0, player.stderr
    assert [values[-1] for values in heard.values()] == [0.0, 0.0], heard
    assert "zero thrust sent" in player.stderr and "Traceback" not in player.stderr
