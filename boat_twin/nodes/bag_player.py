"""ROS 2 node ``bag_player``: plays a recorded trial onto the package's topics at a rate factor, publishing /clock
(``ros2 bag play`` is not installable from wheels). Thin wiring only: the messages come from
boat_twin.io.playback.

Plays any trial the readers accept: a rosbag2 directory (MCAP or sqlite3), a bare .mcap, a ROS 1 .bag, a MAVLink
log (.tlog, .BIN) with a calibration, a CSV table with a column mapping. Topics (relative, so a namespace
applies): the commands on the boat's actuator topics (std_msgs/Float64: thrusters/{left,right}/thrust and pos, or
with a config_file whose vessel has a propulsion section its own thrusters/<name>/thrust|cmd|pos and
rudders/<name>/angle), gnss/fix (NavSatFix), gnss/vel (TwistStamped), imu/data (Imu), wind (Vector3Stamped, where
the trial measured it), all reliable (system default QoS), and /clock. Header stamps and /clock run
from ``start_time_s`` + trial time; other nodes follow with use_sim_time:=true. Exits when the trial ends.

Parameters (read at start-up)
  trial (string, required)      the recording
  rate (double, 1.0)            trial seconds per wall-clock second (at most 100)
  topics (string, "")           remaps as ROLE=TOPIC,... (the --topic of the command line; roles thrust_left,
                                thrust_right, angle_left, angle_right, gnss_fix, gnss_vel, imu)
  namespace (string, "")        namespace the recording's topics were recorded under
  calibration (string, "")      MAVLink logs: PWM → N / rad calibration YAML
  columns (string, "")          CSV trials: QUANTITY=COLUMN,... or a YAML mapping
  config_file (string, "")      twin YAML whose sensors' noise fills the covariances and whose boat's actuators
                                name the command topics (empty: built-in)
  start_time_s (double, 1.0)    stamp of the trial's t = 0, s (0 would read as "no clock yet")
  wait_for_subscriber_s (double, 10.0)  wall time to wait for a subscriber on gnss/vel before playing
  frame_prefix (string, "")     prepended to every frame id (several boats: boat1/)
"""

from __future__ import annotations

import time
from pathlib import Path

from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rosgraph_msgs.msg import Clock as ClockMsg

from boat_twin.config import TwinConfig, load_config
from boat_twin.io import messages
from boat_twin.io.playback import playback_messages, playback_topics
from boat_twin.io.sources import read_trial_file
from boat_twin.nodes import conventions, parameters
from boat_twin.nodes.spin import run_node

TICK_S = 0.002
"""Wall time between two publishing rounds, s: at 10x, messages go out within 0.02 s of trial time of their stamp
(a subscriber that stamps a command on arrival, by /clock, sees its time that close)."""
MAX_RATE = 100.0
"""Upper bound of ``rate``."""


class BagPlayerNode(Node):
    """Publishes a trial's messages when the played clock passes their stamps; /clock after each round."""

    def __init__(self) -> None:
        super().__init__("bag_player")
        trial_path = parameters.string(self, "trial", "", "recording to play")
        self.rate = parameters.double(self, "rate", 1.0, "trial seconds per wall second", above=0.0,
                                      maximum=MAX_RATE)
        remap = conventions.topic_remap(parameters.string(self, "topics", "", "ROLE=TOPIC,... remaps"))
        namespace = parameters.string(self, "namespace", "", "namespace of the recorded topics")
        calibration = parameters.string(self, "calibration", "", "MAVLink calibration YAML")
        columns = parameters.string(self, "columns", "", "CSV column mapping")
        config_file = parameters.string(self, "config_file", "", "twin YAML for the covariances")
        self.start_s = parameters.double(self, "start_time_s", 1.0, "stamp of the trial's start, s", above=0.0)
        self.wait_s = parameters.double(self, "wait_for_subscriber_s", 10.0, "wait for a subscriber, s")
        self.frame_prefix = conventions.frame_prefix(self)
        if not trial_path:
            from boat_twin.errors import InputError

            raise InputError("parameter trial: give the recording to play (-p trial:=PATH)")
        config = load_config(Path(config_file)) if config_file else TwinConfig()
        trial = read_trial_file(Path(trial_path), remap=remap, namespace=namespace,
                                calibration=calibration or None, columns=columns or None,
                                order=messages.actuator_order(config.vessel.propulsion))
        self.duration_s = float(trial.t_s[-1])
        self.messages = playback_messages(trial, config, self.start_s)
        self.pending = next(self.messages, None)
        self.publishers_by_topic = {}
        for topic, kind in playback_topics(config).items():  # the boat file's actuator topics, the wind
            self.publishers_by_topic[topic] = self.create_publisher(conventions.message_class(kind), topic,
                                                                    QoSProfile(depth=100))
        self.clock_pub = self.create_publisher(ClockMsg, "/clock", QoSProfile(depth=1))
        self.started_wall: float | None = None
        self.created_wall = time.monotonic()
        self.done = False
        self.create_timer(TICK_S, self.on_tick, clock=Clock(clock_type=ClockType.STEADY_TIME))
        conventions.use_sim_time(self)
        self.get_logger().info(f"playing {trial.metadata.source}: {self.duration_s:.0f} s at {self.rate:g}x "
                               f"({trial.metadata.summary_line()})")

    def on_tick(self) -> None:
        now = time.monotonic()
        if self.started_wall is None:
            waited = now - self.created_wall
            if self.count_subscribers(messages.TOPIC_GNSS_VEL) == 0 and waited < self.wait_s:
                return
            self.started_wall = now
        played_ns = int(round((self.start_s + (now - self.started_wall) * self.rate) * 1e9))
        clock_ns = -1
        while self.pending is not None and self.pending[1] <= played_ns:
            topic, stamp_ns, msg = self.pending
            if self.frame_prefix:
                ((topic, stamp_ns, msg),) = messages.restamped([self.pending], stamp_ns, self.frame_prefix)
            if stamp_ns != clock_ns:  # the clock reaches each stamp before its messages go out
                self.clock_pub.publish(ClockMsg(clock=conventions.ros_time(stamp_ns)))
                clock_ns = stamp_ns
            self.publishers_by_topic[topic].publish(messages.serialize(msg, messages.topic_type(topic)))
            self.pending = next(self.messages, None)
        self.clock_pub.publish(ClockMsg(clock=conventions.ros_time(played_ns)))
        if self.pending is None:
            self.get_logger().info(f"trial played to its end ({self.duration_s:.0f} s)")
            self.done = True


def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run boat_twin bag_player``."""
    return run_node("bag_player", BagPlayerNode, args)
