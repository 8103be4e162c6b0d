"""ROS 2 node ``simulator``: the live twin at 10 Hz. Thin wiring only — all physics is in boat_twin.live.

Subscribes: thrusters/{left,right}/thrust (std_msgs/Float64, N), thrusters/{left,right}/pos (rad).
Publishes: every topic of boat_twin.io.messages.TOPICS that the twin produces (GNSS, UM7 IMU, odom/truth, tf),
as the same CDR bytes a bag holds. Parameters: config_file (twin YAML), seed, noise; mavlink_url (empty: off,
e.g. udpout:127.0.0.1:14550) also runs the twin as a MAVLink boat (boat_twin.io.mavlink_link), with
mavlink_allow_remote for a non-loopback address.
"""

from __future__ import annotations

from pathlib import Path

from rclpy.node import Node
from rclpy.qos import QoSProfile, qos_profile_sensor_data
from rosidl_runtime_py.utilities import get_message
from std_msgs.msg import Float64

from boat_twin.config import TwinConfig, load_config
from boat_twin.io import messages
from boat_twin.io.mavlink_link import MavlinkBoat
from boat_twin.live import LiveTwin
from boat_twin.nodes.spin import run_node
from boat_twin.vessel.simulate import OUTPUT_RATE_HZ

SENSOR_TOPICS = ("gnss/fix", "gnss/vel", "imu/data", "imu/mag", "imu/rpy", "imu/temperature")


class SimulatorNode(Node):
    """Feeds thruster commands into a LiveTwin and publishes what each tick returns."""

    def __init__(self) -> None:
        super().__init__("simulator")
        config_file = self.declare_parameter("config_file", "").value
        seed = int(self.declare_parameter("seed", 0).value)
        noise = bool(self.declare_parameter("noise", True).value)
        config = load_config(Path(config_file)) if config_file else TwinConfig()
        epoch_s = self.get_clock().now().nanoseconds * 1e-9
        self.twin = LiveTwin(config, seed=seed, noise=noise, epoch_s=epoch_s)
        mavlink_url = str(self.declare_parameter("mavlink_url", "").value)
        allow_remote = bool(self.declare_parameter("mavlink_allow_remote", False).value)
        self.link = MavlinkBoat(self.twin, mavlink_url, allow_remote=allow_remote) if mavlink_url else None
        commands = self.link if self.link is not None else self.twin
        self.publishers_by_topic = {}
        for topic, msgtype in messages.TOPICS.items():
            if topic in messages.COMMAND_TOPICS:
                continue
            qos = qos_profile_sensor_data if topic in SENSOR_TOPICS else QoSProfile(depth=10)
            self.publishers_by_topic[topic] = self.create_publisher(get_message(msgtype), topic, qos)
        for index, topic in enumerate(messages.COMMAND_TOPICS):
            self.create_subscription(Float64, topic, lambda msg, i=index: commands.set_command(i, msg.data), 10)
        self.create_timer(1.0 / OUTPUT_RATE_HZ, self.on_tick)

    def on_tick(self) -> None:
        """One twin tick; publish its sensor and truth messages (commands are inputs, not re-published)."""
        for topic, _stamp_ns, msg in (self.link.step(1) if self.link is not None else self.twin.tick()):
            publisher = self.publishers_by_topic.get(topic)
            if publisher is not None:
                publisher.publish(messages.serialize(msg, messages.TOPICS[topic]))

    def destroy_node(self) -> None:
        """Close the MAVLink link (socket) with the node."""
        if self.link is not None:
            self.link.close()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run boat_twin simulator``."""
    return run_node("simulator", SimulatorNode, args)
