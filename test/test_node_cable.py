"""The ``cable`` node with real rclpy: services answer like the library, topics carry the shape."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

rclpy = pytest.importorskip("rclpy")
pytest.importorskip("std_srvs.srv")
pytest.importorskip("nav_msgs.msg")

from geometry_msgs.msg import TwistStamped  # noqa: E402
from nav_msgs.msg import Path as PathMsg  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from rclpy.qos import DurabilityPolicy, QoSProfile  # noqa: E402
from std_msgs.msg import Float64  # noqa: E402
from std_srvs.srv import Trigger  # noqa: E402

from boat_twin.cable import load_case, solve_depth, solve_length, with_overrides  # noqa: E402
from boat_twin.nodes.cable import CableNode  # noqa: E402

CASE = Path(__file__).resolve().parents[1] / "config" / "cable" / "default.yaml"
LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)


@pytest.fixture()
def ros():
    rclpy.init()
    node = CableNode(parameter_overrides=[Parameter("case_file", value=str(CASE)),
                                          Parameter("update_period_s", value=0.05)])
    client = rclpy.create_node("cable_test_client")
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    executor.add_node(client)
    yield node, client, executor
    executor.shutdown()
    client.destroy_node()
    node.destroy_node()
    rclpy.try_shutdown()


def call(client, executor, name: str) -> Trigger.Response:
    cli = client.create_client(Trigger, name)
    assert cli.wait_for_service(timeout_sec=5.0)
    future = cli.call_async(Trigger.Request())
    executor.spin_until_future_complete(future, timeout_sec=10.0)
    assert future.done()
    return future.result()


def spin_until(executor, predicate, timeout_s: float = 5.0) -> None:
    for _ in range(int(timeout_s / 0.05)):
        if predicate():
            return
        executor.spin_once(timeout_sec=0.05)
    assert predicate()


def test_services_answer_like_the_library(ros) -> None:
    node, client, executor = ros
    case = load_case(CASE)
    reply = call(client, executor, "/cable/solve_depth")
    assert reply.success, reply.message
    assert json.loads(reply.message)["vehicle_depth_m"] == pytest.approx(solve_depth(case).vehicle_depth_m)
    reply = call(client, executor, "/cable/solve_length")
    assert reply.success, reply.message
    assert json.loads(reply.message)["length_m"] == pytest.approx(solve_length(case).length_m)


def test_topics_carry_shape_depth_and_tension(ros) -> None:
    node, client, executor = ros
    got: dict[str, object] = {}
    client.create_subscription(PathMsg, "cable/path", lambda m: got.__setitem__("path", m), LATCHED)
    client.create_subscription(Float64, "cable/vehicle_depth", lambda m: got.__setitem__("depth", m), LATCHED)
    client.create_subscription(Float64, "cable/top_tension", lambda m: got.__setitem__("tension", m), LATCHED)
    spin_until(executor, lambda: len(got) == 3)
    expected = solve_depth(load_case(CASE))
    path = got["path"]
    assert path.header.frame_id == "tow_point"
    assert len(path.poses) == expected.link_length_m.size + 1
    assert path.poses[-1].pose.position.z == pytest.approx(-expected.vehicle_depth_m)
    assert got["depth"].data == pytest.approx(expected.vehicle_depth_m)
    assert got["tension"].data == pytest.approx(expected.top_tension_N)


def test_bad_parameter_is_refused_with_the_reason(ros) -> None:
    node, _client, _executor = ros
    result = node.set_parameters([Parameter("cable.diameter_m", value=-0.02)])[0]
    assert not result.successful and "cable.diameter_m" in result.reason
    assert node.get_parameter("cable.diameter_m").value == pytest.approx(0.02)
    assert node.set_parameters([Parameter("cable.length_m", value=250.0)])[0].successful


def test_follows_live_tow_speed(ros) -> None:
    node, client, executor = ros
    node.set_parameters([Parameter("follow_gnss_vel", value=True)])
    depths: list[float] = []
    client.create_subscription(Float64, "cable/vehicle_depth", lambda m: depths.append(m.data), LATCHED)
    pub = client.create_publisher(TwistStamped, "gnss/vel", 10)
    msg = TwistStamped()
    msg.twist.linear.x, msg.twist.linear.y = 1.2, 1.6  # 2.0 m/s over ground, ENU
    expected = solve_depth(with_overrides(load_case(CASE), tow_speed_mps=2.0)).vehicle_depth_m

    def reached() -> bool:
        pub.publish(msg)
        return bool(depths) and depths[-1] == pytest.approx(expected)

    spin_until(executor, reached)
