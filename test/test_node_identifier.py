"""The identifier node with real rclpy: a simulated trial's thrust and GNSS velocity in, the identified
coefficients (labelled Float64MultiArray) and /diagnostics out at 1 Hz, ~/save and ~/reset services."""

import json
import math
import time

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy")

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus  # noqa: E402
from geometry_msgs.msg import TwistStamped  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.qos import qos_profile_sensor_data  # noqa: E402
from std_msgs.msg import Float64, Float64MultiArray  # noqa: E402
from std_srvs.srv import Trigger  # noqa: E402

from boat_twin.config import TwinConfig  # noqa: E402
from boat_twin.ident.live import LiveIdentifier  # noqa: E402
from boat_twin.io import messages  # noqa: E402
from boat_twin.nodes.identifier import IdentifierNode  # noqa: E402
from boat_twin.sea_trial import run_sea_trial, trial_messages  # noqa: E402
from boat_twin.vessel.params import load_params  # noqa: E402
from boat_twin.vessel.scenarios import CommandProfile  # noqa: E402

ORDER = 2
LEVELS_N, HOLDS_S = (300, 700, 1150, 500, 0), (80, 70, 60, 120, 5)
"""Four settled thrust levels (N + 2 for N = 2), up and down; the short idle closes the last segment."""
THRUST_TOPICS = (messages.TOPIC_THRUST_LEFT, messages.TOPIC_THRUST_RIGHT)


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
            inputs.append((topic, (stamp_ns, msg.twist.linear.x, msg.twist.linear.y)))
    return inputs


def velocity_msg(stamp_ns: int, east: float, north: float) -> TwistStamped:
    msg = TwistStamped()
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
    msg.header.frame_id = "gnss_link"
    msg.twist.linear.x, msg.twist.linear.y = east, north
    return msg


def test_identifier_node_publishes_coefficients_and_diagnostics_and_serves_save_and_reset(tmp_path) -> None:
    model_path = tmp_path / "identified.yaml"
    rclpy.init(args=["test_identifier", "--ros-args", "-p", f"order:={ORDER}", "-p", f"model_path:={model_path}"])
    try:
        node = IdentifierNode()
        probe = rclpy.create_node("probe")
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        executor.add_node(probe)

        def spin_until(done, timeout_s: float) -> bool:
            end = time.monotonic() + timeout_s
            while not done() and time.monotonic() < end:
                executor.spin_once(timeout_sec=0.01)
            return bool(done())

        coefficients: list = []
        diagnostics: list = []
        probe.create_subscription(Float64MultiArray, "identification/coefficients", coefficients.append, 10)
        probe.create_subscription(DiagnosticArray, "/diagnostics", diagnostics.append, 10)
        thrust = {t: probe.create_publisher(Float64, t, 10) for t in THRUST_TOPICS}
        velocity = probe.create_publisher(TwistStamped, messages.TOPIC_GNSS_VEL, qos_profile_sensor_data)
        publishers = [*thrust.values(), velocity]
        assert spin_until(lambda: all(p.get_subscription_count() > 0 for p in publishers), 10.0)

        # Feed the trial in stamp order, each message handled before the next (the velocity QoS keeps only 5).
        direct = LiveIdentifier(order=ORDER)
        for topic, payload in trial_inputs():
            if topic in thrust:
                index = messages.COMMAND_TOPICS.index(topic)
                thrust[topic].publish(Float64(data=payload))
                direct.set_command(index, payload)
                assert spin_until(lambda i=index, v=payload: node.ident.commands[i] == v, 2.0)
            else:
                before = node.ident.core.n_samples
                velocity.publish(velocity_msg(*payload))
                direct.on_velocity(payload[0] * 1e-9, payload[1], payload[2])
                assert spin_until(lambda n=before: node.ident.core.n_samples > n, 2.0)
        assert node.ident.core.n_samples == direct.core.n_samples

        # Publications after the feed (2.5 s: at least two 1 Hz ticks, the last one surely after the last sample)
        # carry the identified model: the same numbers as the direct replay.
        published = len(coefficients)
        spin_until(lambda: False, 2.5)
        assert len(coefficients) >= published + 2 and diagnostics
        labels, expected = direct.coefficients()
        out = coefficients[-1]
        assert out.layout.dim[0].label.split(",") == labels == [
            "c0_N_per_mps0", "c1_N_per_mps1", "c2_N_per_mps2", "effective_mass_kg"]
        assert out.layout.dim[0].size == len(out.data) == ORDER + 2
        np.testing.assert_allclose(out.data, expected, rtol=1e-9, atol=1e-9)
        assert all(math.isfinite(x) for x in out.data)
        status = diagnostics[-1].status[0]
        assert status.name == "boat_twin: thrust-speed identification"
        assert status.level == DiagnosticStatus.OK and status.message == "identified"
        values = {kv.key: json.loads(kv.value) for kv in status.values}
        assert values["steady_points"] == len(LEVELS_N) - 1 and values["rejected_segments"] == 0
        np.testing.assert_allclose(values["coefficients"], out.data[:-1], rtol=1e-9, atol=1e-9)

        def call(service: str) -> Trigger.Response:
            client = probe.create_client(Trigger, f"/identifier/{service}")
            assert client.wait_for_service(timeout_sec=5.0)
            future = client.call_async(Trigger.Request())
            executor.spin_until_future_complete(future, timeout_sec=5.0)
            assert future.done()
            return future.result()

        saved = call("save")
        assert saved.success and saved.message == str(model_path)
        params = load_params(model_path)
        np.testing.assert_allclose(params.resistance.coefficients, out.data[:-1], rtol=1e-9, atol=1e-9)
        assert params.mass_kg * (1.0 + params.surge_added_mass_ratio) == pytest.approx(out.data[-1])

        assert call("reset").success
        assert spin_until(lambda: all(math.isnan(x) for x in coefficients[-1].data), 3.0)
        assert spin_until(lambda: diagnostics[-1].status[0].level == DiagnosticStatus.WARN, 3.0)
        assert diagnostics[-1].status[0].message == "waiting for steady points"
        model_path.unlink()
        refused = call("save")
        assert not refused.success and refused.message == "not enough steady points yet"
        assert not model_path.exists()
    finally:
        rclpy.try_shutdown()
