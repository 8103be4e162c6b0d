"""ROS 2 node ``shadow``: the live twin following a real boat. Thin wiring only: the core is
boat_twin.shadow.session.Shadow (the one ``boat-twin follow`` runs).

Subscribes (found as the bag reader finds them, boat_twin.io.bags.resolve_topics, on the live graph: the
``topics`` remaps first, then the default names under ``namespace``, then a topic whose name ends in the default
one, then the one topic of the role's type): thrusters/{left,right}/thrust and pos (std_msgs/Float64, stamped
by the node clock on arrival), gnss/fix (NavSatFix), gnss/vel (TwistStamped, TwistWithCovarianceStamped, or
an Odometry when it is the only velocity), imu/data (Imu); sensors best effort (SensorDataQoS, 1,000 samples of
history), commands best effort (boat_twin.nodes.conventions.COMMAND_QOS). The graph is searched again every 2 s
until a GNSS stream is found.
Publishes: shadow/odom (nav_msgs/Odometry: the twin's predicted state, pose in ENU ``map`` about the first fix,
twist through the water in ``base_link``), shadow/innovations (std_msgs/Float64MultiArray per velocity fix:
layout label ``t_s,speed_innovation_mps,stdev_mps,ratio``), shadow/model (Float64MultiArray every wall second: label
``mass_kg,mass_low_kg,mass_high_kg,resistance_factor,factor_low,factor_high``, 95 % intervals), the same
quantities one std_msgs/Float64 topic each, readable and plottable by name (shadow/model/mass_kg, ...,
shadow/model/<turning coefficient>_low; shadow/innovation/speed_innovation_mps, stdev_mps, ratio) and
/diagnostics every wall second (the rolling diagnosis runs in a worker process meanwhile; OK: in step,
innovations within 1.5× their noise and no cause; WARN: not synchronised,
misfit, or the named causes with their sizes). Services: ~/save (the twin as it predicts, a twin.yaml, to
``twin_path``), ~/reset (back to the configured model). Works on the node clock (use_sim_time:=true with a
bag_player or simulator /clock).

Parameters (read at start-up)
  config_file (string, "")   twin YAML to start from (empty: the built-in boat)
  topics (string, "")        ROLE=TOPIC,... remaps; namespace (string, "")
  adapt (bool, true), diagnose (bool, true)   online adaptation, rolling diagnosis
  twin_path (string, "")     YAML written by ~/save; default $ROS_HOME/boat_twin/twin.yaml
  reorder_s (double, 0.3)    samples wait this long for late siblings, s of the node clock (a recording played
                             at N x on a busy machine: N x the executor's delays)
  foxglove (string, ""), foxglove_allow_remote (bool, false)   a live Foxglove view (boat_twin.view, the view
                             extra): HOST:PORT, HOST or :PORT, loopback by default; empty: off (docs/live-twin.md)
  frame_prefix (string, ""), hardware_id (string, namespace)   as every node (boat_twin.nodes.conventions,
                             boat_twin.nodes.diagnostics)
"""

from __future__ import annotations

import math
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
from nav_msgs.msg import Odometry
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Float64, Float64MultiArray, MultiArrayDimension
from std_srvs.srv import Trigger

from boat_twin.config import TwinConfig, load_config
from boat_twin.errors import InputError
from boat_twin.frames import quaternion_xyzw
from boat_twin.io.bags import EXTRACTORS, resolve_topics
from boat_twin.io.messages import FRAME_BASE, FRAME_MAP
from boat_twin.io.roles import COMMAND_ROLES
from boat_twin.nodes import conventions, parameters
from boat_twin.nodes.diagnostics import OK, WARN, Diagnostics, Status
from boat_twin.nodes.identifier import default_model_path
from boat_twin.nodes.spin import run_node
from boat_twin.shadow.session import Shadow, ShadowSettings
from boat_twin.shadow.sync import INNOVATION_CHANNELS, Innovation, SyncSettings
from boat_twin.shadow.turning import LIVE_KEYS
from boat_twin.view.observer import ShadowView

SENSOR_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.BEST_EFFORT)
"""SensorDataQoS with 100 s of a 10 Hz stream as history: a rolling diagnosis holds the executor for 2-3 s, which
a recording played at 10x fills with 30 s of samples."""
MODEL_LABEL = ",".join(["mass_kg,mass_low_kg,mass_high_kg,resistance_factor,factor_low,factor_high"]
                       + [f"{k},{k}_low,{k}_high" for k in LIVE_KEYS])
"""The ``shadow/model`` array: the surge model, then each live turning coefficient (SI) with its 95 % interval
(NaN while the twin turns with the configured ones)."""
INNOVATION_LABEL = "t_s,speed_innovation_mps,stdev_mps,ratio"
MODEL_TOPICS = tuple(f"shadow/model/{name}" for name in MODEL_LABEL.split(","))
"""The same quantities as ``shadow/model``, one std_msgs/Float64 topic each, named by the label (SI)."""
INNOVATION_TOPICS = tuple(f"shadow/innovation/{name}" for name in INNOVATION_LABEL.split(",")[1:])
"""``shadow/innovations`` but its stamp, one std_msgs/Float64 topic each."""


def _array(values: list[float], label: str) -> Float64MultiArray:
    out = Float64MultiArray(data=[float(v) for v in values])
    out.layout.dim = [MultiArrayDimension(label=label, size=len(values), stride=len(values))]
    return out


class ShadowNode(Node):
    """Wires a boat's topics into a Shadow and publishes what it predicts and finds."""

    def __init__(self) -> None:
        super().__init__("shadow")
        config_file = parameters.string(self, "config_file", "", "twin YAML to start from (empty: built-in)")
        topics = parameters.string(self, "topics", "", "ROLE=TOPIC,... remaps")
        self.namespace_ = parameters.string(self, "namespace", "", "namespace of the boat's topics")
        adapt = parameters.boolean(self, "adapt", True, "adapt the surge model online")
        diagnose = parameters.boolean(self, "diagnose", True, "run the rolling diagnosis")
        twin_path = parameters.string(self, "twin_path", "", "YAML written by ~/save")
        reorder_s = parameters.double(self, "reorder_s", SyncSettings().reorder_s,
                                      "samples wait this long (node clock) for late siblings, s", above=0.0)
        self.frame_prefix = conventions.frame_prefix(self)
        self.remap = conventions.topic_remap(topics)
        self.twin_path = Path(twin_path).expanduser() if twin_path else default_model_path().with_name("twin.yaml")
        config = load_config(Path(config_file)) if config_file else TwinConfig()
        self.view = conventions.foxglove_view(self, (config.vessel.length_m, config.vessel.beam_m),
                                              INNOVATION_CHANNELS)
        self.watch = ShadowView(self.view) if self.view is not None else None
        self.shadow = Shadow(config, ShadowSettings(SyncSettings(reorder_s=reorder_s), adapt=adapt, diagnose=diagnose,
                                                    diagnose_in_background=True), self.log_line)
        self.shadow.on_innovation = self.on_innovation
        if self.watch is not None:
            self.watch.attach(self.shadow)
        self.subscribed: dict[str, str] = {}
        self.odom_pub = self.create_publisher(Odometry, "shadow/odom", 10)
        self.innovation_pub = self.create_publisher(Float64MultiArray, "shadow/innovations", 10)
        self.model_pub = self.create_publisher(Float64MultiArray, "shadow/model", 10)
        self.model_pubs = [self.create_publisher(Float64, topic, 10) for topic in MODEL_TOPICS]
        self.innovation_pubs = [self.create_publisher(Float64, topic, 10) for topic in INNOVATION_TOPICS]
        self.diagnostics = Diagnostics(self)
        self.create_service(Trigger, "~/save", self.on_save)
        self.create_service(Trigger, "~/reset", self.on_reset)
        # wall-clock (steady) timers: with use_sim_time, a node clock stops with the player, and a diagnosis that
        # finishes then must still be taken and published
        self.create_timer(1.0, self.on_publish, clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.discovery = self.create_timer(2.0, self.discover)
        self.discover()
        conventions.use_sim_time(self)

    def discover(self) -> None:
        """Subscribe to the roles found on the graph (once a GNSS stream is there)."""
        own = {self.resolve_topic_name(t) for t in ("shadow/odom", "shadow/innovations", "shadow/model",
                                                     *MODEL_TOPICS, *INNOVATION_TOPICS)}
        available = {name: types[0] for name, types in self.get_topic_names_and_types() if types and name not in own}
        try:
            chosen, notes = resolve_topics(available, self.remap, self.namespace_, "ROS graph")
        except InputError:
            return
        for role, topic in chosen.items():
            if role in self.subscribed:
                continue
            cls = conventions.message_class(available[topic])
            if cls is None:
                continue
            qos = conventions.COMMAND_QOS if role in COMMAND_ROLES else SENSOR_QOS
            self.create_subscription(cls, topic, partial(self.on_message, role), qos)
            self.subscribed[role] = topic
            self.get_logger().info(f"{role}: subscribed to {topic} ({available[topic]})")
        for note in notes:
            self.get_logger().info(note)
        if "gnss_vel" in self.subscribed and "imu" in self.subscribed and "thrust_left" in self.subscribed:
            self.discovery.cancel()

    def log_line(self, line: str) -> None:
        """A line of the Shadow's log: to the node's log and the Foxglove view."""
        self.get_logger().info(line)
        if self.watch is not None:
            self.watch.log_line(line)

    def on_message(self, role: str, msg: Any) -> None:
        row = EXTRACTORS[role](msg, self.get_clock().now().nanoseconds * 1e-9)
        if row is not None:
            self.shadow.add(role, row[0], tuple(row[1:]))
            if self.watch is not None:
                self.watch.sample(role, row[0], tuple(row[1:]))

    def on_innovation(self, item: Innovation) -> None:
        if item.channel == "speed_mps":
            values = [item.t_s, item.value, item.stdev, self.shadow.speed_ratio()]
            self.innovation_pub.publish(_array(values, INNOVATION_LABEL))
            for publisher, value in zip(self.innovation_pubs, values[1:], strict=True):
                publisher.publish(Float64(data=float(value)))

    def on_publish(self) -> None:
        self.shadow.poll()
        self._publish_odometry()
        surge = self.shadow.adapter.current
        turning = self.shadow.turning.to_dict(self.shadow.twin.config.vessel)
        coefficients = [x for k in LIVE_KEYS
                        for x in (turning["coefficients"][k], *turning["ci95"].get(k, (math.nan, math.nan)))]
        values = [surge.mass_kg, *surge.mass_ci95_kg, surge.resistance_factor, *surge.factor_ci95, *coefficients]
        self.model_pub.publish(_array(values, MODEL_LABEL))
        for publisher, value in zip(self.model_pubs, values, strict=True):
            publisher.publish(Float64(data=float(value)))
        status = self.shadow.status()
        latest = self.shadow.rolling.latest
        causes = latest.causes if latest is not None else []
        ratio = status["speed_innovation_ratio"]
        if not status["synchronised"]:
            level, message = WARN, "waiting for a fix, a velocity and an IMU heading"
        elif causes:
            level = WARN
            message = "named cause: " + ", ".join(f"{c.name} {c.size:.3g} {c.size_unit}" for c in causes)
        elif status["unexplained"]:
            level, message = WARN, "unexplained: the twin misfits and no catalogue cause explains it"
        elif ratio is not None and ratio > self.shadow.settings.misfit_ratio:
            level, message = WARN, f"misfit: speed innovations {ratio:.1f}x their noise"
        else:
            level, message = OK, "twin in step with the boat"
        self.diagnostics.publish(Status("shadow twin", level, message, {**status, "model": self.shadow.model()}))

    def _publish_odometry(self) -> None:
        twin = self.shadow.twin
        if twin.state is None or not math.isfinite(twin.t_s):
            return
        east, north, yaw, u, v, r = (float(x) for x in twin.state)
        odom = Odometry()
        sec = math.floor(twin.t_s)
        odom.header.stamp.sec, odom.header.stamp.nanosec = int(sec), int((twin.t_s - sec) * 1e9)
        odom.header.frame_id = self.frame_prefix + FRAME_MAP
        odom.child_frame_id = self.frame_prefix + FRAME_BASE
        odom.pose.pose.position.x, odom.pose.pose.position.y = east, north
        q = quaternion_xyzw(np.zeros(1), np.zeros(1), np.array([yaw]))[0]
        odom.pose.pose.orientation.x, odom.pose.pose.orientation.y = float(q[0]), float(q[1])
        odom.pose.pose.orientation.z, odom.pose.pose.orientation.w = float(q[2]), float(q[3])
        odom.twist.twist.linear.x, odom.twist.twist.linear.y, odom.twist.twist.angular.z = u, v, r
        self.odom_pub.publish(odom)

    def on_save(self, _request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        try:
            self.twin_path.parent.mkdir(parents=True, exist_ok=True)
            self.shadow.save(self.twin_path)
        except (OSError, InputError) as err:
            response.success, response.message = False, f"cannot write {self.twin_path}: {err}"
            return response
        response.success, response.message = True, str(self.twin_path)
        return response

    def on_reset(self, _request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        self.shadow.reset()
        response.success, response.message = True, "shadow twin reset to the configured model"
        return response


    def destroy_node(self) -> None:
        """Stop the diagnosis worker process and the Foxglove view with the node."""
        self.shadow.close()
        if self.view is not None:
            self.view.close()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run boat_twin shadow``."""
    return run_node("shadow", ShadowNode, args)
