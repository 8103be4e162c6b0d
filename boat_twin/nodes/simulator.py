"""ROS 2 node ``simulator``: the live twin at 10 Hz. Thin wiring only — physics in boat_twin.twin.live, timing
and the command watchdog in boat_twin.twin.pacing.

Subscribes: thrusters/{left,right}/thrust (std_msgs/Float64, N), thrusters/{left,right}/pos (rad), best effort
(reliable and best-effort publishers both connect); a boat file's propulsion section: its actuators' own topics,
thrusters/<name>/thrust|cmd|pos and rudders/<name>/angle. Publishes every topic of boat_twin.io.messages.TOPICS that
the twin produces (GNSS, UM7 IMU, odom/truth, and tf when tf2_msgs is installed), as the same CDR bytes a bag
holds, with the system-default (reliable) QoS so that every subscriber connects (REP-2003); gnss/vel_cov
(gnss/vel with the sensor model's covariance, for robot_localization); tf_static (base_link -> gnss_link,
imu_link; transient local) when tf2_msgs is installed; /diagnostics every wall second. Each tick's messages are
stamped with the node clock at that tick.

Services: ~/pause (std_srvs/SetBool: true stops the ticks, and with publish_clock the clock; false resumes),
~/reset (std_srvs/Trigger: the boat at rest at the origin, the sensor noise re-seeded, the watchdog cleared and,
with publish_clock, the clock back to 0, which resets the identifiers that follow it; refused with mavlink_url).

Parameters (read at start-up)
  config_file (string, "")      twin YAML (empty: the built-in seed boat)
  seed (int, 0), noise (bool, true)   sensor noise
  publish_clock (bool, false)   run on the simulator's own clock, from 0, and publish it on /clock: other nodes
                                then run with use_sim_time:=true, as with Gazebo
  real_time_factor (double, 1.0)   simulated seconds per wall-clock second with publish_clock (at most 100; the
                                clock slows down rather than skip ticks when the machine cannot keep up)
  command_timeout_s (double, 1.0)  thrust goes to zero this long after the last command (simulator time), with
                                one warning per lapse (boat_twin.twin.pacing.DEFAULT_COMMAND_TIMEOUT_S)
  frame_prefix (string, "")     prepended to every frame id (several boats: boat1/)
  publish_truth_tf (bool, true) publish the true map -> base_link on tf (false: a localization stack owns it)
  hardware_id (string, namespace)  of the /diagnostics statuses
  foxglove (string, ""), foxglove_allow_remote (bool, false)   a live Foxglove view of the simulated boat
                                (boat_twin.view, the view extra): HOST:PORT, HOST or :PORT, loopback by default;
                                empty: off (docs/live-twin.md)
  mavlink_url (string, "")      also run the twin as a MAVLink boat (boat_twin.link.mavlink_boat), e.g.
                                udpout:127.0.0.1:14550; mavlink_allow_remote (bool, false) for a non-loopback address
"""

from __future__ import annotations

import time
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING

from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import DurabilityPolicy, QoSProfile
from rosgraph_msgs.msg import Clock as ClockMsg
from std_msgs.msg import Float64
from std_srvs.srv import SetBool, Trigger

from boat_twin.config import TwinConfig, load_config
from boat_twin.errors import InputError
from boat_twin.io import messages
from boat_twin.nodes import conventions, parameters
from boat_twin.nodes.diagnostics import OK, WARN, Diagnostics, Status
from boat_twin.nodes.spin import run_node
from boat_twin.twin.live import LiveTwin
from boat_twin.twin.pacing import DEFAULT_COMMAND_TIMEOUT_S, CommandWatchdog, RateMeter, TickSchedule
from boat_twin.vessel.simulate import OUTPUT_RATE_HZ
from boat_twin.view.simulation import SimulationView

if TYPE_CHECKING:
    from boat_twin.link.mavlink_boat import MavlinkBoat

MAX_REAL_TIME_FACTOR = 100.0
"""Upper bound of real_time_factor: 1,000 ticks per wall second is already beyond what one core publishes."""
TICK_NS = round(1e9 / OUTPUT_RATE_HZ)
"""Simulated time of one tick, ns."""
THRUST_INDICES = (0, 1)
"""Command indices the watchdog zeroes (thrust left, right); the steering angles stay where they were."""
LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)


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
        timeout_s = parameters.double(self, "command_timeout_s", DEFAULT_COMMAND_TIMEOUT_S,
                                      "thrust to zero this long after the last command, s", above=0.0)
        self.frame_prefix = conventions.frame_prefix(self)
        truth_tf = parameters.boolean(self, "publish_truth_tf", True, "publish the true map -> base_link on tf")
        mavlink_url = parameters.string(self, "mavlink_url", "", "serve the twin over MAVLink (empty: off)")
        allow_remote = parameters.boolean(self, "mavlink_allow_remote", False, "allow a non-loopback MAVLink peer")
        self.diagnostics = Diagnostics(self)
        if self.publish_clock and self.get_parameter("use_sim_time").value:
            raise InputError("simulator: publish_clock and use_sim_time exclude each other (it is the clock)")
        config = load_config(Path(config_file)) if config_file else TwinConfig()
        self.new_twin = partial(LiveTwin, config, seed=seed, noise=noise)
        self.twin = self.new_twin()
        self.paused = False
        self.link: MavlinkBoat | None = None
        if mavlink_url:  # pymavlink is imported only then
            from boat_twin.link.mavlink_boat import MavlinkBoat

            self.link = MavlinkBoat(self.twin, mavlink_url, allow_remote=allow_remote)
        self.view = conventions.foxglove_view(self, (config.vessel.length_m, config.vessel.beam_m))
        self.view_sim = SimulationView(self.view, config) if self.view is not None else None
        self.watchdog = CommandWatchdog(timeout_s)
        self.publishers_by_topic = self._sensor_publishers(truth_tf)
        self.velocity_variances = [config.gnss.velocity_stdev_mps ** 2] * 3
        conventions.subscribe_commands(self, config.vessel.propulsion, self.on_command)  # a boat file's own topics
        self.clock_pub: Publisher | None = None
        self.schedule = TickSchedule(1.0 / OUTPUT_RATE_HZ, factor if self.publish_clock else 1.0)
        self.overruns = 0
        self.rate = RateMeter()
        if self.publish_clock:
            self.clock_pub = self.create_publisher(ClockMsg, "/clock", QoSProfile(depth=1))
            self.create_timer(self.schedule.wall_period_s, self.on_schedule, clock=conventions.steady_clock())
        else:
            self.create_timer(1.0 / OUTPUT_RATE_HZ, self.on_tick)
        self.create_timer(1.0, self.on_diagnostics, clock=conventions.steady_clock())
        self.create_service(SetBool, "~/pause", self.on_pause)
        self.create_service(Trigger, "~/reset", self.on_reset)
        conventions.use_sim_time(self)
        self._publish_static_transforms(config.gnss.antenna_height_m)

    @property
    def commands(self) -> LiveTwin | MavlinkBoat:
        """Where commands go: the twin, or the MAVLink link that arbitrates them."""
        return self.link if self.link is not None else self.twin

    def on_command(self, index: int, msg: Float64) -> None:
        """A thruster or rudder command (N, the thruster's own unit, or rad)."""
        self.commands.set_command(index, msg.data)
        self.watchdog.heard(self._stamp_ns() * 1e-9)

    def on_pause(self, request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        if self.paused and not request.data:
            self.schedule.restart()  # resume from now, not catch up the pause
        self.paused = request.data
        state = "paused" if self.paused else "running"
        response.success, response.message = True, f"{state} at {self.twin.tick_index / OUTPUT_RATE_HZ:.1f} s"
        self.get_logger().info(f"simulation {response.message}")
        return response

    def on_reset(self, _request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        if self.link is not None:
            response.success, response.message = False, "reset is not available with mavlink_url: restart the node"
            return response
        self.twin = self.new_twin()
        self.watchdog = CommandWatchdog(self.watchdog.timeout_s)
        self.schedule.restart()
        response.success, response.message = True, "boat at rest at the origin, time 0"
        self.get_logger().info(f"reset: {response.message}")
        return response

    def _sensor_publishers(self, truth_tf: bool) -> dict[str, Publisher]:
        """One reliable publisher per twin output topic; tf only where tf2_msgs is installed (one warning)."""
        publishers = {}
        topics = {**messages.TOPICS, **messages.LIVE_TOPICS}
        missing: dict[str, list[str]] = {}
        for topic, msgtype in topics.items():
            if topic in messages.COMMAND_TOPICS or (topic == messages.TOPIC_TF and not truth_tf):
                continue
            cls = conventions.message_class(msgtype)
            if cls is None:
                missing.setdefault(msgtype, []).append(topic)
                continue
            qos = LATCHED if topic == messages.TOPIC_TF_STATIC else QoSProfile(depth=10)
            publishers[topic] = self.create_publisher(cls, topic, qos)
        for msgtype, names in missing.items():
            listed = ", ".join(f"'{name}'" for name in names)
            self.get_logger().warning(f"{msgtype} is not installed: topic{'s' * (len(names) > 1)} {listed} "
                                      f"{'are' if len(names) > 1 else 'is'} not published")
        return publishers

    def _publish_static_transforms(self, antenna_height_m: float) -> None:
        publisher = self.publishers_by_topic.get(messages.TOPIC_TF_STATIC)
        if publisher is not None:
            msg = messages.static_transforms(self._stamp_ns(), antenna_height_m, self.frame_prefix)
            publisher.publish(messages.serialize(msg, messages.LIVE_TOPICS[messages.TOPIC_TF_STATIC]))

    def _stamp_ns(self) -> int:
        """This tick's stamp: the simulated clock (publish_clock) or the node clock (wall or /clock time)."""
        if self.publish_clock:
            return self.twin.tick_index * TICK_NS  # the twin's nominal time, from 0
        return self.get_clock().now().nanoseconds

    def on_schedule(self) -> None:
        """publish_clock: run the ticks that are due on the wall clock (more than one after a late wake-up)."""
        if self.paused:
            return
        n = self.schedule.due(time.monotonic())
        for _ in range(n):
            self.on_tick()
        self.schedule.ran(n)

    def on_tick(self) -> None:
        """One twin tick: publish its sensor and truth messages (commands are inputs only), then /clock.

        The tick samples the sensors at its start and integrates one period under the held commands; /clock
        then says the time the simulation has reached, from which the next commands act. A driver that answers
        /clock before the next tick therefore acts at the time it read, as a bag records it. Commands arriving
        between ticks act from the next tick (on the wall clock: 0-100 ms later, a 10 Hz actuator update).
        """
        if self.paused:
            return
        started = time.monotonic()
        stamp_ns = self._stamp_ns()
        if self.watchdog.check(stamp_ns * 1e-9):
            for index in THRUST_INDICES:
                self.commands.set_command(index, 0.0)
            self.get_logger().warning(f"no thruster command for {self.watchdog.timeout_s:g} s "
                                      "(command_timeout_s): thrust set to zero")
        tick = self.link.step(1) if self.link is not None else self.twin.tick()
        listened = {topic for topic, publisher in self.publishers_by_topic.items()
                    if publisher.get_subscription_count() > 0}  # nobody listening: no message to make
        with_covariance = messages.TOPIC_GNSS_VEL_COV in listened
        needed = listened | ({messages.TOPIC_GNSS_VEL} if with_covariance else set())
        for topic, _stamp_ns, msg in messages.restamped([i for i in tick if i[0] in needed], stamp_ns,
                                                        self.frame_prefix):
            if topic in listened:
                self.publishers_by_topic[topic].publish(messages.serialize(msg, messages.TOPICS[topic]))
            if topic == messages.TOPIC_GNSS_VEL and with_covariance:
                self._publish_velocity_covariance(msg)
        if self.view_sim is not None:
            self._show(tick, stamp_ns)
        if self.clock_pub is not None:
            self.clock_pub.publish(ClockMsg(clock=conventions.ros_time(stamp_ns + TICK_NS)))
        if time.monotonic() - started > self.schedule.wall_period_s:
            self.overruns += 1

    def _publish_velocity_covariance(self, velocity: messages.Message) -> None:
        msg = messages.velocity_with_covariance(velocity, self.frame_prefix + messages.FRAME_MAP,
                                                self.velocity_variances)
        self.publishers_by_topic[messages.TOPIC_GNSS_VEL_COV].publish(
            messages.serialize(msg, messages.LIVE_TOPICS[messages.TOPIC_GNSS_VEL_COV]))

    def on_diagnostics(self) -> None:
        """Once a wall second: how fast the simulation runs, how late it is, how old the commands are."""
        sim_s = self.twin.tick_index / OUTPUT_RATE_HZ
        achieved = self.rate.factor(time.monotonic(), sim_s)
        asked = self.schedule.factor
        slow = achieved is not None and self.twin.tick_index > 0 and achieved < 0.9 * asked and not self.paused
        if self.paused:
            message = f"paused at {sim_s:.1f} s"
        else:
            message = f"running at {achieved:.1f}x of {asked:g}x" if achieved is not None else "starting"
        timing = Status("simulation", WARN if slow else OK, message,
                        {"real_time_factor_requested": asked, "real_time_factor_achieved": achieved,
                         "ticks": self.twin.tick_index, "simulated_time_s": sim_s, "tick_overruns": self.overruns,
                         "late_ticks": self.schedule.late_ticks, "clock_slowed_s": round(self.schedule.slowed_s, 6)})
        age = self.watchdog.age_s(self._stamp_ns() * 1e-9)
        if age is None:
            commands = Status("commands", OK, "no command yet (thrust zero)", {"command_age_s": None})
        elif self.watchdog.lapsed:
            commands = Status("commands", WARN, f"no command for {age:.1f} s: thrust held at zero",
                              {"command_age_s": age})
        else:
            commands = Status("commands", OK, "commands fresh", {"command_age_s": age})
        commands.values.update(command_timeout_s=self.watchdog.timeout_s, lapses=self.watchdog.lapses,
                               held_commands=self.twin.commands.tolist())
        self.diagnostics.publish(timing, commands)

    def _show(self, tick: list[messages.Message], stamp_ns: int) -> None:
        """The tick's true pose (the state it started from, as its sensors sampled) and GNSS fix to the view."""
        assert self.view_sim is not None
        fixes = messages.restamped([i for i in tick if i[0] == messages.TOPIC_GNSS_FIX], stamp_ns)
        self.view_sim.tick(fixes, stamp_ns * 1e-9, self.twin.state[0])

    def destroy_node(self) -> None:
        """Close the MAVLink link (socket) and the Foxglove view with the node."""
        if self.link is not None:
            self.link.close()
        if self.view is not None:
            self.view.close()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run boat_twin simulator``."""
    return run_node("simulator", SimulatorNode, args)
