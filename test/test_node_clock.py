"""Simulated time without silent states: use_sim_time is fixed at start-up (a change is refused with the
reason), a node waiting for a /clock that never comes says so, and a clock that jumps backwards resets the
identifier with one log line."""

from __future__ import annotations

import json

import rosnodes
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import TwistStamped
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from rclpy.qos import QoSProfile, qos_profile_sensor_data
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import NavSatFix
from std_msgs.msg import Float64

from boat_twin.io.messages import COMMAND_TOPICS
from boat_twin.nodes.conventions import CLOCK_WAIT_S


def clock_msg(stamp_ns: int) -> Clock:
    msg = Clock()
    msg.clock.sec, msg.clock.nanosec = divmod(stamp_ns, 1_000_000_000)
    return msg


def set_use_sim_time(probe: rosnodes.Probe, node_name: str, value: bool):
    client = probe.node.create_client(SetParameters, f"/{node_name}/set_parameters")
    assert client.wait_for_service(timeout_sec=rosnodes.START_TIMEOUT_S)
    request = SetParameters.Request(parameters=[Parameter(
        name="use_sim_time", value=ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=value))])
    future = client.call_async(request)
    probe.executor.spin_until_future_complete(future, timeout_sec=10.0)
    return future.result().results[0]


def test_a_simulator_on_sim_time_warns_without_clock_refuses_a_change_and_runs_on_clock(tmp_path) -> None:
    with rosnodes.nodes(("simulator", {"use_sim_time": True}), log_dir=tmp_path) as (sim,), \
            rosnodes.probe() as probe:
        fixes: list = []
        probe.node.create_subscription(NavSatFix, "gnss/fix", fixes.append, 10)
        refused = set_use_sim_time(probe, "simulator", False)
        assert not refused.successful and "use_sim_time is read at start-up only" in refused.reason
        assert probe.spin_until(lambda: "no /clock has arrived" in sim.stderr, rosnodes.START_TIMEOUT_S)
        assert not fixes  # nothing runs without /clock...
        clock = probe.node.create_publisher(Clock, "/clock", QoSProfile(depth=1))
        now_ns = 7_000_000_000

        def tick() -> None:
            nonlocal now_ns
            now_ns += 10_000_000
            clock.publish(clock_msg(now_ns))

        assert probe.spin_until(lambda: len(fixes) > 3, 20.0, tick)  # ...and it runs on the /clock it hears
        stamp = fixes[-1].header.stamp
        assert 7.0 < stamp.sec + stamp.nanosec * 1e-9 <= now_ns * 1e-9
        stderr = sim.stderr
    assert stderr.count("no /clock has arrived") == 1 and f"in {CLOCK_WAIT_S:.0f} s" in stderr
    assert "Traceback" not in stderr


def test_a_clock_jumping_back_resets_the_identifier_with_one_line(tmp_path) -> None:
    with rosnodes.nodes(("identifier", {"use_sim_time": True}), log_dir=tmp_path) as (ident,), \
            rosnodes.probe() as probe:
        node = probe.node
        samples: list[int] = []
        node.create_subscription(DiagnosticArray, "/diagnostics", lambda m: samples.extend(
            json.loads(kv.value) for s in m.status for kv in s.values if kv.key == "n_samples"), 10)
        clock = node.create_publisher(Clock, "/clock", QoSProfile(depth=1))
        velocity = node.create_publisher(TwistStamped, "gnss/vel", qos_profile_sensor_data)
        commands = [node.create_publisher(Float64, topic, 10) for topic in COMMAND_TOPICS]
        now_ns = 500_000_000_000

        def run() -> None:
            """Simulated time at 0.05 s per spin, the commands and a GNSS velocity at each step."""
            nonlocal now_ns
            now_ns += 50_000_000
            clock.publish(clock_msg(now_ns))
            for publisher, value in zip(commands, (100.0, 100.0, 0.0, 0.0), strict=True):
                publisher.publish(Float64(data=value))
            msg = TwistStamped()
            msg.header.stamp = clock_msg(now_ns).clock
            msg.twist.linear.x = 1.0
            velocity.publish(msg)

        assert probe.spin_until(lambda: bool(samples) and samples[-1] > 20, rosnodes.START_TIMEOUT_S, run)
        now_ns = 0  # a restarted simulator
        assert probe.spin_until(lambda: "clock jumped back" in ident.stderr, 10.0, run)
        heard = len(samples)
        assert probe.spin_until(lambda: len(samples) > heard, 10.0, run)
        assert samples[heard] < 50, samples[heard - 3:]  # counted afresh from the jump (<= 2.5 s of samples)
        stderr = ident.stderr
    assert stderr.count("clock jumped back") == 1 and "identification reset" in stderr, stderr
    assert "no /clock has arrived" not in stderr  # the clock came within CLOCK_WAIT_S
    assert "Traceback" not in stderr
