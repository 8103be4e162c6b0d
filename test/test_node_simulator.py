"""The simulator node as a process on a real ROS 2 graph: what a user's subscriber sees on the wire."""

from __future__ import annotations

import importlib.util
import time

import pytest
import rosnodes
from geometry_msgs.msg import TwistStamped
from nav_msgs.msg import Odometry
from rclpy.qos import QoSProfile, qos_profile_sensor_data
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, NavSatFix
from std_msgs.msg import Float64

HAS_TF2_MSGS = importlib.util.find_spec("tf2_msgs") is not None


def stamp_s(msg) -> float:
    return msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9


def test_reliable_and_best_effort_subscribers_both_receive_and_the_boat_obeys_thrust(tmp_path) -> None:
    with rosnodes.nodes(("simulator", {"seed": 1}), log_dir=tmp_path) as (sim,), rosnodes.probe() as probe:
        node = probe.node
        got: dict[str, list] = {"fix": [], "vel": [], "imu": [], "odom": []}
        arrival: list[tuple[float, float]] = []  # (wall clock at receipt, header stamp) of gnss/vel
        node.create_subscription(NavSatFix, "gnss/fix", got["fix"].append, 10)  # ordinary (reliable) subscriber

        def on_vel(msg: TwistStamped) -> None:
            got["vel"].append(msg)
            arrival.append((time.time(), stamp_s(msg)))

        node.create_subscription(TwistStamped, "gnss/vel", on_vel, qos_profile_sensor_data)
        node.create_subscription(Imu, "imu/data", got["imu"].append, QoSProfile(depth=10))
        node.create_subscription(Odometry, "odom/truth", got["odom"].append, qos_profile_sensor_data)
        thrust = [node.create_publisher(Float64, t, 10) for t in ("thrusters/left/thrust", "thrusters/right/thrust")]

        def push() -> None:
            for publisher in thrust:
                publisher.publish(Float64(data=500.0))

        assert probe.spin_until(lambda: all(got.values()), rosnodes.START_TIMEOUT_S), {k: len(v) for k, v in
                                                                                         got.items()}
        counted = {k: len(v) for k, v in got.items()}
        probe.spin_for(5.0, push)
        rates = {k: (len(v) - counted[k]) / 5.0 for k, v in got.items()}
        assert all(7.0 <= r <= 12.0 for r in rates.values()), rates  # 10 Hz, loose for a loaded machine
        assert probe.spin_until(lambda: got["odom"][-1].twist.twist.linear.x > 0.5, 60.0, push)
        stderr = sim.stderr
    assert got["fix"][-1].header.frame_id == "gnss_link" and got["imu"][-1].header.frame_id == "imu_link"
    assert got["fix"][-1].position_covariance_type == NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN
    assert abs(got["imu"][-1].linear_acceleration.z - 9.80665) < 0.5  # REP-145: +g when level
    # stamps come from the node clock at each tick: close to the wall clock, never a constant lag
    lags = [wall - stamp for wall, stamp in arrival[-20:]]
    assert all(-0.05 < lag < 0.5 for lag in lags), lags
    if not HAS_TF2_MSGS:
        assert stderr.count("tf2_msgs/msg/TFMessage is not installed") == 1, stderr
    assert "Traceback" not in stderr


def test_publish_clock_runs_simulated_time_faster_than_real_time(tmp_path) -> None:
    factor = 10.0
    params = {"publish_clock": True, "real_time_factor": factor}
    with rosnodes.nodes(("simulator", params), log_dir=tmp_path), rosnodes.probe() as probe:
        clocks: list[tuple[float, float]] = []
        stamps: list[float] = []
        probe.node.create_subscription(Clock, "/clock", lambda m: clocks.append(
            (time.monotonic(), m.clock.sec + m.clock.nanosec * 1e-9)), qos_profile_sensor_data)
        probe.node.create_subscription(TwistStamped, "gnss/vel", lambda m: stamps.append(stamp_s(m)), 10)
        assert probe.spin_until(lambda: len(clocks) > 10, rosnodes.START_TIMEOUT_S)
        first = clocks[-1]
        probe.spin_for(4.0)
        last = clocks[-1]
    achieved = (last[1] - first[1]) / (last[0] - first[0])
    assert 0.5 * factor < achieved < 1.1 * factor, achieved
    # sensor stamps are simulated time: whole ticks of 0.1 s, as the clock
    assert stamps and all(abs(s * 10.0 - round(s * 10.0)) < 1e-6 for s in stamps)
    assert max(stamps) <= last[1] + 1e-9


@pytest.mark.parametrize(("params", "message"), [
    ({"real_time_factor": 0}, "parameter real_time_factor: must be > 0"),
    ({"config_file": "/nonexistent/boat.yaml"}, "/nonexistent/boat.yaml"),
    ({"seed": "abc"}, "parameter seed: expected an integer"),
    ({"publish_clock": True, "use_sim_time": True}, "publish_clock and use_sim_time"),
])
def test_bad_parameters_end_with_one_line_and_exit_2(tmp_path, params, message) -> None:
    proc = rosnodes.NodeProcess("simulator", params, tmp_path)
    assert proc.wait(rosnodes.START_TIMEOUT_S) == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("simulator: error: ") and message in lines[0], lines
