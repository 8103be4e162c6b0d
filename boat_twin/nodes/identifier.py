"""ROS 2 node ``identifier``: online thrust-speed identification from live topics. Thin wiring only.

Subscribes: the boat's command topics (std_msgs/Float64, best effort: thrusters/{left,right}/thrust and pos, or with
a config_file whose vessel has a propulsion section its own thrusters/<name>/thrust|cmd|pos and
rudders/<name>/angle, the commands turned into surge thrust by its thrust maps), gnss/vel
(geometry_msgs/TwistStamped, best effort like SensorDataQoS: connects to reliable and best-effort drivers alike).
Publishes every second of the node clock (sim time with use_sim_time:=true): identification/coefficients
(std_msgs/Float64MultiArray, layout label "c0_N_per_mps0,...,effective_mass_kg"; NaN until known) and
/diagnostics (diagnostic_msgs/DiagnosticArray, boat_twin.nodes.diagnostics). Services: ~/reset, ~/save
(std_srvs/Trigger). A clock that jumps backwards (a restarted simulator's /clock, a looped bag) resets the
identification, with one log line: the steady points held belong to another run.

Parameters (read at start-up)
  order (int, 5)            order N of the resistance power series Fc(v); a curve needs N + 2 steady points.
                            5: the seed boat's curve has a planing hump that no cubic follows (the best cubic
                            through its thrust-steps speeds misses by up to 56 N, 66 % at 0.5 m/s; order 5 by
                            8 N or less below 7 m/s), N = 5 is the paper's highest order, and `boat-twin identify`
                            selects it by BIC on the thrust-steps trial
  memory_s (double, 3600)   forgetting time constant of the recursive least squares, s
  steady_window_s (double, 20)      shortest settled tail the steady-state detector tests, s. Live, nothing is
                            known of the boat in advance: the default suits the 6 m boat's GNSS (0.05 m/s at
                            10 Hz); `boat-twin identify` derives it from a recording (docs/identification.md)
  thrust_tolerance_N (double, 5)    thrust counts as constant within max(this, 1 %) of a segment's start, N
  model_path (string)       YAML written by ~/save; default $ROS_HOME/boat_twin/identified_model.yaml
                            ($ROS_HOME defaults to ~/.ros)
  config_file (string, "")  twin YAML whose boat's actuators name the command topics (empty: built-in boat)
  hardware_id (string, namespace)   of the /diagnostics status
"""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

from geometry_msgs.msg import TwistStamped
from rclpy.clock import JumpThreshold, TimeJump
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Float64, Float64MultiArray, MultiArrayDimension
from std_srvs.srv import Trigger

from boat_twin.config import load_config
from boat_twin.errors import InputError
from boat_twin.ident.live import LiveIdentifier
from boat_twin.ident.online import SteadyCriteria
from boat_twin.ident.steady import MAX_ORDER
from boat_twin.io.messages import TOPIC_GNSS_VEL
from boat_twin.nodes import conventions, parameters
from boat_twin.nodes.diagnostics import OK, WARN, Diagnostics, Status
from boat_twin.nodes.spin import run_node
from boat_twin.vessel.params import VesselParams

SENSOR_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.BEST_EFFORT)
"""SensorDataQoS (best effort: takes reliable and best-effort drivers) with 10 s of a 10 Hz stream as history,
so that a busy moment of the executor loses no sample (SensorDataQoS keeps 5)."""
DEFAULT_ORDER = 5
"""Order of Fc(v) by default (see the module docstring)."""


def default_model_path() -> Path:
    """$ROS_HOME/boat_twin/identified_model.yaml, ROS_HOME defaulting to ~/.ros (where ROS keeps its logs)."""
    ros_home = os.environ.get("ROS_HOME") or os.path.join(os.path.expanduser("~"), ".ros")
    return Path(ros_home) / "boat_twin" / "identified_model.yaml"


class IdentifierNode(Node):
    """Wires topics and services to a LiveIdentifier."""

    def __init__(self) -> None:
        super().__init__("identifier")
        order = parameters.integer(self, "order", DEFAULT_ORDER, "order N of Fc(v)", minimum=1, maximum=MAX_ORDER)
        memory_s = parameters.double(self, "memory_s", 3600.0, "forgetting time constant, s", above=0.0)
        default = SteadyCriteria()
        criteria = replace(
            default,
            window_s=parameters.double(self, "steady_window_s", default.window_s,
                                       "shortest settled tail of the steady-state detector, s", above=0.0),
            thrust_tolerance_N=parameters.double(self, "thrust_tolerance_N", default.thrust_tolerance_N,
                                                 "thrust counts as constant within this, N", above=0.0))
        model_path = parameters.string(self, "model_path", "", "YAML written by ~/save (empty: $ROS_HOME/...)")
        self.model_path = Path(model_path).expanduser() if model_path else default_model_path()
        config_file = parameters.string(self, "config_file", "", "twin YAML naming the boat's actuators")
        vessel = load_config(Path(config_file)).vessel if config_file else VesselParams()
        self.ident = LiveIdentifier(order, memory_s, criteria, vessel)
        conventions.subscribe_commands(self, vessel.propulsion, self.on_command)  # a boat file's own topics
        self.create_subscription(TwistStamped, TOPIC_GNSS_VEL, self.on_velocity, SENSOR_QOS)
        self.coefficients_pub = self.create_publisher(Float64MultiArray, "identification/coefficients", 10)
        self.diagnostics = Diagnostics(self)
        self.create_service(Trigger, "~/reset", self.on_reset)
        self.create_service(Trigger, "~/save", self.on_save)
        self.create_timer(1.0, self.on_publish)
        self.jump_handle = self.get_clock().create_jump_callback(
            JumpThreshold(min_forward=None, min_backward=Duration(nanoseconds=-1), on_clock_change=False),
            post_callback=self.on_clock_jump)
        conventions.use_sim_time(self)

    def on_clock_jump(self, jump: TimeJump) -> None:
        """The clock went back: start the identification afresh."""
        self.ident.reset()
        self.get_logger().warning(f"clock jumped back {-jump.delta.nanoseconds * 1e-9:.3f} s: identification reset")

    def on_command(self, index: int, msg: Float64) -> None:
        self.ident.set_command(index, msg.data)

    def on_velocity(self, msg: TwistStamped) -> None:
        stamp_ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        segment = self.ident.on_velocity(stamp_ns, msg.twist.linear.x, msg.twist.linear.y)
        if segment is None:
            return
        if not segment.accepted:
            self.get_logger().info(f"segment at {segment.thrust_N:.0f} N not steady: {segment.reason}")
            return
        found, needed = len(self.ident.core.steady_points), self.ident.order + 2
        progress = f"of the {needed} needed" if found <= needed else f"{needed} needed: the fit is refined"
        self.get_logger().info(f"steady point {found} ({progress}): {segment.speed_mps:.2f} m/s "
                               f"at {segment.thrust_N:.0f} N")
        if found == needed:
            labels, values = self.ident.coefficients()
            curve = ", ".join(f"{label.split('_')[0]} {value:.4g}" for label, value in zip(labels, values[:-1],
                                                                                           strict=False))
            self.get_logger().info(f"identified Fc(v) = sum c_i v^i (N, m/s): {curve}")

    def on_publish(self) -> None:
        labels, values = self.ident.coefficients()
        out = Float64MultiArray(data=values)
        out.layout.dim = [MultiArrayDimension(label=",".join(labels), size=len(values), stride=len(values))]
        self.coefficients_pub.publish(out)
        status = self.ident.status()
        ok = status["coefficients"] is not None
        waiting = f"waiting for steady points ({status['steady_points']} of {status['steady_points_needed']})"
        self.diagnostics.publish(Status("thrust-speed identification", OK if ok else WARN,
                                        "identified" if ok else waiting, dict(status)))

    def on_reset(self, _request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        self.ident.reset()
        response.success, response.message = True, "identifier reset"
        return response

    def on_save(self, _request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        try:
            response.success = self.ident.save(self.model_path)
        except OSError as err:
            response.success, response.message = False, f"cannot write {self.model_path}: {err.strerror}"
            return response
        except InputError as err:  # e.g. another process writing the same file now
            response.success, response.message = False, str(err)
            return response
        response.message = str(self.model_path) if response.success else "not enough steady points yet"
        return response


def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run boat_twin identifier``."""
    return run_node("identifier", IdentifierNode, args)
