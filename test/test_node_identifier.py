"""The identifier node as a process: a simulated trial's thrust and GNSS velocity in, the identified
coefficients (labelled Float64MultiArray) and /diagnostics out every second, ~/save and ~/reset services."""

from __future__ import annotations

import json
import math
import time

import numpy as np
import pytest
import rosnodes
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import TwistStamped
from rclpy.qos import qos_profile_sensor_data
from std_msgs.msg import Float64, Float64MultiArray
from std_srvs.srv import Trigger

from boat_twin.config import TwinConfig
from boat_twin.ident.live import LiveIdentifier
from boat_twin.io import messages
from boat_twin.twin.sea_trial import run_sea_trial, trial_messages
from boat_twin.vessel.params import load_params
from boat_twin.vessel.scenarios import CommandProfile

ORDER = 2
LEVELS_N, HOLDS_S = (300, 700, 1150, 500, 0), (80, 70, 60, 120, 5)
"""Four settled thrust levels (N + 2 for N = 2), up and down; the short idle closes the last segment."""
THRUST_TOPICS = (messages.TOPIC_THRUST_LEFT, messages.TOPIC_THRUST_RIGHT)
EPOCH_NS = 1_795_000_000_000_000_000
"""Stamps as a live driver gives them (wall-clock epoch): seconds from sec + nanosec must not move windows."""


def trial_inputs() -> list[tuple[str, object]]:
    """The simulated trial as the node hears it: thrust on change, every GNSS velocity fix, in stamp order."""
    times = np.concatenate([[0.0], np.cumsum(HOLDS_S)[:-1]])
    rows = np.array([[f / 2.0, f / 2.0, 0.0, 0.0] for f in LEVELS_N])
    profile = CommandProfile("node-steps", times, rows, float(sum(HOLDS_S)))
    inputs, held = [], {}
    for topic, stamp_ns, msg in trial_messages(run_sea_trial(TwinConfig(), profile, seed=0), truth=False):
        if topic in THRUST_TOPICS and held.get(topic) != msg.data:
            held[topic] = msg.data
            inputs.append((topic, msg.data))
        elif topic == messages.TOPIC_GNSS_VEL:
            inputs.append((topic, (EPOCH_NS + stamp_ns, msg.twist.linear.x, msg.twist.linear.y)))
    return inputs


def velocity_msg(stamp_ns: int, east: float, north: float) -> TwistStamped:
    msg = TwistStamped()
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
    msg.header.frame_id = "gnss_link"
    msg.twist.linear.x, msg.twist.linear.y = east, north
    return msg


def test_identifier_node_publishes_coefficients_and_diagnostics_and_serves_save_and_reset(tmp_path) -> None:
    model_path = tmp_path / "models" / "identified.yaml"
    params = {"order": ORDER, "memory_s": 3600, "model_path": str(model_path)}  # an integer where a double goes
    with rosnodes.nodes(("identifier", params), log_dir=tmp_path) as (ident,), rosnodes.probe() as probe:
        node = probe.node
        coefficients: list = []
        diagnostics: list = []
        node.create_subscription(Float64MultiArray, "identification/coefficients", coefficients.append, 10)
        node.create_subscription(DiagnosticArray, "/diagnostics", diagnostics.append, 10)
        thrust = {t: node.create_publisher(Float64, t, 10) for t in THRUST_TOPICS}
        velocity = node.create_publisher(TwistStamped, messages.TOPIC_GNSS_VEL, qos_profile_sensor_data)
        publishers = [*thrust.values(), velocity]
        assert probe.spin_until(lambda: all(p.get_subscription_count() > 0 for p in publishers) and diagnostics,
                                rosnodes.START_TIMEOUT_S)
        assert diagnostics[-1].status[0].message == f"waiting for steady points (0 of {ORDER + 2})"

        def status(key: str):
            """A value of the node's latest /diagnostics (published every second)."""
            return {kv.key: json.loads(kv.value) for kv in diagnostics[-1].status[0].values}[key]

        # Feed the trial in stamp order at a pace the node keeps up with; a thrust change settles first.
        direct = LiveIdentifier(order=ORDER)
        sent = 0
        for topic, payload in trial_inputs():
            if topic in thrust:
                # every fix sent so far is handled under the old command, then the new command is in force
                assert probe.spin_until(lambda n=sent: status("n_samples") == n, 10.0)
                index = messages.COMMAND_TOPICS.index(topic)
                thrust[topic].publish(Float64(data=payload))
                direct.set_command(index, payload)
                assert probe.spin_until(lambda i=index, v=payload: status("held_commands")[i] == v, 10.0)
            else:
                velocity.publish(velocity_msg(*payload))
                direct.on_velocity(*payload)
                sent += 1
                time.sleep(0.001)
                probe.executor.spin_once(timeout_sec=0.0)

        assert probe.spin_until(lambda: status("n_samples") == sent, 10.0), (status("n_samples"), sent)
        published = len(coefficients)
        probe.spin_for(2.5)  # at least two more 1 Hz publications, the last surely after the last sample
        assert len(coefficients) >= published + 2
        labels, expected = direct.coefficients()
        out = coefficients[-1]
        assert out.layout.dim[0].label.split(",") == labels == [
            "c0_N_per_mps0", "c1_N_per_mps1", "c2_N_per_mps2", "effective_mass_kg"]
        assert out.layout.dim[0].size == len(out.data) == ORDER + 2
        np.testing.assert_allclose(out.data, expected, rtol=1e-9, atol=1e-9)
        assert all(math.isfinite(x) for x in out.data)
        status = diagnostics[-1].status[0]
        assert status.name == "identifier: thrust-speed identification"  # diagnostic_updater: "<node>: <task>"
        assert status.hardware_id == "boat_twin"  # the root namespace's default
        assert status.level == DiagnosticStatus.OK and status.message == "identified"
        values = {kv.key: json.loads(kv.value) for kv in status.values}
        assert values["steady_points"] == len(LEVELS_N) - 1 and values["rejected_segments"] == 0
        np.testing.assert_allclose(values["coefficients"], out.data[:-1], rtol=1e-9, atol=1e-9)

        def call(service: str) -> Trigger.Response:
            client = node.create_client(Trigger, f"/identifier/{service}")
            assert client.wait_for_service(timeout_sec=10.0)
            future = client.call_async(Trigger.Request())
            probe.executor.spin_until_future_complete(future, timeout_sec=10.0)
            assert future.done()
            return future.result()

        saved = call("save")
        assert saved.success and saved.message == str(model_path)
        model = load_params(model_path)
        np.testing.assert_allclose(model.resistance.coefficients, out.data[:-1], rtol=1e-9, atol=1e-9)
        assert model.mass_kg * (1.0 + model.surge_added_mass_ratio) == pytest.approx(out.data[-1])

        assert call("reset").success
        assert probe.spin_until(lambda: all(math.isnan(x) for x in coefficients[-1].data), 5.0)
        assert probe.spin_until(lambda: diagnostics[-1].status[0].level == DiagnosticStatus.WARN, 5.0)
        model_path.unlink()
        refused = call("save")
        assert not refused.success and refused.message == "not enough steady points yet"
        assert not model_path.exists()
        assert "Traceback" not in ident.stderr


def test_the_model_path_defaults_under_ros_home(tmp_path, monkeypatch) -> None:
    from boat_twin.nodes.identifier import default_model_path

    monkeypatch.setenv("ROS_HOME", str(tmp_path))
    assert default_model_path() == tmp_path / "boat_twin" / "identified_model.yaml"


@pytest.mark.parametrize(("params", "message"), [
    ({"order": 0}, "parameter order: must be from 1 to"),
    ({"memory_s": -5}, "parameter memory_s: must be > 0"),
    ({"memory_s": "long"}, "parameter memory_s: expected a finite number"),
])
def test_bad_parameters_end_with_one_line_and_exit_2(tmp_path, params, message) -> None:
    proc = rosnodes.NodeProcess("identifier", params, tmp_path)
    assert proc.wait(rosnodes.START_TIMEOUT_S) == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("identifier: error: ") and message in lines[0], lines
