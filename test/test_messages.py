"""ROS 2 messages: contents, stamps, time order, and CDR bytes an independent decoder (mcap_ros2) reads."""

from __future__ import annotations

import io
import math
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.records import Schema
from mcap_ros2.decoder import DecoderFactory
from mcap_ros2.writer import Writer

from boat_twin.io import messages as m
from boat_twin.sensors.gnss import GnssConfig, GnssModel
from boat_twin.sensors.um7 import Um7Config, Um7Model
from boat_twin.units import STANDARD_GRAVITY_MPS2
from boat_twin.vessel.truth import TruthSeries

N = 50

NAVSATFIX_MSG = """\
std_msgs/Header header
sensor_msgs/NavSatStatus status
float64 latitude
float64 longitude
float64 altitude
float64[9] position_covariance
uint8 position_covariance_type
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
================================================================================
MSG: sensor_msgs/NavSatStatus
int8 status
uint16 service
"""
"""sensor_msgs/msg/NavSatFix as written in ROS 2 Jazzy's .msg files (comments and constants left out)."""


def northbound_truth(n: int = N) -> TruthSeries:
    """Heading north (ENU yaw pi/2) at 5 m/s, turning gently, from t = 1000 s (stamps with whole seconds)."""
    t_s = 1000.0 + np.arange(n) * 0.1
    zeros = np.zeros(n)
    return TruthSeries(
        t_s=t_s, east_m=zeros, north_m=5.0 * (t_s - t_s[0]), yaw_rad=np.full(n, math.pi / 2),
        vel_east_mps=zeros, vel_north_mps=np.full(n, 5.0), surge_mps=np.full(n, 5.0), sway_mps=zeros,
        yaw_rate_radps=np.full(n, 0.01), accel_x_mps2=zeros, accel_y_mps2=np.full(n, 0.05),
    )


def all_messages() -> list[tuple[str, int, Any]]:
    truth = northbound_truth()
    rng = np.random.default_rng(0)
    gnss = GnssModel(GnssConfig(), rng).measure(truth)
    imu = Um7Model(Um7Config(), rng).measure(truth)
    commands = np.column_stack([np.full(N, 120.0), np.full(N, 110.0), np.full(N, 0.1), np.full(N, -0.1)])
    return [
        *m.gnss_messages(gnss), *m.imu_messages(imu), *m.truth_messages(truth),
        *m.command_messages(truth.t_s, commands),
    ]


def one_of_each() -> dict[str, Any]:
    return {topic: msg for topic, _, msg in reversed(all_messages())}


def mcap_schema(msgtype: str, text: str | None = None) -> Schema:
    text = m.TS.generate_msgdef(msgtype, ros_version=2)[0] if text is None else text
    return Schema(id=1, name=msgtype, encoding="ros2msg", data=text.encode())


def assert_same(ours: Any, theirs: Any, path: str = "msg") -> None:
    """Field-by-field equality of a rosbags message and an mcap_ros2 decoded one (constants excluded)."""
    if hasattr(ours, "__msgtype__"):
        for name in ours.__dataclass_fields__:
            if name != "__msgtype__" and not name.isupper():
                assert_same(getattr(ours, name), getattr(theirs, name), f"{path}.{name}")
    elif isinstance(ours, list):
        assert len(ours) == len(theirs), path
        for i, (a, b) in enumerate(zip(ours, theirs, strict=True)):
            assert_same(a, b, f"{path}[{i}]")
    elif isinstance(ours, np.ndarray):
        np.testing.assert_array_equal(ours, np.asarray(theirs), err_msg=path)
    else:
        assert ours == theirs, f"{path}: {ours!r} != {theirs!r}"


def test_topic_table_is_relative_and_known_to_jazzy() -> None:
    for topic, msgtype in m.TOPICS.items():
        assert not topic.startswith("/") and topic == topic.strip()
        assert msgtype in m.TS.types
    assert set(one_of_each()) == set(m.TOPICS)
    assert m.TOPICS["imu/rpy"] == "geometry_msgs/msg/Vector3Stamped"
    assert m.TOPICS["imu/temperature"] == "std_msgs/msg/Float32"


@pytest.mark.parametrize("stamp_ns", [0, 1, 999_999_999, 1_000_000_000, 1_700_000_000_123_456_789])
def test_time_is_exact(stamp_ns: int) -> None:
    t = m.time_msg(stamp_ns)
    assert 0 <= t.nanosec < 1_000_000_000 and t.sec * 1_000_000_000 + t.nanosec == stamp_ns


def test_stamps_round_to_the_nanosecond() -> None:
    ns = m.stamps_ns(np.arange(36000) * 0.1)
    np.testing.assert_array_equal(ns, np.arange(36000, dtype=np.int64) * 100_000_000)


def test_series_are_time_ordered_and_headers_carry_the_stamp() -> None:
    messages = all_messages()
    counts: dict[str, int] = {}
    for topic, stamp_ns, msg in messages:
        counts[topic] = counts.get(topic, 0) + 1
        stamped = msg.transforms[0] if topic == "tf" else msg
        if hasattr(stamped, "header"):
            assert stamped.header.stamp.sec * 1_000_000_000 + stamped.header.stamp.nanosec == stamp_ns
    for source in ("gnss/", "imu/", "odom/", "thrusters/"):
        stamps = [s for topic, s, _ in messages if topic.startswith(source)]
        assert stamps == sorted(stamps)
    assert counts["imu/data"] == counts["imu/temperature"] == counts["odom/truth"] == counts["tf"] == N
    assert counts["thrusters/left/pos"] == N and counts["gnss/fix"] == counts["gnss/vel"] == N - 1  # latency


def test_navsatfix_contents() -> None:
    fix = one_of_each()["gnss/fix"]
    assert fix.header.frame_id == "gnss_link"
    assert fix.status.status == fix.status.STATUS_FIX
    assert fix.status.service == fix.status.SERVICE_GPS | fix.status.SERVICE_GLONASS
    assert fix.position_covariance_type == fix.COVARIANCE_TYPE_DIAGONAL_KNOWN
    sigma_h, sigma_v = GnssConfig().horizontal_stdev_m, GnssConfig().vertical_stdev_m
    expected = np.diag([sigma_h**2, sigma_h**2, sigma_v**2])
    np.testing.assert_allclose(fix.position_covariance.reshape(3, 3), expected)


def test_imu_messages_follow_rep145_and_the_um7_driver() -> None:
    msgs = one_of_each()
    data, mag, rpy = msgs["imu/data"], msgs["imu/mag"], msgs["imu/rpy"]
    assert data.header.frame_id == mag.header.frame_id == rpy.header.frame_id == "imu_link"
    assert abs(data.linear_acceleration.z - STANDARD_GRAVITY_MPS2) < 0.5  # +g on z, REP-145
    cfg = Um7Config()
    expected = {
        "orientation_covariance": np.array([cfg.roll_pitch_stdev_rad, cfg.roll_pitch_stdev_rad,
                                            cfg.yaw_stdev_rad]) ** 2,
        "angular_velocity_covariance": [cfg.gyro_stdev_radps**2] * 3,
        "linear_acceleration_covariance": [cfg.accel_stdev_mps2**2] * 3,
    }
    for name, diagonal in expected.items():
        np.testing.assert_allclose(getattr(data, name).reshape(3, 3), np.diag(diagonal))
    mag_covariance = mag.magnetic_field_covariance.reshape(3, 3)
    np.testing.assert_allclose(mag_covariance, np.diag([cfg.mag_stdev_tesla**2] * 3))
    assert 20e-6 < abs(mag.magnetic_field.z) < 60e-6  # tesla, not gauss or unit-norm
    assert abs(rpy.vector.z) < 0.3  # heading north: -NED yaw = 0 rad, as the driver's ENU mode publishes
    q = data.orientation
    assert math.isclose(q.x**2 + q.y**2 + q.z**2 + q.w**2, 1.0, rel_tol=1e-12)


def test_odometry_twist_is_in_the_body_frame() -> None:
    msgs = one_of_each()
    odom, tf = msgs["odom/truth"], msgs["tf"].transforms[0]
    assert (odom.header.frame_id, odom.child_frame_id) == ("map", "base_link")
    assert (tf.header.frame_id, tf.child_frame_id) == ("map", "base_link")
    assert odom.twist.twist.linear.x == pytest.approx(5.0) and abs(odom.twist.twist.linear.y) < 1e-12
    assert odom.twist.twist.angular.z == pytest.approx(0.01)
    q = odom.pose.pose.orientation
    assert (q.z, q.w) == pytest.approx((math.sin(math.pi / 4), math.cos(math.pi / 4)))
    assert tf.transform.rotation == q


def test_commands_go_to_the_four_thruster_topics_in_column_order() -> None:
    msgs = one_of_each()
    assert [msgs[topic].data for topic in m.COMMAND_TOPICS] == [120.0, 110.0, 0.1, -0.1]
    with pytest.raises(ValueError, match="shape"):
        list(m.command_messages(np.arange(3.0), np.zeros((3, 2))))


@pytest.mark.parametrize("topic", sorted(m.TOPICS))
def test_cdr_round_trip_with_rosbags_and_an_independent_decoder(topic: str) -> None:
    msgtype = m.TOPICS[topic]
    ours = one_of_each()[topic]
    data = m.serialize(ours, msgtype)
    assert isinstance(data, bytes)
    assert_same(ours, m.deserialize(data, msgtype))
    schema = mcap_schema(msgtype)
    decoded = DecoderFactory().decoder_for("cdr", schema)(data)
    assert_same(ours, decoded)
    # mcap_ros2's own encoder writes the decoded message back to the very same bytes
    buffer = io.BytesIO()
    writer = Writer(buffer)
    writer.write_message(topic, writer.register_msgdef(msgtype, schema.data.decode()), decoded, log_time=0)
    writer.finish()
    buffer.seek(0)
    (_, _, record), = list(make_reader(buffer).iter_messages())
    assert record.data == data


def test_navsatfix_decodes_with_the_definition_written_out_by_hand() -> None:
    ours = one_of_each()["gnss/fix"]
    decoded = DecoderFactory().decoder_for("cdr", mcap_schema("sensor_msgs/msg/NavSatFix", NAVSATFIX_MSG))(
        m.serialize(ours, "sensor_msgs/msg/NavSatFix"))
    assert_same(ours, decoded)


def test_restamped_replaces_every_header_and_tf_stamp_and_keeps_the_content() -> None:
    from boat_twin.config import TwinConfig
    from boat_twin.twin.live import LiveTwin

    twin = LiveTwin(TwinConfig(), noise=False)
    for _ in range(5):
        tick = twin.tick()
    stamp_ns = 1_795_000_000_123_456_789
    again = m.restamped(tick, stamp_ns)
    assert [t for t, _, _ in again] == [t for t, _, _ in tick]
    for (topic, old_ns, before), (_, new_ns, after) in zip(tick, again, strict=True):
        assert new_ns == stamp_ns and old_ns != stamp_ns
        headers = [t.header for t in getattr(after, "transforms", [])]
        headers += [after.header] if hasattr(after, "header") else []
        for h in headers:
            assert (h.stamp.sec, h.stamp.nanosec) == divmod(stamp_ns, 1_000_000_000)
        restored = m.deserialize(m.serialize(after, m.TOPICS[topic]), m.TOPICS[topic])
        if hasattr(before, "header"):
            assert restored.header.frame_id == before.header.frame_id
            restored.header = before.header
        elif hasattr(before, "transforms"):
            restored.transforms[0].header = before.transforms[0].header
        assert m.serialize(restored, m.TOPICS[topic]) == m.serialize(before, m.TOPICS[topic])
