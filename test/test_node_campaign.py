"""The hostile-input campaign of issue 24 over the nodes, in small form, on the real rclpy (test_campaign.py is the
one over the CLI verbs).

Hostile parameters (misspelt, of the wrong type, out of bounds, NaN or infinite) given to every node at start-up:
exit 2 with one error line naming the parameter, never a traceback. Hostile messages (NaN, ±1e300 commands and
velocities, velocity stamps running backwards) published to the simulator, identifier, cable and shadow nodes at once:
each stays alive and every number it publishes stays finite (or NaN where it means "not yet known"), and it ends
with exit 0 on Ctrl-C.
"""

from __future__ import annotations

import json
import math

import rosnodes
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import TwistStamped
from nav_msgs.msg import Odometry
from rclpy.qos import DurabilityPolicy, QoSProfile, qos_profile_sensor_data
from std_msgs.msg import Float64, Float64MultiArray

from boat_twin.io import messages

PARAMETER_CASES = [
    # (node, hostile parameter, value as typed after -p NAME:=, what the error line names)
    ("simulator", "sead", "5", "parameter sead: not a parameter"),  # misspelt
    ("simulator", "real_time_factor", ".nan", "parameter real_time_factor: expected a finite number"),
    ("identifier", "order", "99", "parameter order: must be from 1 to"),  # out of bounds
    ("identifier", "memory_s", "abc", "parameter memory_s: expected a finite number"),  # wrong type
    ("cable", "tow_speed_mps", ".nan", "tow_speed_mps: expected a finite number"),
    ("cable", "update_period_s", "-1.0", "parameter update_period_s: must be > 0"),
    ("shadow", "adapt", "1.5", "parameter adapt: expected true or false"),
    ("shadow", "reorder_s", ".inf", "parameter reorder_s: expected a finite number"),
    ("player", "seed", "-5", "parameter seed: must be from 0 to"),
    ("bag_player", "rate", ".nan", "parameter rate: expected a finite number"),
]
"""Every node, every kind of hostile parameter; all started at once."""


def test_hostile_parameters_end_every_node_with_one_line_and_exit_2(tmp_path) -> None:
    procs = [rosnodes.NodeProcess(node, {name: value}, tmp_path) for node, name, value, _ in PARAMETER_CASES]
    try:
        codes = [proc.wait(rosnodes.START_TIMEOUT_S) for proc in procs]
    finally:
        for proc in procs:
            proc.stop()
    for (node, name, value, named), proc, code in zip(PARAMETER_CASES, procs, codes, strict=True):
        err = proc.stderr
        errors = [line for line in err.strip().splitlines() if "error" in line.lower()]
        assert code == 2 and "Traceback" not in err, (node, name, value, code, err)
        assert len(errors) == 1 and errors[0].startswith(f"{node}: error: ") and named in errors[0], \
            (node, name, value, err)


HOSTILE_VALUES = (math.nan, 1e300, -1e300, math.inf, 0.5)
"""What a broken driver publishes (the last a valid value: its velocity's stamp, from another clock and running
backwards, is what is hostile)."""


def _velocity(stamp_ns: int, east: float, north: float) -> TwistStamped:
    msg = TwistStamped()
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
    msg.header.frame_id = "hostile"
    msg.twist.linear.x, msg.twist.linear.y = east, north
    return msg


def _finite_or_nan(values: list[float]) -> bool:
    """Finite, or NaN ("not known yet"); never ±inf or an absurd magnitude taken from a hostile sample."""
    return all(math.isnan(v) or (math.isfinite(v) and abs(v) < 1e12) for v in values)


def test_hostile_messages_leave_the_nodes_alive_and_finite(tmp_path) -> None:
    with rosnodes.nodes(("simulator", {"seed": 3}), ("identifier", {}),
                        ("cable", {"follow_gnss_vel": True, "update_period_s": 0.5}),
                        ("shadow", {"twin_path": str(tmp_path / "twin.yaml")}), log_dir=tmp_path) as procs, \
            rosnodes.probe("hostile_probe") as probe:
        node = probe.node
        seen: dict[str, list] = {"sim": [], "odom": [], "coefficients": [], "tension": [], "identifier": [],
                                 "shadow": [], "shadow_model": []}
        node.create_subscription(TwistStamped, messages.TOPIC_GNSS_VEL,
                                 lambda m: m.header.frame_id != "hostile" and seen["sim"].append(m),
                                 qos_profile_sensor_data)
        node.create_subscription(Odometry, "odom/truth", seen["odom"].append, qos_profile_sensor_data)
        node.create_subscription(Odometry, "shadow/odom", seen["shadow"].append, 10)
        node.create_subscription(Float64MultiArray, "shadow/model", lambda m: seen["shadow_model"].append(
            list(m.data)), 10)
        node.create_subscription(Float64MultiArray, "identification/coefficients",
                                 lambda m: seen["coefficients"].append(list(m.data)), 10)
        node.create_subscription(Float64, "cable/top_tension", lambda m: seen["tension"].append(m.data),
                                 QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL))  # latched

        def on_diagnostics(array: DiagnosticArray) -> None:
            for status in array.status:
                if "thrust-speed identification" in status.name:
                    seen["identifier"].append({kv.key: json.loads(kv.value) for kv in status.values})

        node.create_subscription(DiagnosticArray, "/diagnostics", on_diagnostics, 50)
        commands = [node.create_publisher(Float64, topic, 10) for topic in (
            messages.TOPIC_THRUST_LEFT, messages.TOPIC_THRUST_RIGHT, messages.TOPIC_ANGLE_LEFT,
            messages.TOPIC_ANGLE_RIGHT)]
        velocity = node.create_publisher(TwistStamped, messages.TOPIC_GNSS_VEL, qos_profile_sensor_data)
        assert probe.spin_until(lambda: all(seen[key] for key in ("sim", "coefficients", "tension", "shadow")),
                                rosnodes.START_TIMEOUT_S), {k: len(v) for k, v in seen.items()}
        counted = {key: len(values) for key, values in seen.items()}
        tick = [0]

        def hostile() -> None:
            """Every spin: a hostile value on every command and on the velocity, whose stamps run backwards."""
            value = HOSTILE_VALUES[tick[0] % len(HOSTILE_VALUES)]
            for publisher in commands:
                publisher.publish(Float64(data=value))
            velocity.publish(_velocity(2_000_000_000_000 - tick[0] * 100_000_000, value, -value))
            tick[0] += 1

        probe.spin_for(4.0, hostile)
        for publisher in commands[:2]:  # valid data again
            publisher.publish(Float64(data=500.0))
        probe.spin_until(lambda: len(seen["identifier"]) > counted["identifier"] + 1
                         and len(seen["shadow"]) > counted["shadow"], 10.0)  # each publishing again
        probe.spin_for(1.0)
        alive = [proc.process.poll() is None for proc in procs]
        logs = [proc.stderr for proc in procs]
    assert tick[0] > 20 and alive == [True] * 4, (tick, alive, logs)
    assert [proc.process.returncode for proc in procs] == [0] * 4, logs
    assert all("Traceback" not in log for log in logs), logs
    # cable: refused (its one warning names the first refused velocity, NaN or ±1e300 as discovery lets it
    # through first), never solved for
    assert "is not a velocity" in logs[2] and all("is not a velocity" in line for line in logs[2].splitlines()
                                                  if "e+300" in line), logs[2]
    fresh = {key: values[counted[key]:] for key, values in seen.items()}
    assert len(fresh["sim"]) > 10, {k: len(v) for k, v in fresh.items()}  # still publishing (10 Hz)
    assert all(_finite_or_nan([m.twist.linear.x, m.twist.linear.y]) and not math.isnan(m.twist.linear.x)
               for m in fresh["sim"])
    assert all(_finite_or_nan([m.pose.pose.position.x, m.twist.twist.linear.x]) and
               math.isfinite(m.pose.pose.position.x) for m in fresh["odom"])
    assert fresh["coefficients"] and all(_finite_or_nan(values) for values in fresh["coefficients"])
    assert all(math.isfinite(t) for t in seen["tension"])
    assert fresh["shadow"] and all(math.isfinite(m.pose.pose.position.x) and math.isfinite(m.twist.twist.linear.x)
                                   for m in fresh["shadow"])
    assert fresh["shadow_model"] and all(_finite_or_nan(values) for values in fresh["shadow_model"])
    assert fresh["identifier"][-1]["rejected_samples"] > 0, fresh["identifier"][-1]  # counted, not absorbed
