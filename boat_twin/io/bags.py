"""rosbag2 (MCAP or sqlite3 storage) and bare MCAP: write the twin's messages, read any trial into a Trial.

Writing goes through the rosbags writer (rosbag2 metadata version 8, as ROS 2 Jazzy writes) into the scratch
directory of an :class:`~boat_twin.files.OutputClaim` next to the target, renamed into place when complete: an
interrupted run leaves nothing half-written, and two runs cannot write one bag at once.
Reading streams messages in log-time order and keeps only the few numbers each role needs.
"""

from __future__ import annotations

import math
import tempfile
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.rosbag2.enums import CompressionFormat, CompressionMode

from boat_twin.errors import InputError
from boat_twin.files import OutputClaim, check_trial_path
from boat_twin.frames import quaternion_yaw_rad
from boat_twin.io.mcap_crc import check_chunk_crcs, fill_chunk_crcs
from boat_twin.io.messages import TOPIC_ODOM_TRUTH, TOPIC_WIND, TOPICS, TS, topic_type
from boat_twin.io.roles import ACTUATOR_TOPIC, COMMAND_ROLES, ONE_THRUSTER_NOTE, actuator_slots
from boat_twin.io.trial import Stream, Trial, build_trial, empty_second_thruster

ROLE_TOPICS = {
    "thrust_left": "thrusters/left/thrust",
    "thrust_right": "thrusters/right/thrust",
    "angle_left": "thrusters/left/pos",
    "angle_right": "thrusters/right/pos",
    "gnss_fix": "gnss/fix",
    "gnss_vel": "gnss/vel",
    "imu": "imu/data",
    "wind": TOPIC_WIND,
}
"""Trial role → the package's relative topic name (its type is in :data:`boat_twin.io.messages.TOPICS`)."""

STORAGES = {"mcap": StoragePlugin.MCAP, "sqlite3": StoragePlugin.SQLITE3}
"""Storage plugins for ``--storage``."""

Message = tuple[str, int, Any]
"""(relative topic, log time in ns, rosbags message object)."""


def write_bag(path: Path, messages: Iterable[Message], storage: str = "mcap", force: bool = False) -> int:
    """Write ``messages`` (time-ordered) to a rosbag2 directory, or to a bare MCAP file if ``path`` ends in .mcap.

    Returns the number of messages written. Refuses an existing ``path`` unless ``force``.
    """
    if storage not in STORAGES:
        raise InputError(f"unknown storage {storage!r} (choose mcap or sqlite3)")
    bare = path.suffix == ".mcap"
    if bare and storage != "mcap":
        raise InputError(f"{path}: a bare .mcap file needs --storage mcap")
    count = 0
    with OutputClaim(path, force, "bag") as claim:
        bag_dir = claim.scratch / (path.stem if bare else path.name)
        writer = Writer(bag_dir, version=8, storage_plugin=STORAGES[storage])
        if storage == "mcap":
            writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
        with writer:
            connections: dict[str, Any] = {}
            for topic, stamp_ns, msg in messages:
                conn = connections.get(topic)
                if conn is None:
                    conn = writer.add_connection("/" + topic, topic_type(topic), typestore=TS)
                    connections[topic] = conn
                writer.write(conn, stamp_ns, TS.serialize_cdr(msg, topic_type(topic)))
                count += 1
        for mcap_file in bag_dir.glob("*.mcap"):
            fill_chunk_crcs(mcap_file)
        claim.commit(bag_dir / f"{bag_dir.name}.mcap" if bare else bag_dir)
    return count


def _stamp_s(msg: Any) -> float:
    return msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9


def _fix(msg: Any, log_s: float) -> tuple[float, float, float, float] | None:
    if msg.status.status < 0:  # STATUS_NO_FIX
        return None
    return _stamp_s(msg), msg.latitude, msg.longitude, msg.altitude


def _yaw(q: Any) -> float:
    """ENU yaw of a quaternion (REP-103), rad."""
    return float(quaternion_yaw_rad(q.x, q.y, q.z, q.w))


def _vel(msg: Any, log_s: float) -> tuple[float, float, float]:
    twist = msg.twist.twist if hasattr(msg.twist, "twist") else msg.twist  # TwistWithCovarianceStamped
    if hasattr(msg, "pose"):  # nav_msgs/Odometry: the twist is in the child (body) frame; rotate it by the pose's yaw
        yaw = _yaw(msg.pose.pose.orientation)
        u, v = twist.linear.x, twist.linear.y
        return _stamp_s(msg), u * math.cos(yaw) - v * math.sin(yaw), u * math.sin(yaw) + v * math.cos(yaw)
    return _stamp_s(msg), twist.linear.x, twist.linear.y


def _provided(covariance: Any) -> bool:
    """REP-145 / sensor_msgs/Imu: a covariance whose first element is −1 marks the field as not provided."""
    return float(covariance[0]) != -1.0


def _imu(msg: Any, log_s: float) -> tuple[float, float, float, float, float]:
    yaw = _yaw(msg.orientation)
    if not _provided(msg.orientation_covariance):
        yaw = math.nan
    rate = msg.angular_velocity.z if _provided(msg.angular_velocity_covariance) else math.nan
    accel = msg.linear_acceleration
    ax, ay = (accel.x, accel.y) if _provided(msg.linear_acceleration_covariance) else (math.nan, math.nan)
    return _stamp_s(msg), yaw, rate, ax, ay


def _scalar(msg: Any, log_s: float) -> tuple[float, float]:
    return log_s, msg.data


def _wind(msg: Any, _log_s: float) -> tuple[float, ...]:
    """A Vector3Stamped true wind: stamp, east, north (m/s)."""
    return _stamp_s(msg), float(msg.vector.x), float(msg.vector.y)


EXTRACTORS: dict[str, Callable[[Any, float], tuple[float, ...] | None]] = {
    "thrust_left": _scalar,
    "thrust_right": _scalar,
    "angle_left": _scalar,
    "angle_right": _scalar,
    "gnss_fix": _fix,
    "gnss_vel": _vel,
    "imu": _imu,
    "wind": _wind,
}
"""Role → function pulling one row (stamp in s, values...) out of one message: header stamp for sensors, log
time for commands (std_msgs/Float64 has no header)."""

ROLE_WIDTHS = {"thrust_left": 1, "thrust_right": 1, "angle_left": 1, "angle_right": 1, "gnss_fix": 3,
               "gnss_vel": 2, "imu": 4, "wind": 2}
"""Role → number of values per row after the stamp (the columns of its :class:`Stream`)."""

BLOCK_ROWS = 4096
"""Rows gathered as Python floats before they are packed into the float64 array (bounds the per-object cost)."""
MAX_PREALLOCATED_ROWS = 1 << 24
"""At most this many rows are reserved up front from a bag's message count (a corrupt count reserves no more)."""


class RowCollector:
    """Rows of ``1 + width`` floats (stamp, values) written into one float64 array, :data:`BLOCK_ROWS` at a time.

    Holds 8 bytes per number, not a Python object per sample. ``capacity`` (the topic's message count in the
    bag, when known) sizes the array up front; it grows if more rows arrive.
    """

    def __init__(self, width: int, capacity: int = 0) -> None:
        self.width = width
        self._rows = np.empty((min(max(capacity, BLOCK_ROWS), MAX_PREALLOCATED_ROWS), 1 + width))
        self._count = 0
        self._pending: list[float] = []

    def append(self, row: tuple[float, ...]) -> None:
        """Add one row (stamp, ``width`` values)."""
        self._pending.extend(row)
        if len(self._pending) >= BLOCK_ROWS * (1 + self.width):
            self._flush()

    def _flush(self) -> None:
        block = np.array(self._pending, dtype=float).reshape(-1, 1 + self.width)
        self._pending = []
        end = self._count + block.shape[0]
        if end > self._rows.shape[0]:
            grown = np.empty((max(end, 2 * self._rows.shape[0]), 1 + self.width))
            grown[: self._count] = self._rows[: self._count]
            self._rows = grown
        self._rows[self._count : end] = block
        self._count = end

    def stream(self) -> Stream:
        """The rows so far as a :class:`Stream`: float64 views, stamps (n,) and values (n, width)."""
        self._flush()
        rows = self._rows[: self._count]
        return Stream(rows[:, 0], rows[:, 1:])


ROLE_TYPES = {
    "gnss_fix": ("sensor_msgs/msg/NavSatFix",),
    "gnss_vel": ("geometry_msgs/msg/TwistStamped", "geometry_msgs/msg/TwistWithCovarianceStamped"),
    "imu": ("sensor_msgs/msg/Imu",),
}
"""Sensor role → message types it reads (the first is what the twin writes); a role whose default name is absent
is found by type when exactly one topic of its types is in the bag. gnss_vel is an ENU velocity over ground
(as nmea_navsat_driver's ``/vel`` and ``/fix_velocity``)."""


FALLBACK_TYPES = {"gnss_vel": ("nav_msgs/msg/Odometry",)}
"""Sensor role → types read only when no topic of its :data:`ROLE_TYPES` is in the bag: an odometry (its twist in
the body frame, rotated to ENU by its pose's yaw; its header frame taken as ENU-aligned) as the velocity when it is
the bag's only velocity. The twin's own ground truth (``odom/truth``) is never taken for a measurement."""


NAMED_ONLY_TYPES = {"wind": ("geometry_msgs/msg/Vector3Stamped",)}
"""Roles read only from a topic found by name (never the one topic of a type: a UM7's ``imu/rpy`` is a
Vector3Stamped too) → their types. ``wind``: the true wind over ground, vector x east, y north, m/s (the air's
velocity, where it blows to), header stamp."""


def _types(role: str) -> tuple[str, ...]:
    if role in NAMED_ONLY_TYPES:
        return NAMED_ONLY_TYPES[role]
    return ROLE_TYPES.get(role, (TOPICS[ROLE_TOPICS[role]],)) + FALLBACK_TYPES.get(role, ())


def holdings(available: dict[str, str]) -> str:
    """What a bag holds, for an error: ``topic (type), ...`` sorted by topic."""
    return ", ".join(f"{topic} ({msgtype})" for topic, msgtype in sorted(available.items())) or "no topics"


def resolve_topics(available: dict[str, str], remap: dict[str, str], namespace: str, source: str,
                   order: Sequence[str] = ()) -> tuple[dict[str, str], list[str]]:
    """Role → topic in the bag, and how each role not found by name was chosen (in words).

    ``remap`` first, else ``namespace`` + the default name, else a unique topic ending in the default name (a
    namespaced recording), else, for a sensor role, the one topic whose type the role reads (:data:`ROLE_TYPES`;
    e.g. nmea_navsat_driver's ``/fix`` and ``/vel``, an IMU driver's ``/imu/data``). Checks each found topic's
    type. No GNSS stream at all is an error that lists what the bag holds. ``order``: the boat file's actuator
    names in its order (:func:`~boat_twin.io.roles.actuator_slots`)."""
    chosen: dict[str, str] = {}
    for role, name in ROLE_TOPICS.items():
        if role in remap:
            topic = remap[role] if remap[role].startswith("/") else "/" + remap[role]
            if topic not in available:
                raise InputError(f"{source}: remapped topic {topic} for '{role}' is not in the bag; it holds: "
                                 f"{holdings(available)}")
        else:
            topic = f"{namespace.rstrip('/')}/{name}" if namespace else "/" + name
            if topic not in available:
                ends = [t for t in available if t.endswith("/" + name)]
                if len(ends) != 1:
                    continue
                topic = ends[0]
        if available[topic] not in _types(role):
            if role in NAMED_ONLY_TYPES and role not in remap:  # someone else's topic of that name: not ours
                continue
            raise InputError(f"{source}: topic {topic} has type {available[topic]}, expected "
                             f"{' or '.join(_types(role))}")
        chosen[role] = topic
    notes = _actuator_topics(available, chosen, namespace, order)
    for role in ROLE_TYPES:
        if role in chosen:
            continue
        taken = set(chosen.values()) | {"/" + TOPIC_ODOM_TRUTH}
        candidates = sorted(t for t, msgtype in available.items() if msgtype in ROLE_TYPES[role] and t not in taken)
        fallback = not candidates and role in FALLBACK_TYPES
        if fallback:
            candidates = sorted(t for t, msgtype in available.items()
                                if msgtype in FALLBACK_TYPES[role] and t not in taken)
        if len(candidates) == 1:
            chosen[role] = candidates[0]
            notes.append(f"{role} read from {candidates[0]} ({available[candidates[0]]}), the bag's only topic of "
                         "that type" + (" and its only velocity (body-frame twist rotated to ENU by the pose's yaw)"
                                        if fallback else ""))
        elif len(candidates) > 1:
            notes.append(f"{role}: several candidate topics ({', '.join(candidates)}); choose one with "
                         f"--topic {role}=TOPIC")
    if "gnss_fix" not in chosen and "gnss_vel" not in chosen:
        hint = "; ".join(n for n in notes if "several" in n)
        raise InputError(f"{source}: no GNSS fix (NavSatFix) or velocity (TwistStamped) topic found"
                         + (f" ({hint})" if hint else "") + f"; the bag holds: {holdings(available)}; "
                         "name them with --topic gnss_fix=TOPIC / gnss_vel=TOPIC")
    return chosen, notes


def _actuator_topics(available: dict[str, str], chosen: dict[str, str], namespace: str,
                     order: Sequence[str]) -> list[str]:
    """Command roles taken from a boat file's per-actuator topics (``thrusters/<name>/thrust|cmd|pos``,
    ``rudders/<name>/angle``; :func:`~boat_twin.io.messages.command_topics`) where the slot topics are absent:
    thrusters in the boat file's order (``order``; without it in name order), rudders before steered thrusters.
    Adds them to ``chosen``; returns a note per role so read."""
    if any(role in chosen for role in COMMAND_ROLES):
        return []
    prefix = "/" + namespace.strip("/") + "/" if namespace.strip("/") else "/"
    found = sorted(t[len(prefix):] for t, msgtype in available.items()
                   if t.startswith(prefix) and msgtype == "std_msgs/msg/Float64"
                   and ACTUATOR_TOPIC.match(t[len(prefix):]))
    notes = []
    pairs = actuator_slots(found, order)
    for role, topic in pairs:
        chosen[role] = prefix + topic
        notes.append(f"{role} read from {prefix + topic} (a boat file's actuator topic, slots in "
                     + ("the boat file's order)" if order else "name order)"))
    if [role for role, _ in pairs if role.startswith("thrust")] == ["thrust_left"]:
        notes.append(ONE_THRUSTER_NOTE)
    return notes


@contextmanager
def _rosbag2_alias(path: Path) -> Iterator[Path]:
    """``path``, or for a rosbag2 directory named ``*.bag`` a symlink to it without the suffix: rosbags'
    AnyReader takes any ``.bag`` path for a ROS 1 bag file."""
    if not (path.is_dir() and path.suffix == ".bag"):
        yield path
        return
    with tempfile.TemporaryDirectory(prefix="boat_twin_bag_") as tmp:
        alias = Path(tmp) / path.stem
        alias.symlink_to(path.resolve(), target_is_directory=True)
        yield alias


def read_trial(
    path: Path,
    remap: dict[str, str] | None = None,
    namespace: str = "",
    origin: tuple[float, float, float] | None = None,
    order: Sequence[str] = (),
) -> Trial:
    """Read a rosbag2 directory (MCAP or sqlite3) or a bare .mcap file into a :class:`Trial`, streaming; ``order``:
    the boat file's actuator names in its order, which fill the command slots (:func:`actuator_slots`)."""
    source = str(path)
    if not path.exists():
        raise InputError(f"{source}: no such bag")
    check_trial_path(path)
    unknown = sorted(set(remap or {}) - set(ROLE_TOPICS))
    if unknown:
        raise InputError(f"--topic: unknown role '{unknown[0]}' (roles: {', '.join(ROLE_TOPICS)})")
    try:
        with _rosbag2_alias(path) as readable, AnyReader([readable], default_typestore=TS) as reader:
            available = {c.topic: c.msgtype for c in reader.connections}
            topics, notes = resolve_topics(available, remap or {}, namespace, source, order)
            if not any(role in topics for role in COMMAND_ROLES):
                raise InputError(f"{source}: no command topic (thrusters/*/thrust or pos, std_msgs/Float64) found; "
                                 f"the bag holds: {holdings(available)}; name them with --topic thrust_left=TOPIC")
            role_of = {topic: role for role, topic in topics.items()}
            wanted = [c for c in reader.connections if c.topic in role_of]
            counts = {role: sum(c.msgcount for c in wanted if role_of[c.topic] == role) for role in topics}
            rows = {role: RowCollector(ROLE_WIDTHS[role], counts[role]) for role in topics}
            for conn, log_ns, raw in reader.messages(connections=wanted):
                role = role_of[conn.topic]
                row = EXTRACTORS[role](reader.deserialize(raw, conn.msgtype), log_ns * 1e-9)
                if row is not None:
                    rows[role].append(row)
    except InputError:
        raise
    except Exception as err:  # rosbags raises several types for corrupt or truncated files
        for mcap_file in [path] if path.is_file() else sorted(path.glob("*.mcap")):
            check_chunk_crcs(mcap_file)  # names the corrupt chunk's byte offset
        reason = " ".join(str(err).split())  # rosbags' YAML errors span several lines
        raise InputError(f"{source}: cannot read bag ({type(err).__name__}: {reason})") from None
    streams = {role: rows.pop(role).stream() for role in topics}
    if ONE_THRUSTER_NOTE in notes and "thrust_left" in streams:  # a boat file's single thruster: no second slot
        empty_second_thruster(streams)
    trial = build_trial(streams, source, topics, origin, release=True)
    trial.metadata.stream_choices += notes
    return trial
