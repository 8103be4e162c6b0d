"""ROS 2 node ``player``: plays a scenario's open-loop commands on the boat's command topics, on the node clock.

The helmsman of a live walkthrough or a hardware-in-the-loop test: the same command profiles as
``boat-twin simulate`` (boat_twin.vessel.scenarios), published on change and re-sent every 0.25 s (a late
subscriber gets the held value; the simulator's 1 s command watchdog stays fed), stamped by the node clock
(use_sim_time:=true follows the simulator's /clock). It exits when the profile ends. Whenever it stops — the
profile's end, Ctrl-C, SIGTERM — it sends zero thrust last (the steering stays), so that the boat is not left
running on its last command. The topics are the boat's (:func:`~boat_twin.io.messages.command_topics`): the
default layout's ``thrusters/{left,right}/thrust`` and ``pos``, or a boat file's per-actuator
``thrusters/<name>/thrust|cmd|pos`` and ``rudders/<name>/angle``; "zero thrust" is each thruster's own stop
command (0 N, 0 rev/s, a table's zero-thrust command such as 1500 µs).

Parameters (read at start-up)
  scenario (string, thrust-steps)   an open-loop scenario of the registry (boat_twin.vessel.scenarios.SCENARIOS)
  commands_file (string, "")        or a command CSV (t, thrust_left_N, thrust_right_N, angle_left_rad,
                                    angle_right_rad), as ``simulate --commands``
  seed (int, 0)                     random scenario's seed
  config_file (string, "")          twin YAML whose vessel sizes the scenario and names the topics (empty: the
                                    built-in boat)
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from rclpy.duration import Duration
from rclpy.node import Node
from std_msgs.msg import Float64

from boat_twin.config import TwinConfig, load_config
from boat_twin.errors import InputError
from boat_twin.io.messages import command_topics
from boat_twin.io.roles import COMMAND_ROLES
from boat_twin.nodes import conventions, parameters
from boat_twin.nodes.spin import run_node
from boat_twin.vessel.scenarios import CommandProfile, make_scenario, read_command_csv

RESEND_PERIOD_S = 0.25
"""Held commands are re-sent this often, s (of the node clock): four times per simulator command_timeout_s
(1 s), so that three lost messages in a row do not stop the boat."""
STOP_ACK_TIMEOUT_S = 1.0
"""Wall time the final zero thrust gets to be acknowledged by the subscribers (reliable) before the node ends."""


class PlayerNode(Node):
    """Publishes a CommandProfile's rows at their times of the node clock; shuts down at the profile's end."""

    def __init__(self) -> None:
        super().__init__("player")
        name = parameters.string(self, "scenario", "thrust-steps", "open-loop scenario to play")
        commands_file = parameters.string(self, "commands_file", "", "command CSV to play instead")
        seed = parameters.integer(self, "seed", 0, "seed of the random scenario", minimum=0, maximum=2**63 - 1)
        config_file = parameters.string(self, "config_file", "", "twin YAML (empty: built-in boat)")
        config = load_config(Path(config_file)) if config_file else TwinConfig()
        if commands_file:
            profile = read_command_csv(Path(commands_file))
        else:
            scenario = make_scenario(name, config.vessel, np.random.default_rng(seed))
            if not isinstance(scenario, CommandProfile):
                raise InputError(f"parameter scenario: {name} steers on the boat's heading (closed loop); "
                                 "play an open-loop scenario or a commands_file")
            profile = scenario
        self.profile = profile
        topics = command_topics(config.vessel.propulsion)
        self.columns = [i for i, role in enumerate(COMMAND_ROLES) if role in topics]
        """The profile's command columns the boat has a topic for (thrust left, right, angle left, right)."""
        self.publishers_ = [self.create_publisher(Float64, topics[COMMAND_ROLES[i]], 10) for i in self.columns]
        propulsion = config.vessel.propulsion
        self.stops = {k: (propulsion.thrusters[i].stop_command if propulsion is not None else 0.0)
                      for k, i in enumerate(self.columns) if i < 2}
        """Publisher index → the command that stops its thruster, in the thruster's own unit."""
        self.start_ns: int | None = None
        self.held: np.ndarray | None = None
        self.sent_ns = 0
        self.done = False
        self.create_timer(0.05, self.on_timer)
        conventions.use_sim_time(self)
        self.get_logger().info(f"playing {profile.name}: {profile.duration_s:.0f} s of commands")

    def on_stop(self) -> None:
        """Zero thrust on every thruster, waited for (the node runner calls this however the node stops)."""
        thrust = [self.publishers_[k] for k in self.stops]
        for k, stop in self.stops.items():
            self.publishers_[k].publish(Float64(data=stop))
        for publisher in thrust:
            publisher.wait_for_all_acked(Duration(seconds=STOP_ACK_TIMEOUT_S))
        self.get_logger().info("stopped: zero thrust sent")

    def on_timer(self) -> None:
        now_ns = self.get_clock().now().nanoseconds
        if now_ns == 0:  # use_sim_time and no /clock yet
            return
        self.start_ns = now_ns if self.start_ns is None else self.start_ns
        t_s = (now_ns - self.start_ns) * 1e-9
        if t_s > self.profile.duration_s:
            self.get_logger().info(f"{self.profile.name} played to its end ({self.profile.duration_s:.0f} s)")
            self.done = True
            return
        row = self.profile.command(t_s, np.zeros((1, 6)))[0]
        if self.held is None or not np.array_equal(row, self.held) or now_ns - self.sent_ns >= RESEND_PERIOD_S * 1e9:
            for publisher, column in zip(self.publishers_, self.columns, strict=True):
                publisher.publish(Float64(data=float(row[column])))
            self.held, self.sent_ns = row, now_ns


def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run boat_twin player``."""
    return run_node("player", PlayerNode, args)
