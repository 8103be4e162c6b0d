"""ROS 2 node ``simulator``: the live twin at 10 Hz. Thin wiring only — all physics is in boat_twin.twin.live.

Subscribes: thrusters/{left,right}/thrust (std_msgs/Float64, N), thrusters/{left,right}/pos (rad).
Publishes every topic of boat_twin.io.messages.TOPICS that the twin produces (GNSS, UM7 IMU, odom/truth, and tf
when tf2_msgs is installed), as the same CDR bytes a bag holds, with the system-default (reliable) QoS so that
every subscriber connects (REP-2003). Each tick's messages are stamped with the node clock at that tick.

Parameters (read at start-up)
  config_file (string, "")      twin YAML (empty: the built-in seed boat)
  seed (int, 0), noise (bool, true)   sensor noise
  publish_clock (bool, false)   run on the simulator's own clock, from 0, and publish it on /clock: other nodes
                                then run with use_sim_time:=true, as with Gazebo
  real_time_factor (double, 1.0)   simulated seconds per wall-clock second with publish_clock (at most 100; the
                                clock slows down rather than skip ticks when the machine cannot keep up)
  mavlink_url (string, "")      also run the twin as a MAVLink boat (boat_twin.link.mavlink_boat), e.g.
                                udpout:127.0.0.1:14550; mavlink_allow_remote (bool, false) for a non-loopback address
"""

from __future__ import annotations

import importlib
from functools import partial
from pathlib import Path

from builtin_interfaces.msg import Time
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import QoSProfile
from rosgraph_msgs.msg import Clock as ClockMsg
from std_msgs.msg import Float64

from boat_twin.config import TwinConfig, load_config
from boat_twin.errors import InputError
from boat_twin.io import messages
from boat_twin.link.mavlink_boat import MavlinkBoat
from boat_twin.nodes import parameters
from boat_twin.nodes.spin import run_node
from boat_twin.twin.live import LiveTwin
from boat_twin.vessel.simulate import OUTPUT_RATE_HZ

MAX_REAL_TIME_FACTOR = 100.0
"""Upper bound of real_time_factor: 1,000 ticks per wall second is already beyond what one core publishes."""
TICK_NS = round(1e9 / OUTPUT_RATE_HZ)
"""Simulated time of one tick, ns."""


def message_class(msgtype: str) -> type | None:
    """The rclpy message class of a ROS type name (``sensor_msgs/msg/Imu``); None if its package is absent."""
    package, _, name = msgtype.split("/")
    try:
        return getattr(importlib.import_module(f"{package}.msg"), name)
    except ImportError:
        return None


class SimulatorNode(Node):
    """Feeds thruster commands into a LiveTwin and publishes what each tick returns."""

    def __init__(self) -> None:
        super().__init__("simulator")
        config_file = parameters.string(self, "config_file", "", "twin configuration YAML (empty: built-in boat)")
        seed = parameters.integer(self, "seed", 0, "seed of the sensor noise", minimum=0, maximum=2**63 - 1)
        noise = parameters.boolean(self, "noise", True, "false: exact measurements")
        self.publish_clock = parameters.boolean(
            self, "publish_clock", False, "run on the simulator's own clock from 0 and publish /clock")
        factor = parameters.double(self, "real_time_factor", 1.0, "simulated s per wall s with publish_clock",
                                   above=0.0, maximum=MAX_REAL_TIME_FACTOR)
        mavlink_url = parameters.string(self, "mavlink_url", "", "serve the twin over MAVLink (empty: off)")
        allow_remote = parameters.boolean(self, "mavlink_allow_remote", False, "allow a non-loopback MAVLink peer")
        if self.publish_clock and self.get_parameter("use_sim_time").value:
            raise InputError("simulator: publish_clock and use_sim_time exclude each other (it is the clock)")
        config = load_config(Path(config_file)) if config_file else TwinConfig()
        self.twin = LiveTwin(config, seed=seed, noise=noise)
        self.link = MavlinkBoat(self.twin, mavlink_url, allow_remote=allow_remote) if mavlink_url else None
        self.publishers_by_topic = self._sensor_publishers()
        commands = self.link if self.link is not None else self.twin
        for index, topic in enumerate(messages.COMMAND_TOPICS):
            self.create_subscription(Float64, topic, partial(self.on_command, commands, index), 10)
        self.clock_pub: Publisher | None = None
        period_s = 1.0 / OUTPUT_RATE_HZ
        if self.publish_clock:
            self.clock_pub = self.create_publisher(ClockMsg, "/clock", QoSProfile(depth=1))
            self.create_timer(period_s / factor, self.on_tick, clock=Clock(clock_type=ClockType.STEADY_TIME))
        else:
            self.create_timer(period_s, self.on_tick)

    @staticmethod
    def on_command(commands: LiveTwin | MavlinkBoat, index: int, msg: Float64) -> None:
        """A thruster command (N or rad) into the twin, or into the MAVLink link that arbitrates it."""
        commands.set_command(index, msg.data)

    def _sensor_publishers(self) -> dict[str, Publisher]:
        """One reliable publisher per twin output topic; tf only where tf2_msgs is installed (one warning)."""
        publishers = {}
        for topic, msgtype in messages.TOPICS.items():
            if topic in messages.COMMAND_TOPICS:
                continue
            cls = message_class(msgtype)
            if cls is None:
                self.get_logger().warning(f"{msgtype} is not installed: topic '{topic}' is not published")
                continue
            publishers[topic] = self.create_publisher(cls, topic, QoSProfile(depth=10))
        return publishers

    def _stamp_ns(self) -> int:
        """This tick's stamp: the simulated clock (publish_clock) or the node clock (wall or /clock time)."""
        if self.publish_clock:
            return self.twin.tick_index * TICK_NS  # the twin's nominal time, from 0
        return self.get_clock().now().nanoseconds

    def on_tick(self) -> None:
        """One twin tick: publish its sensor and truth messages (commands are inputs only), then /clock.

        The tick samples the sensors at its start and integrates one period under the held commands; /clock
        then says the time the simulation has reached, from which the next commands act. A driver that answers
        /clock before the next tick therefore acts at the time it read, as a bag records it. Commands arriving
        between ticks act from the next tick (on the wall clock: 0-100 ms later, a 10 Hz actuator update).
        """
        stamp_ns = self._stamp_ns()
        tick = self.link.step(1) if self.link is not None else self.twin.tick()
        for topic, _stamp_ns, msg in messages.restamped(tick, stamp_ns):
            publisher = self.publishers_by_topic.get(topic)
            if publisher is not None:
                publisher.publish(messages.serialize(msg, messages.TOPICS[topic]))
        if self.clock_pub is not None:
            self.clock_pub.publish(ClockMsg(clock=_time(stamp_ns + TICK_NS)))

    def destroy_node(self) -> None:
        """Close the MAVLink link (socket) with the node."""
        if self.link is not None:
            self.link.close()
        super().destroy_node()


def _time(stamp_ns: int) -> Time:
    """builtin_interfaces/Time (rclpy) from integer nanoseconds."""
    sec, nanosec = divmod(stamp_ns, 1_000_000_000)
    return Time(sec=sec, nanosec=nanosec)


def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run boat_twin simulator``."""
    return run_node("simulator", SimulatorNode, args)
