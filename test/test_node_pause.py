"""The simulator's ~/pause and ~/reset services: a paused simulation publishes nothing and its clock stands; a
reset puts the boat at rest at the origin and its /clock back to 0."""

from __future__ import annotations

import math

import rosnodes
from nav_msgs.msg import Odometry
from rclpy.qos import QoSProfile, qos_profile_sensor_data
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Float64
from std_srvs.srv import SetBool, Trigger

from boat_twin.io.messages import COMMAND_TOPICS


def call(probe: rosnodes.Probe, srv_type: type, name: str, request: object) -> object:
    client = probe.node.create_client(srv_type, name)
    assert client.wait_for_service(timeout_sec=rosnodes.START_TIMEOUT_S)
    future = client.call_async(request)
    probe.executor.spin_until_future_complete(future, timeout_sec=10.0)
    assert future.done()
    return future.result()


def test_pause_stops_the_clock_and_reset_puts_the_boat_back_at_rest(tmp_path) -> None:
    params = {"publish_clock": True, "real_time_factor": 5.0, "noise": False}
    with rosnodes.nodes(("simulator", params), log_dir=tmp_path) as (sim,), rosnodes.probe() as probe:
        node = probe.node
        clocks: list[float] = []
        odom: list[Odometry] = []
        node.create_subscription(Clock, "/clock", lambda m: clocks.append(m.clock.sec + m.clock.nanosec * 1e-9),
                                 QoSProfile(depth=10))
        node.create_subscription(Odometry, "odom/truth", odom.append, qos_profile_sensor_data)
        thrust = [node.create_publisher(Float64, topic, 10) for topic in COMMAND_TOPICS[:2]]

        def push() -> None:
            for publisher in thrust:
                publisher.publish(Float64(data=600.0))

        def speed() -> float:
            return math.hypot(odom[-1].twist.twist.linear.x, odom[-1].twist.twist.linear.y)

        assert probe.spin_until(lambda: bool(odom) and speed() > 0.5, rosnodes.START_TIMEOUT_S, push)
        paused = call(probe, SetBool, "/simulator/pause", SetBool.Request(data=True))
        assert paused.success and paused.message.startswith("paused at"), paused.message
        probe.spin_for(0.3)  # what was on its way
        heard = (len(clocks), len(odom))
        probe.spin_for(1.5, push)  # 7.5 s of simulated time if it were running
        assert (len(clocks), len(odom)) == heard
        assert call(probe, SetBool, "/simulator/pause", SetBool.Request(data=False)).success
        assert probe.spin_until(lambda: len(clocks) > heard[0] + 5, 10.0, push)
        assert clocks[-1] - clocks[heard[0] - 1] < 3.0  # resumed where it stood, no catch-up of the pause
        before = clocks[-1]
        reset = call(probe, Trigger, "/simulator/reset", Trigger.Request())
        assert reset.success, reset.message
        count = len(odom)

        def at_origin(msg: Odometry) -> bool:
            return math.hypot(msg.pose.pose.position.x, msg.pose.pose.position.y) < 0.01

        assert not any(at_origin(m) for m in odom[-5:])  # it had moved away
        assert probe.spin_until(lambda: any(at_origin(m) for m in odom[count:]), 10.0)
        assert probe.spin_until(lambda: clocks[-1] < before, 10.0)  # /clock went back
        stderr = sim.stderr
    assert "Traceback" not in stderr
