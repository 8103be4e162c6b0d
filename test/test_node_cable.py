"""The ``cable`` node as a process: services answer like the library, topics carry the shape, parameters are
checked, and the tow speed follows gnss/vel from reliable and best-effort publishers alike."""

from __future__ import annotations

import json

import pytest
import rosnodes
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import TwistStamped
from nav_msgs.msg import Path as PathMsg
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from rclpy.qos import DurabilityPolicy, QoSProfile, qos_profile_sensor_data
from std_msgs.msg import Float64
from std_srvs.srv import Trigger

from boat_twin.cable import load_case, solve_depth, solve_length, with_overrides

CASE = rosnodes.ROOT / "config" / "cable" / "default.yaml"
LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)


@pytest.fixture(scope="module")
def cable(tmp_path_factory):
    """One cable node (integer parameters given where doubles go) and a probe, for the whole module."""
    log_dir = tmp_path_factory.mktemp("cable")
    params = {"case_file": str(CASE), "update_period_s": 0.2, "cable.length_m": 120, "frame_prefix": "boat1/"}
    with rosnodes.nodes(("cable", params), log_dir=log_dir) as (proc,), rosnodes.probe() as probe:
        yield proc, probe


def call(probe, srv_type, name: str, request):
    client = probe.node.create_client(srv_type, name)
    assert client.wait_for_service(timeout_sec=rosnodes.START_TIMEOUT_S)
    future = client.call_async(request)
    probe.executor.spin_until_future_complete(future, timeout_sec=30.0)
    assert future.done()
    return future.result()


def set_parameter(probe, name: str, value: ParameterValue):
    request = SetParameters.Request(parameters=[Parameter(name=name, value=value)])
    return call(probe, SetParameters, "/cable/set_parameters", request).results[0]


def test_services_answer_like_the_library(cable) -> None:
    _proc, probe = cable
    case = load_case(CASE)
    reply = call(probe, Trigger, "/cable/solve_length", Trigger.Request())
    assert reply.success, reply.message
    assert json.loads(reply.message)["length_m"] == pytest.approx(solve_length(case).length_m)
    reply = call(probe, Trigger, "/cable/solve_depth", Trigger.Request())
    assert reply.success, reply.message
    answer = json.loads(reply.message)
    assert answer["length_m"] == pytest.approx(120.0)
    assert answer["vehicle_depth_m"] > 0.0


def test_topics_carry_shape_depth_and_tension(cable) -> None:
    _proc, probe = cable
    got: dict[str, object] = {}
    probe.node.create_subscription(PathMsg, "cable/path", lambda m: got.__setitem__("path", m), LATCHED)
    probe.node.create_subscription(Float64, "cable/vehicle_depth", lambda m: got.__setitem__("depth", m), LATCHED)
    probe.node.create_subscription(Float64, "cable/top_tension", lambda m: got.__setitem__("tension", m), LATCHED)
    assert probe.spin_until(lambda: len(got) == 3, rosnodes.START_TIMEOUT_S)
    path = got["path"]
    assert path.header.frame_id == "boat1/tow_point"  # frame_prefix + frame_id
    assert path.poses[-1].pose.position.z == pytest.approx(-got["depth"].data)
    assert got["depth"].data > 0.0 and got["tension"].data > 0.0


def test_diagnostics_name_the_node_and_say_the_answer(cable) -> None:
    _proc, probe = cable
    got: list = []
    probe.node.create_subscription(DiagnosticArray, "/diagnostics", lambda m: got.extend(
        s for s in m.status if s.name == "cable: towed cable" and s.level == DiagnosticStatus.OK), 10)
    assert probe.spin_until(lambda: bool(got), 10.0)
    values = {kv.key: json.loads(kv.value) for kv in got[-1].values}
    assert got[-1].hardware_id == "boat_twin" and values["vehicle_depth_m"] > 0.0, values


def test_use_sim_time_is_refused_at_run_time_with_the_reason(cable) -> None:
    _proc, probe = cable
    refused = set_parameter(probe, "use_sim_time", ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=True))
    assert not refused.successful and "use_sim_time is read at start-up only" in refused.reason
    same = set_parameter(probe, "use_sim_time", ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=False))
    assert same.successful, same.reason  # setting the value it has is no change


def test_bad_parameter_is_refused_with_the_reason_and_integers_are_accepted(cable) -> None:
    _proc, probe = cable
    bad = set_parameter(probe, "cable.diameter_m", ParameterValue(type=ParameterType.PARAMETER_DOUBLE,
                                                                  double_value=-0.02))
    assert not bad.successful and "cable.diameter_m" in bad.reason
    good = set_parameter(probe, "cable.length_m", ParameterValue(type=ParameterType.PARAMETER_INTEGER,
                                                                 integer_value=250))
    assert good.successful, good.reason
    reply = call(probe, Trigger, "/cable/solve_depth", Trigger.Request())
    assert json.loads(reply.message)["length_m"] == pytest.approx(250.0)


@pytest.mark.parametrize("qos", [qos_profile_sensor_data, QoSProfile(depth=10)], ids=["best_effort", "reliable"])
def test_follows_live_tow_speed(cable, qos) -> None:
    _proc, probe = cable
    assert set_parameter(probe, "follow_gnss_vel", ParameterValue(type=ParameterType.PARAMETER_BOOL,
                                                                  bool_value=True)).successful
    depths: list[float] = []
    probe.node.create_subscription(Float64, "cable/vehicle_depth", lambda m: depths.append(m.data), LATCHED)
    publisher = probe.node.create_publisher(TwistStamped, "gnss/vel", qos)
    msg = TwistStamped()
    speed = 2.0 if qos.reliability == qos_profile_sensor_data.reliability else 1.5
    msg.twist.linear.x, msg.twist.linear.y = 0.6 * speed, 0.8 * speed  # ENU over ground
    length = json.loads(call(probe, Trigger, "/cable/solve_depth", Trigger.Request()).message)["length_m"]
    expected = solve_depth(with_overrides(load_case(CASE), tow_speed_mps=speed, length_m=length)).vehicle_depth_m
    assert probe.spin_until(lambda: bool(depths) and depths[-1] == pytest.approx(expected), 30.0,
                            lambda: publisher.publish(msg)), (depths[-3:], expected)


def test_default_case_file_without_a_sourced_workspace(monkeypatch) -> None:
    from boat_twin.nodes.cable import default_case_file

    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    assert default_case_file() == str(CASE)
