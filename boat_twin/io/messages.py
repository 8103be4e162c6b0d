"""ROS 2 Jazzy messages built with the rosbags typestore: one table of topics, one builder per message type.

Bags and live topics carry the same objects: :func:`serialize` gives the CDR bytes the bag writer stores and
the nodes publish raw with rclpy, so both are byte-identical. Topic names are relative (a namespace applies);
the bag writer prefixes ``/``. Builders of stamped messages take a :func:`header`; the series iterators share
one header among the messages of one sample (as the UM7 driver does) and constant arrays (covariances) among
all messages: treat messages as read-only. Iterators yield ``(topic, stamp_ns, message)`` in time order;
merge several with ``heapq.merge(..., key=lambda item: item[1])``.

Frames (REP-103/REP-105): ``map`` is the local ENU frame at the GNSS geodetic origin, ``base_link`` the FLU
body, ``gnss_link`` the antenna (its velocity topic carries ENU components, as nmea_navsat_driver publishes
them), ``imu_link`` the UM7 (coincides with ``base_link``).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np
from rosbags.typesys import Stores, get_typestore

from boat_twin.frames import quaternion_xyzw
from boat_twin.io.roles import ACTUATOR_TOPIC, COMMAND_ROLES
from boat_twin.sensors.gnss import GnssMeasurements
from boat_twin.sensors.um7 import ImuMeasurements
from boat_twin.vessel.actuators import Propulsion
from boat_twin.vessel.truth import TruthSeries

TOPIC_THRUST_LEFT = "thrusters/left/thrust"
TOPIC_THRUST_RIGHT = "thrusters/right/thrust"
TOPIC_ANGLE_LEFT = "thrusters/left/pos"
TOPIC_ANGLE_RIGHT = "thrusters/right/pos"
TOPIC_GNSS_FIX = "gnss/fix"
TOPIC_GNSS_VEL = "gnss/vel"
TOPIC_IMU_DATA = "imu/data"
TOPIC_IMU_MAG = "imu/mag"
TOPIC_IMU_RPY = "imu/rpy"
TOPIC_IMU_TEMPERATURE = "imu/temperature"
TOPIC_ODOM_TRUTH = "odom/truth"
TOPIC_TF = "tf"
TOPIC_TF_STATIC = "tf_static"
TOPIC_GNSS_VEL_COV = "gnss/vel_cov"

TOPICS: dict[str, str] = {
    TOPIC_THRUST_LEFT: "std_msgs/msg/Float64",  # N, per outboard (VRX thruster convention)
    TOPIC_THRUST_RIGHT: "std_msgs/msg/Float64",
    TOPIC_ANGLE_LEFT: "std_msgs/msg/Float64",  # rad, outboard steering angle
    TOPIC_ANGLE_RIGHT: "std_msgs/msg/Float64",
    TOPIC_GNSS_FIX: "sensor_msgs/msg/NavSatFix",
    TOPIC_GNSS_VEL: "geometry_msgs/msg/TwistStamped",
    TOPIC_IMU_DATA: "sensor_msgs/msg/Imu",
    TOPIC_IMU_MAG: "sensor_msgs/msg/MagneticField",
    TOPIC_IMU_RPY: "geometry_msgs/msg/Vector3Stamped",
    TOPIC_IMU_TEMPERATURE: "std_msgs/msg/Float32",
    TOPIC_ODOM_TRUTH: "nav_msgs/msg/Odometry",
    TOPIC_TF: "tf2_msgs/msg/TFMessage",
}
"""Every topic boat_twin writes or reads (relative name -> ROS 2 message type)."""

LIVE_TOPICS: dict[str, str] = {
    TOPIC_GNSS_VEL_COV: "geometry_msgs/msg/TwistWithCovarianceStamped",  # gnss/vel with covariance, for an ekf
    TOPIC_TF_STATIC: "tf2_msgs/msg/TFMessage",  # base_link -> gnss_link, imu_link
}
"""Topics only the simulator node publishes (never in a bag the twin writes)."""

COMMAND_TOPICS = (TOPIC_THRUST_LEFT, TOPIC_THRUST_RIGHT, TOPIC_ANGLE_LEFT, TOPIC_ANGLE_RIGHT)
"""The default layout's command topics in the column order of a commands array (n, 4)."""


def command_topics(propulsion: Propulsion | None) -> dict[str, str]:
    """Command role → its topic, for the roles the boat has: the package's :data:`COMMAND_TOPICS` for the default
    layout (None); for a boat file's propulsion section its actuators' own (the VRX convention), a thruster's
    ``thrusters/<name>/thrust`` (N) or ``.../cmd`` (its table's unit, rev/s), a steering input's
    ``rudders/<name>/angle`` or, for a steered thruster, ``thrusters/<name>/pos`` (rad)."""
    if propulsion is None:
        return dict(zip(COMMAND_ROLES, COMMAND_TOPICS, strict=True))
    topics = {}
    for j, (thrust_role, angle_role) in enumerate((COMMAND_ROLES[0::2], COMMAND_ROLES[1::2])):
        if j < len(propulsion.thrusters):
            topics[thrust_role] = propulsion.thrusters[j].command_topic
        steering = propulsion.steering_input(j)
        if steering == "rudder":
            topics[angle_role] = f"rudders/{propulsion.rudders[j].name}/angle"
        elif steering == "thruster":
            topics[angle_role] = f"thrusters/{propulsion.thrusters[j].name}/pos"
    return topics


def actuator_order(propulsion: Propulsion | None) -> tuple[str, ...]:
    """The boat file's actuator names in its own order (thrusters, then rudders): the order its per-actuator
    command topics fill the slots (:func:`~boat_twin.io.roles.actuator_slots`); empty for the default layout."""
    if propulsion is None:
        return ()
    return tuple(t.name for t in propulsion.thrusters) + tuple(r.name for r in propulsion.rudders)


TOPIC_WIND = "wind"
"""The true wind over ground an anemometer measures: geometry_msgs/Vector3Stamped in the ENU world frame, m/s
(x east, y north: the air's velocity, where it blows to). Written by the simulator when its environment has a
wind; read as the ``wind`` role."""


def topic_type(topic: str) -> str:
    """The message type of one of the package's topics (relative name), an actuator's command included."""
    if topic in TOPICS:
        return TOPICS[topic]
    if topic == TOPIC_WIND:
        return "geometry_msgs/msg/Vector3Stamped"
    if ACTUATOR_TOPIC.match(topic):
        return "std_msgs/msg/Float64"
    raise KeyError(topic)

FRAME_MAP = "map"
FRAME_BASE = "base_link"
FRAME_GNSS = "gnss_link"
FRAME_IMU = "imu_link"

TS = get_typestore(Stores.ROS2_JAZZY)
"""The one typestore (ROS 2 Jazzy message definitions) used to build, serialize and read messages."""

_Time = TS.types["builtin_interfaces/msg/Time"]
_Header = TS.types["std_msgs/msg/Header"]
_Float32 = TS.types["std_msgs/msg/Float32"]
_Float64 = TS.types["std_msgs/msg/Float64"]
_Vector3 = TS.types["geometry_msgs/msg/Vector3"]
_Point = TS.types["geometry_msgs/msg/Point"]
_Quaternion = TS.types["geometry_msgs/msg/Quaternion"]
_Pose = TS.types["geometry_msgs/msg/Pose"]
_PoseWithCovariance = TS.types["geometry_msgs/msg/PoseWithCovariance"]
_Twist = TS.types["geometry_msgs/msg/Twist"]
_TwistWithCovariance = TS.types["geometry_msgs/msg/TwistWithCovariance"]
_TwistStamped = TS.types["geometry_msgs/msg/TwistStamped"]
_TwistWithCovarianceStamped = TS.types["geometry_msgs/msg/TwistWithCovarianceStamped"]
_Vector3Stamped = TS.types["geometry_msgs/msg/Vector3Stamped"]
_Transform = TS.types["geometry_msgs/msg/Transform"]
_TransformStamped = TS.types["geometry_msgs/msg/TransformStamped"]
_NavSatStatus: Any = TS.types["sensor_msgs/msg/NavSatStatus"]  # Any: its constants are class attributes
_NavSatFix: Any = TS.types["sensor_msgs/msg/NavSatFix"]
_Imu = TS.types["sensor_msgs/msg/Imu"]
_MagneticField = TS.types["sensor_msgs/msg/MagneticField"]
_Odometry = TS.types["nav_msgs/msg/Odometry"]
_TFMessage = TS.types["tf2_msgs/msg/TFMessage"]

_ZERO_COV6 = np.zeros(36)
_ZERO_COV6.flags.writeable = False
_GNSS_STATUS = _NavSatStatus(
    status=_NavSatStatus.STATUS_FIX, service=_NavSatStatus.SERVICE_GPS | _NavSatStatus.SERVICE_GLONASS
)

Message = Any
"""A rosbags message object (a dataclass of the typestore)."""

MESSAGE_BLOCK_ROWS = 1000
"""Samples turned into Python numbers at a time by the series iterators: bounds their memory, not their output."""


def stamps_ns(t_s: np.ndarray) -> np.ndarray:
    """Seconds (float) to integer nanoseconds, rounded to the nearest ns (int64)."""
    return np.rint(np.asarray(t_s, dtype=float) * 1e9).astype(np.int64)


def time_msg(stamp_ns: int) -> Message:
    """builtin_interfaces/Time from integer nanoseconds, exact (sec = floor(ns / 1e9))."""
    sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
    return _Time(sec=sec, nanosec=nanosec)


def header(stamp_ns: int, frame_id: str) -> Message:
    """std_msgs/Header."""
    return _Header(stamp=time_msg(stamp_ns), frame_id=frame_id)


def diagonal_covariance(diagonal: Sequence[float] | np.ndarray) -> np.ndarray:
    """A read-only row-major 3x3 covariance (9,) with ``diagonal`` on its diagonal (safe to share)."""
    cov = np.zeros(9)
    cov[[0, 4, 8]] = diagonal
    cov.flags.writeable = False
    return cov


def navsatfix(header_msg: Message, lat_deg: float, lon_deg: float, alt_m: float,
              position_covariance_m2: np.ndarray) -> Message:
    """sensor_msgs/NavSatFix: GPS+GLONASS fix, ENU covariance (9,) row-major, type DIAGONAL_KNOWN."""
    return _NavSatFix(
        header=header_msg,
        status=_GNSS_STATUS,
        latitude=lat_deg,
        longitude=lon_deg,
        altitude=alt_m,
        position_covariance=position_covariance_m2,
        position_covariance_type=_NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN,
    )


def twist_stamped(header_msg: Message, linear: Sequence[float], angular: Sequence[float] = (0.0, 0.0, 0.0)
                  ) -> Message:
    """geometry_msgs/TwistStamped (for ``gnss/vel``: linear = ENU velocity over ground, m/s)."""
    return _TwistStamped(
        header=header_msg,
        twist=_Twist(
            linear=_Vector3(x=linear[0], y=linear[1], z=linear[2]),
            angular=_Vector3(x=angular[0], y=angular[1], z=angular[2]),
        ),
    )


UNMEASURED_VARIANCE = 1e6
"""Variance given to what a sensor does not measure (the GNSS's angular velocity), in its unit squared: large,
so that a filter fusing it by mistake trusts it no more than nothing."""


def velocity_with_covariance(velocity: Message, frame_id: str, variances: Sequence[float]) -> Message:
    """``gnss/vel_cov``: the ``gnss/vel`` message as geometry_msgs/TwistWithCovarianceStamped for a filter.

    Same stamp and ENU components, in ``frame_id`` (the ENU world frame, so that robot_localization rotates it
    into base_link through tf; docs/ros.md), with ``variances`` (east, north, up, (m/s)^2) on the linear
    diagonal and :data:`UNMEASURED_VARIANCE` on the angular one (a GNSS does not measure rotation).
    """
    covariance = np.zeros(36)
    covariance[[0, 7, 14]] = variances
    covariance[[21, 28, 35]] = UNMEASURED_VARIANCE
    return _TwistWithCovarianceStamped(
        header=_Header(stamp=velocity.header.stamp, frame_id=frame_id),
        twist=_TwistWithCovariance(twist=velocity.twist, covariance=covariance),
    )


def imu(header_msg: Message, orientation_xyzw: Sequence[float], angular_velocity_radps: Sequence[float],
        linear_acceleration_mps2: Sequence[float], orientation_covariance: np.ndarray,
        angular_velocity_covariance: np.ndarray, linear_acceleration_covariance: np.ndarray) -> Message:
    """sensor_msgs/Imu (REP-145): FLU body in ENU, gravity included; covariances (9,) row-major."""
    q = orientation_xyzw
    w = angular_velocity_radps
    a = linear_acceleration_mps2
    return _Imu(
        header=header_msg,
        orientation=_Quaternion(x=q[0], y=q[1], z=q[2], w=q[3]),
        orientation_covariance=orientation_covariance,
        angular_velocity=_Vector3(x=w[0], y=w[1], z=w[2]),
        angular_velocity_covariance=angular_velocity_covariance,
        linear_acceleration=_Vector3(x=a[0], y=a[1], z=a[2]),
        linear_acceleration_covariance=linear_acceleration_covariance,
    )


def magnetic_field(header_msg: Message, field_tesla: Sequence[float], covariance: np.ndarray) -> Message:
    """sensor_msgs/MagneticField: field in tesla in the sensor frame, covariance (9,) row-major."""
    return _MagneticField(
        header=header_msg,
        magnetic_field=_Vector3(x=field_tesla[0], y=field_tesla[1], z=field_tesla[2]),
        magnetic_field_covariance=covariance,
    )


def vector3_stamped(header_msg: Message, vector: Sequence[float]) -> Message:
    """geometry_msgs/Vector3Stamped (``imu/rpy``: radians, UM7 driver layout)."""
    return _Vector3Stamped(header=header_msg, vector=_Vector3(x=vector[0], y=vector[1], z=vector[2]))


def float32(value: float) -> Message:
    """std_msgs/Float32."""
    return _Float32(data=value)


def float64(value: float) -> Message:
    """std_msgs/Float64."""
    return _Float64(data=value)


def odometry(header_msg: Message, east_m: float, north_m: float, orientation_xyzw: Sequence[float],
             body_velocity_mps: Sequence[float], yaw_rate_radps: float,
             child_frame_id: str = FRAME_BASE) -> Message:
    """nav_msgs/Odometry of the truth: pose in the header's frame (ENU ``map``), twist over ground in
    ``child_frame_id`` (FLU). Covariances are zero: this is ground truth."""
    q = orientation_xyzw
    return _Odometry(
        header=header_msg,
        child_frame_id=child_frame_id,
        pose=_PoseWithCovariance(
            pose=_Pose(position=_Point(x=east_m, y=north_m, z=0.0),
                       orientation=_Quaternion(x=q[0], y=q[1], z=q[2], w=q[3])),
            covariance=_ZERO_COV6,
        ),
        twist=_TwistWithCovariance(
            twist=_Twist(linear=_Vector3(x=body_velocity_mps[0], y=body_velocity_mps[1], z=0.0),
                         angular=_Vector3(x=0.0, y=0.0, z=yaw_rate_radps)),
            covariance=_ZERO_COV6,
        ),
    )


def tf_message(header_msg: Message, east_m: float, north_m: float, orientation_xyzw: Sequence[float],
               child_frame_id: str = FRAME_BASE) -> Message:
    """tf2_msgs/TFMessage with one transform, header frame (``map``) -> ``child_frame_id`` (the true pose)."""
    q = orientation_xyzw
    return _TFMessage(transforms=[_TransformStamped(
        header=header_msg,
        child_frame_id=child_frame_id,
        transform=_Transform(translation=_Vector3(x=east_m, y=north_m, z=0.0),
                             rotation=_Quaternion(x=q[0], y=q[1], z=q[2], w=q[3])),
    )])


def static_transforms(stamp_ns: int, antenna_height_m: float, frame_prefix: str = "") -> Message:
    """tf2_msgs/TFMessage for ``tf_static``: base_link -> gnss_link (the antenna ``antenna_height_m`` straight
    up) and base_link -> imu_link (coincident), frame ids with ``frame_prefix`` prepended."""
    base = header(stamp_ns, frame_prefix + FRAME_BASE)
    identity = _Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)
    return _TFMessage(transforms=[
        _TransformStamped(header=base, child_frame_id=frame_prefix + child,
                          transform=_Transform(translation=_Vector3(x=0.0, y=0.0, z=height), rotation=identity))
        for child, height in ((FRAME_GNSS, antenna_height_m), (FRAME_IMU, 0.0))])


def restamped(items: Sequence[tuple[str, int, Message]], stamp_ns: int, frame_prefix: str = ""
              ) -> list[tuple[str, int, Message]]:
    """The same messages stamped ``stamp_ns`` (headers and tf transforms replaced, the rest shared), every frame
    id (headers, child frames) with ``frame_prefix`` prepended (several boats on one graph: ``boat1/``).

    A live node stamps what a tick publishes with its clock at that tick, while the sensor models run on the
    tick's nominal time; messages without a header (Float32/64) keep only the new log stamp.
    """
    stamps: dict[int, Message] = {}

    def new_header(old: Message) -> Message:
        if id(old) not in stamps:
            stamps[id(old)] = header(stamp_ns, frame_prefix + old.frame_id)
        return stamps[id(old)]

    out = []
    for topic, _old_ns, msg in items:
        if hasattr(msg, "header"):
            msg = replace(msg, header=new_header(msg.header))
            if frame_prefix and hasattr(msg, "child_frame_id"):
                msg = replace(msg, child_frame_id=frame_prefix + msg.child_frame_id)
        elif hasattr(msg, "transforms"):
            msg = replace(msg, transforms=[
                replace(t, header=new_header(t.header), child_frame_id=frame_prefix + t.child_frame_id)
                for t in msg.transforms])
        out.append((topic, stamp_ns, msg))
    return out


def serialize(message: Message, msgtype: str) -> bytes:
    """CDR (little-endian) bytes of ``message``: what a bag stores and rclpy publishes raw."""
    return bytes(TS.serialize_cdr(message, msgtype))


def deserialize(data: bytes | memoryview, msgtype: str) -> Message:
    """A message object from its CDR bytes."""
    return TS.deserialize_cdr(data, msgtype)


def _diagonal_covariances(diagonals: np.ndarray) -> np.ndarray:
    """(n, 3) diagonals to (n, 9) row-major 3x3 covariances."""
    cov = np.zeros((diagonals.shape[0], 9))
    cov[:, [0, 4, 8]] = diagonals
    return cov


def _blocks(n: int) -> Iterator[slice]:
    """Consecutive row slices of at most :data:`MESSAGE_BLOCK_ROWS` covering ``range(n)``."""
    for start in range(0, n, MESSAGE_BLOCK_ROWS):
        yield slice(start, min(start + MESSAGE_BLOCK_ROWS, n))


def gnss_messages(gnss: GnssMeasurements) -> Iterator[tuple[str, int, Message]]:
    """``gnss/fix`` and ``gnss/vel`` per fix, time-ordered."""
    stamp_s, lat, lon, alt, vel_east, vel_north, vel_up = (np.asarray(a) for a in (
        gnss.stamp_s, gnss.lat_deg, gnss.lon_deg, gnss.alt_m, gnss.vel_east_mps, gnss.vel_north_mps,
        gnss.vel_up_mps))
    variances = np.asarray(gnss.position_covariance_m2, dtype=float)
    for rows in _blocks(stamp_s.size):
        covariances = _diagonal_covariances(variances[rows])
        covariances.flags.writeable = False
        velocities = np.column_stack([vel_east[rows], vel_north[rows], vel_up[rows]]).tolist()
        block = zip(stamps_ns(stamp_s[rows]).tolist(), lat[rows].tolist(), lon[rows].tolist(), alt[rows].tolist(),
                    covariances, velocities, strict=True)
        for stamp_ns, lat_deg, lon_deg, alt_m, cov, vel in block:
            shared = header(stamp_ns, FRAME_GNSS)
            yield TOPIC_GNSS_FIX, stamp_ns, navsatfix(shared, lat_deg, lon_deg, alt_m, cov)
            yield TOPIC_GNSS_VEL, stamp_ns, twist_stamped(shared, vel)


def imu_messages(imu_series: ImuMeasurements) -> Iterator[tuple[str, int, Message]]:
    """``imu/data``, ``imu/mag``, ``imu/rpy`` and ``imu/temperature`` per sample, time-ordered."""
    orientation_cov = diagonal_covariance(imu_series.orientation_covariance_rad2)
    gyro_cov = diagonal_covariance(imu_series.gyro_covariance_radps2)
    accel_cov = diagonal_covariance(imu_series.accel_covariance_mps2_2)
    mag_cov = diagonal_covariance(imu_series.mag_covariance_tesla2)
    series = [np.asarray(a) for a in (
        imu_series.quaternion_xyzw, imu_series.gyro_radps, imu_series.accel_mps2, imu_series.mag_tesla,
        imu_series.rpy_rad, imu_series.temperature_celsius)]
    stamp_s = np.asarray(imu_series.stamp_s)
    for rows in _blocks(stamp_s.size):
        block = zip(stamps_ns(stamp_s[rows]).tolist(), *(a[rows].tolist() for a in series), strict=True)
        for stamp_ns, q, w, a, m, rpy, temperature in block:
            shared = header(stamp_ns, FRAME_IMU)  # one header for the three, as the driver does
            yield TOPIC_IMU_DATA, stamp_ns, imu(shared, q, w, a, orientation_cov, gyro_cov, accel_cov)
            yield TOPIC_IMU_MAG, stamp_ns, magnetic_field(shared, m, mag_cov)
            yield TOPIC_IMU_RPY, stamp_ns, vector3_stamped(shared, rpy)
            yield TOPIC_IMU_TEMPERATURE, stamp_ns, float32(temperature)


def truth_messages(truth: TruthSeries, with_tf: bool = True) -> Iterator[tuple[str, int, Message]]:
    """``odom/truth`` (and ``tf`` map -> base_link unless ``with_tf`` is False) per truth sample, in order."""
    t_s, east, north, vel_east, vel_north, yaw_rate = (np.asarray(a) for a in (
        truth.t_s, truth.east_m, truth.north_m, truth.vel_east_mps, truth.vel_north_mps, truth.yaw_rate_radps))
    yaw_rad = np.asarray(truth.yaw_rad, dtype=float)
    for rows in _blocks(t_s.size):
        yaw = yaw_rad[rows]
        zeros = np.zeros_like(yaw)
        cos_yaw, sin_yaw = np.cos(yaw), np.sin(yaw)
        body_velocity = np.column_stack([
            cos_yaw * vel_east[rows] + sin_yaw * vel_north[rows],
            -sin_yaw * vel_east[rows] + cos_yaw * vel_north[rows],
        ]).tolist()
        block = zip(stamps_ns(t_s[rows]).tolist(), east[rows].tolist(), north[rows].tolist(),
                    quaternion_xyzw(zeros, zeros, yaw).tolist(), body_velocity, yaw_rate[rows].tolist(), strict=True)
        for stamp_ns, east_m, north_m, q, v, r in block:
            shared = header(stamp_ns, FRAME_MAP)
            yield TOPIC_ODOM_TRUTH, stamp_ns, odometry(shared, east_m, north_m, q, v, r)
            if with_tf:
                yield TOPIC_TF, stamp_ns, tf_message(shared, east_m, north_m, q)


def command_messages(t_s: np.ndarray, commands: np.ndarray, topics: Mapping[str, str] | None = None
                     ) -> Iterator[tuple[str, int, Message]]:
    """The thruster topics per command sample; ``commands`` (n, 4) columns: thrust left/right (N, or the
    thruster's own unit), steering angle left/right (rad), in the order of :data:`COMMAND_TOPICS`. ``topics``:
    command role → topic of the roles a boat has (:func:`command_topics`; a role it
    lacks is not written); None: the four :data:`COMMAND_TOPICS`."""
    names = COMMAND_TOPICS if topics is None else tuple(topics.get(role, "") for role in COMMAND_ROLES)
    values = np.asarray(commands, dtype=float)
    if values.ndim != 2 or values.shape[1] != 4 or values.shape[0] != np.size(t_s):
        raise ValueError(f"commands must have shape ({np.size(t_s)}, 4), got {values.shape}")
    stamp_s = np.asarray(t_s)
    for rows in _blocks(values.shape[0]):
        for stamp_ns, row in zip(stamps_ns(stamp_s[rows]).tolist(), values[rows].tolist(), strict=True):
            for topic, value in zip(names, row, strict=True):
                if topic:
                    yield topic, stamp_ns, float64(value)


WIND_MESSAGE_PERIOD_S = 1.0
"""The simulated anemometer's message period, s (1 Hz: a wind sensor's usual NMEA MWV rate)."""


def wind_messages(t_s: np.ndarray, east_mps: float, north_mps: float) -> Iterator[tuple[str, int, Message]]:
    """The true wind (ENU, m/s, where the air goes) at the times ``t_s``, on :data:`TOPIC_WIND`."""
    for stamp_ns in stamps_ns(np.asarray(t_s)).tolist():
        yield TOPIC_WIND, stamp_ns, vector3_stamped(header(stamp_ns, FRAME_MAP), (east_mps, north_mps, 0.0))
