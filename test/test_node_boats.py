"""Two boats on one graph (namespaces, frame_prefix, per-boat /diagnostics) and what robot_localization needs
from one: gnss/vel_cov with the sensor model's variances, in the ENU frame, and the static sensor frames."""

from __future__ import annotations

import importlib.util
import json

import numpy as np
import pytest
import rosnodes
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import TwistStamped, TwistWithCovarianceStamped
from nav_msgs.msg import Odometry
from rclpy.qos import DurabilityPolicy, QoSProfile
from sensor_msgs.msg import Imu, NavSatFix

from boat_twin.config import TwinConfig

HAS_TF2_MSGS = importlib.util.find_spec("tf2_msgs") is not None
BOATS = ("boat1", "boat2")
LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def test_two_namespaced_boats_have_their_own_frames_diagnostics_and_covariance_velocity(tmp_path) -> None:
    specs = [("simulator", {"frame_prefix": f"{boat}/", "publish_truth_tf": boat == "boat1"}, {"__ns": f"/{boat}"})
             for boat in BOATS]
    with rosnodes.nodes(*specs, log_dir=tmp_path) as sims, rosnodes.probe() as probe:
        node = probe.node
        got: dict[str, list] = {}

        def listen(cls: type, topic: str, qos: QoSProfile | int = 10) -> None:
            got[topic] = []
            node.create_subscription(cls, topic, got[topic].append, qos)

        for boat in BOATS:
            listen(NavSatFix, f"/{boat}/gnss/fix")
            listen(Imu, f"/{boat}/imu/data")
            listen(Odometry, f"/{boat}/odom/truth")
            listen(TwistStamped, f"/{boat}/gnss/vel", QoSProfile(depth=50))
            listen(TwistWithCovarianceStamped, f"/{boat}/gnss/vel_cov", QoSProfile(depth=50))
            if HAS_TF2_MSGS:
                from tf2_msgs.msg import TFMessage

                listen(TFMessage, f"/{boat}/tf_static", LATCHED)
        statuses: dict[str, object] = {}
        node.create_subscription(DiagnosticArray, "/diagnostics",
                                 lambda m: statuses.update({s.name: s for s in m.status}), 10)
        names = {f"{boat}/simulator: {task}" for boat in BOATS for task in ("simulation", "commands")}
        assert probe.spin_until(lambda: all(got.values()) and names <= set(statuses), rosnodes.START_TIMEOUT_S), (
            {k: len(v) for k, v in got.items()}, sorted(statuses))
        probe.spin_for(1.0)
        stderr = [sim.stderr for sim in sims]
    variance = TwinConfig().gnss.velocity_stdev_mps ** 2
    for boat in BOATS:
        assert got[f"/{boat}/gnss/fix"][-1].header.frame_id == f"{boat}/gnss_link"
        assert got[f"/{boat}/imu/data"][-1].header.frame_id == f"{boat}/imu_link"
        odom = got[f"/{boat}/odom/truth"][-1]
        assert (odom.header.frame_id, odom.child_frame_id) == (f"{boat}/map", f"{boat}/base_link")
        status = statuses[f"{boat}/simulator: simulation"]
        assert status.hardware_id == boat  # the namespace, by default
        values = {kv.key: json.loads(kv.value) for kv in status.values}
        assert values["real_time_factor_requested"] == 1.0 and values["ticks"] > 0
        # gnss/vel_cov: gnss/vel's ENU components and stamp, in the ENU world frame, the model's variances
        plain = {(m.header.stamp.sec, m.header.stamp.nanosec): m for m in got[f"/{boat}/gnss/vel"]}
        with_cov = got[f"/{boat}/gnss/vel_cov"]
        paired = [(plain[(m.header.stamp.sec, m.header.stamp.nanosec)], m) for m in with_cov
                  if (m.header.stamp.sec, m.header.stamp.nanosec) in plain]
        assert len(paired) >= 5
        for vel, cov in paired:
            assert cov.header.frame_id == f"{boat}/map"
            assert (cov.twist.twist.linear.x, cov.twist.twist.linear.y) == (vel.twist.linear.x, vel.twist.linear.y)
            matrix = np.asarray(cov.twist.covariance).reshape(6, 6)
            np.testing.assert_allclose(np.diag(matrix)[:3], [variance] * 3)
            assert np.all(np.diag(matrix)[3:] >= 1e6)
            assert np.count_nonzero(matrix - np.diag(np.diag(matrix))) == 0
    if HAS_TF2_MSGS:
        transforms = {t.child_frame_id: t for t in got["/boat1/tf_static"][-1].transforms}
        assert set(transforms) == {"boat1/gnss_link", "boat1/imu_link"}
        assert transforms["boat1/gnss_link"].header.frame_id == "boat1/base_link"
        height_m = transforms["boat1/gnss_link"].transform.translation.z
        assert height_m == pytest.approx(TwinConfig().gnss.antenna_height_m)
    else:  # one warning naming what is not published: boat2 leaves its truth tf out (publish_truth_tf:=false)
        assert stderr[0].count("tf2_msgs/msg/TFMessage is not installed: topics 'tf', 'tf_static'") == 1, stderr[0]
        assert stderr[1].count("tf2_msgs/msg/TFMessage is not installed: topic 'tf_static' is not") == 1, stderr[1]
    assert not any("Traceback" in text for text in stderr)


def test_a_frame_prefix_with_a_leading_slash_is_refused(tmp_path) -> None:
    proc = rosnodes.NodeProcess("cable", {"frame_prefix": "/boat1/"}, tmp_path)
    assert proc.wait(rosnodes.START_TIMEOUT_S) == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "parameter frame_prefix" in lines[0], lines
