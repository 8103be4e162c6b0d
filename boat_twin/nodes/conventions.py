"""What every boat_twin node does the same way: command QoS, frame prefixes, the clock (use_sim_time), topic
remaps, message classes and stamps.

- Commands are subscribed best effort: a best-effort subscription matches reliable and best-effort publishers
  alike (a reliable one refuses best-effort publishers: "incompatible QoS", and the boat would not move). On
  one machine nothing is lost in practice, and the ``player`` re-sends held commands four times a second.
- ``frame_prefix`` (string, default empty) is prepended to every frame id a node stamps, so that several boats
  share a graph: ``-r __ns:=/boat1 -p frame_prefix:=boat1/`` gives ``boat1/base_link``, ``boat1/gnss_link``...
- ``use_sim_time`` is read at start-up only: a change at run time is refused with the reason (rclpy would
  switch the clock under running timers, and a simulator that publishes ``/clock`` would wait on itself).
  A node on simulated time that has heard no ``/clock`` after :data:`CLOCK_WAIT_S` says so once.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from functools import partial
from typing import TYPE_CHECKING, Any

from builtin_interfaces.msg import Time
from rcl_interfaces.msg import SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

from boat_twin.errors import InputError
from boat_twin.nodes import parameters

if TYPE_CHECKING:
    from boat_twin.vessel.actuators import Propulsion
    from boat_twin.view.stream import TwinView

COMMAND_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
"""Thruster command subscriptions: best effort, so that both reliable and best-effort publishers connect."""
CLOCK_WAIT_S = 5.0
"""Wall time a node on simulated time waits for its first /clock before it warns, s: a simulator needs 2-4 s
to start on a loaded 2-core machine (tests/test_node_*.py), so 5 s is a silent start-up, not a slow one."""


def subscribe_commands(node: Node, propulsion: Propulsion | None, callback: Callable[[int, Any], None]) -> list[str]:
    """Subscribe ``node`` to the command topics of a boat (:func:`~boat_twin.io.messages.command_topics`: the
    default layout's, or a boat file's per-name ``thrusters/<name>/thrust|cmd|pos`` and ``rudders/<name>/angle``),
    std_msgs/Float64 at :data:`COMMAND_QOS`; ``callback(column, msg)`` with the command's column (thrust left,
    right, angle left, right). Returns the topics subscribed."""
    from std_msgs.msg import Float64

    from boat_twin.io.messages import command_topics
    from boat_twin.io.roles import COMMAND_ROLES

    topics = command_topics(propulsion)
    for index, role in enumerate(COMMAND_ROLES):
        if role in topics:
            node.create_subscription(Float64, topics[role], partial(callback, index), COMMAND_QOS)
    return [topics[role] for role in COMMAND_ROLES if role in topics]


def topic_remap(text: str) -> dict[str, str]:
    """The ``topics`` parameter (``ROLE=TOPIC,ROLE=TOPIC``) as a role → topic map; a bad item is refused naming
    the parameter."""
    from boat_twin.cli.options import parse_remap

    return parse_remap([item for item in text.split(",") if item.strip()], source="parameter topics:")


def message_class(msgtype: str) -> type | None:
    """The rclpy message class of a ROS type name (``sensor_msgs/msg/Imu``); None if its package is absent."""
    package, _, name = msgtype.split("/")
    try:
        return getattr(importlib.import_module(f"{package}.msg"), name)
    except ImportError:
        return None


def ros_time(stamp_ns: int) -> Time:
    """builtin_interfaces/Time (rclpy) from integer nanoseconds."""
    sec, nanosec = divmod(stamp_ns, 1_000_000_000)
    return Time(sec=sec, nanosec=nanosec)


def steady_clock() -> Clock:
    """The wall clock, for timers that must run whatever the node clock does (no /clock yet)."""
    return Clock(clock_type=ClockType.STEADY_TIME)


def frame_prefix(node: Node) -> str:
    """Declare and check the ``frame_prefix`` parameter (tf2 frame ids never start with '/')."""
    prefix = parameters.string(node, "frame_prefix", "", "prepended to every frame id (several boats: boat1/)")
    if prefix.startswith("/") or prefix != prefix.strip():
        raise InputError(f"parameter frame_prefix: a tf2 frame id starts with neither '/' nor a space, got {prefix!r}")
    return prefix


def use_sim_time(node: Node) -> bool:
    """Whether the node runs on /clock; refuse later changes of ``use_sim_time``; warn once if no /clock comes.

    Call at the end of the node's constructor (the refusal runs before rclpy's own handler)."""
    def refuse(params: list[Parameter]) -> SetParametersResult:
        if any(p.name == "use_sim_time" and p.value != simulated for p in params):  # the same value is no change
            return SetParametersResult(successful=False, reason=(
                "use_sim_time is read at start-up only: restart the node with -p use_sim_time:=true|false"))
        return SetParametersResult(successful=True)

    simulated = bool(node.get_parameter("use_sim_time").value)
    node.add_on_set_parameters_callback(refuse)
    if simulated:
        timer = None

        def check() -> None:
            if timer is not None:
                timer.cancel()
            if node.get_clock().now().nanoseconds == 0:
                node.get_logger().warning(
                    f"use_sim_time is true and no /clock has arrived in {CLOCK_WAIT_S:.0f} s: nothing runs until "
                    "one is published (the simulator with publish_clock:=true, ros2 bag play --clock)")

        timer = node.create_timer(CLOCK_WAIT_S, check, clock=steady_clock())
    return simulated


def foxglove_view(node: Node, hull_m: tuple[float, float], innovation_channels: tuple[str, ...] = ()
                  ) -> TwinView | None:
    """The ``foxglove`` parameter (string, "": off; HOST:PORT, HOST or :PORT, loopback by default) and
    ``foxglove_allow_remote`` (bool, false): a live Foxglove view of what the node shows (boat_twin.view), its
    address logged; None when off. A bad address or a missing foxglove-sdk: one line, exit 2.
    ``innovation_channels``: opened at the start (a shadow twin's, :class:`~boat_twin.view.stream.TwinView`)."""
    text = parameters.string(node, "foxglove", "", "serve a live Foxglove view on HOST:PORT (empty: off)")
    allow_remote = parameters.boolean(node, "foxglove_allow_remote", False, "allow a non-loopback foxglove host")
    if not text:
        return None
    from boat_twin.view.address import parse_address, require_sdk
    from boat_twin.view.stream import TwinView

    address = parse_address(text, "foxglove", allow_remote, "foxglove_allow_remote:=true")
    require_sdk("the foxglove parameter")
    view = TwinView(address, hull_m=hull_m, name=node.get_name(), innovation_channels=innovation_channels)
    node.get_logger().info(f"foxglove: live view on {view.url}")
    return view
