"""The simulator node with real rclpy: publishes GNSS and IMU, and the boat moves under thrust commands."""

import pytest

rclpy = pytest.importorskip("rclpy")

from geometry_msgs.msg import TwistStamped  # noqa: E402
from sensor_msgs.msg import Imu, NavSatFix  # noqa: E402
from std_msgs.msg import Float64  # noqa: E402

from boat_twin.nodes.simulator import SimulatorNode  # noqa: E402


def test_simulator_node_publishes_and_obeys_thrust() -> None:
    rclpy.init()
    try:
        sim = SimulatorNode()
        probe = rclpy.create_node("probe")
        got = {"fix": [], "vel": [], "imu": []}
        probe.create_subscription(NavSatFix, "gnss/fix", got["fix"].append, rclpy.qos.qos_profile_sensor_data)
        probe.create_subscription(TwistStamped, "gnss/vel", got["vel"].append, rclpy.qos.qos_profile_sensor_data)
        probe.create_subscription(Imu, "imu/data", got["imu"].append, rclpy.qos.qos_profile_sensor_data)
        left = probe.create_publisher(Float64, "thrusters/left/thrust", 10)
        right = probe.create_publisher(Float64, "thrusters/right/thrust", 10)
        executor = rclpy.executors.SingleThreadedExecutor()
        executor.add_node(sim)
        executor.add_node(probe)
        for _ in range(60):
            left.publish(Float64(data=500.0))
            right.publish(Float64(data=500.0))
            executor.spin_once(timeout_sec=0.1)
        assert got["fix"] and got["vel"] and got["imu"]
        assert got["fix"][-1].header.frame_id == "gnss_link"
        assert abs(got["imu"][-1].linear_acceleration.z - 9.80665) < 0.5
        assert sim.twin.state[0, 3] > 0.5
    finally:
        rclpy.try_shutdown()
