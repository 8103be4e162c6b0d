"""Starting and stopping like a driver: Ctrl-C at any moment of the start-up ends quietly, a best-effort
command publisher drives the boat, and pymavlink is not loaded unless MAVLink is on."""

from __future__ import annotations

import math
import signal
import socket
import subprocess
import sys
import time

import pytest
import rosnodes
from nav_msgs.msg import Odometry
from rclpy.qos import qos_profile_sensor_data
from std_msgs.msg import Float64

from boat_twin.io.messages import COMMAND_TOPICS


@pytest.mark.parametrize(("name", "delay_s", "signum"), [
    ("simulator", 0.2, signal.SIGINT), ("simulator", 0.6, signal.SIGINT), ("simulator", 1.2, signal.SIGINT),
    ("identifier", 0.8, signal.SIGINT), ("player", 0.8, signal.SIGTERM), ("cable", 1.5, signal.SIGTERM),
])
def test_a_signal_during_start_up_ends_the_node_quietly(tmp_path, name, delay_s, signum) -> None:
    proc = rosnodes.NodeProcess(name, {}, tmp_path)
    time.sleep(delay_s)  # numpy, scipy, numba and rclpy are still loading
    proc.process.send_signal(signum)
    assert proc.wait(30.0) == 0, proc.stderr
    assert "Traceback" not in proc.stderr and "KeyboardInterrupt" not in proc.stderr, proc.stderr


def test_a_best_effort_command_publisher_drives_the_boat(tmp_path) -> None:
    with rosnodes.nodes(("simulator", {"noise": False}), log_dir=tmp_path) as (sim,), rosnodes.probe() as probe:
        speeds: list[float] = []
        probe.node.create_subscription(Odometry, "odom/truth", lambda m: speeds.append(
            math.hypot(m.twist.twist.linear.x, m.twist.twist.linear.y)), qos_profile_sensor_data)
        thrust = [probe.node.create_publisher(Float64, topic, qos_profile_sensor_data) for topic in COMMAND_TOPICS[:2]]

        def push() -> None:
            for publisher in thrust:
                publisher.publish(Float64(data=600.0))

        assert probe.spin_until(lambda: bool(speeds) and speeds[-1] > 0.5, rosnodes.START_TIMEOUT_S, push), speeds[-1:]
        stderr = sim.stderr
    assert "incompatible QoS" not in stderr and "Traceback" not in stderr


def test_pymavlink_is_imported_only_with_mavlink_on(tmp_path) -> None:
    code = "import sys, boat_twin.nodes.simulator; print('pymavlink' in sys.modules)"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and done.stdout.strip() == "False", done.stderr
    # ...and with MAVLink on, the node imports it and speaks MAVLink 2 to the ground station
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as ground_station:
        ground_station.bind(("127.0.0.1", 0))
        ground_station.settimeout(rosnodes.START_TIMEOUT_S)
        url = f"udpout:127.0.0.1:{ground_station.getsockname()[1]}"
        with rosnodes.nodes(("simulator", {"mavlink_url": url}), log_dir=tmp_path) as (sim,):
            packet, _sender = ground_station.recvfrom(4096)
            stderr = sim.stderr
    assert packet[0] == 0xFD and "Traceback" not in stderr
