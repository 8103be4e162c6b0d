"""ROS 2 node ``cable``: the towed-cable solver (boat_twin.cable) as parameters, services and topics.

Wiring only; every number comes from the library.

Parameters
  case_file (string, "")     case YAML, read once at start-up ("": the installed config/cable/default.yaml)
  <case fields> (double, double[], string)   every field of the case, dotted: tow_speed_mps, cable.length_m,
                             cable.drag.cx, current.depth_m, vehicle.weight_in_water_N, target_depth_m, ...
                             initialised from the file, settable at run time (a bad value is refused with the
                             reason); cable.length_m, cable.winch_capacity_m and target_depth_m: 0.0 = unset
  follow_gnss_vel (bool, false)   use the horizontal speed of gnss/vel as the tow speed
  frame_id (string, tow_point)    frame of the published path (x forward, z up, origin at the tow point)
  frame_prefix (string, "")       prepended to frame_id (several boats: boat1/)
  hardware_id (string, namespace) of the /diagnostics status ("towed cable": the last problem 1 answer)
  update_period_s (double, 1.0)   how often a changed parameter or speed re-solves problem 1 (start-up only)
Services (std_srvs/srv/Trigger; response.message is the JSON result, or the error when success is false)
  ~/solve_depth    problem 1 for cable.length_m      ~/solve_length   problem 2 for target_depth_m
Topics (transient local, so late subscribers get the last answer)
  cable/path (nav_msgs/Path), cable/vehicle_depth (std_msgs/Float64, m), cable/top_tension (Float64, N),
  cable/length (Float64, m);  subscribes to gnss/vel (geometry_msgs/TwistStamped, ENU, SensorDataQoS) and
  uses it when follow_gnss_vel is true. Integers are accepted wherever a double is expected.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from geometry_msgs.msg import PoseStamped, TwistStamped
from nav_msgs.msg import Path as PathMsg
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, qos_profile_sensor_data
from std_msgs.msg import Float64
from std_srvs.srv import Trigger

from boat_twin.cable.case import CableCase, case_from_parameters, case_parameters, load_case, with_overrides
from boat_twin.cable.problems import CableSolution, solve_depth, solve_length
from boat_twin.errors import InputError
from boat_twin.io.trial import VALUE_LIMITS
from boat_twin.nodes import conventions, parameters
from boat_twin.nodes.diagnostics import ERROR, OK, STALE, Diagnostics, Status
from boat_twin.nodes.spin import run_node

LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def default_case_file() -> str:
    """The installed config/cable/default.yaml; the source tree's outside a sourced ROS workspace."""
    source_tree = Path(__file__).resolve().parents[2] / "config" / "cable" / "default.yaml"
    try:
        from ament_index_python.packages import get_package_share_directory

        return str(Path(get_package_share_directory("boat_twin")) / "config" / "cable" / "default.yaml")
    except (ImportError, LookupError, OSError):  # not installed / not in the index / AMENT_PREFIX_PATH unset
        return str(source_tree)


class CableNode(Node):
    """Parameters -> case -> problem 1 or 2 -> services' JSON and the cable/... topics."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("cable", **kwargs)
        case_file = parameters.string(self, "case_file", "", "case YAML (empty: config/cable/default.yaml)")
        case_file = case_file or default_case_file()
        case = load_case(case_file)
        self._case_names = []
        for name, value in case_parameters(case).items():
            parameters.declare(self, name, value, "case field (see boat_twin.cable.case)", read_only=False)
            self._case_names.append(name)
        parameters.boolean(self, "follow_gnss_vel", False, "tow speed from gnss/vel", read_only=False)
        self._live_speed_mps: float | None = None
        self._rejected = 0
        """gnss/vel samples refused as no velocity (see :meth:`_on_velocity`)."""
        self._case()  # a case field given at start-up (-p tow_speed_mps:=.nan) is checked now: one line, exit 2
        parameters.string(self, "frame_id", "tow_point", "frame of cable/path")
        self._frame_prefix = conventions.frame_prefix(self)
        self._diagnostics = Diagnostics(self)
        self._status = Status("towed cable", STALE, "not solved yet")
        period = parameters.double(self, "update_period_s", 1.0, "re-solve period, s", above=0.0)
        self._dirty = True
        self.add_on_set_parameters_callback(self._check_parameters)
        self._path_pub = self.create_publisher(PathMsg, "cable/path", LATCHED)
        self._depth_pub = self.create_publisher(Float64, "cable/vehicle_depth", LATCHED)
        self._tension_pub = self.create_publisher(Float64, "cable/top_tension", LATCHED)
        self._length_pub = self.create_publisher(Float64, "cable/length", LATCHED)
        self.create_service(Trigger, "~/solve_depth", self._solve_depth)
        self.create_service(Trigger, "~/solve_length", self._solve_length)
        self.create_subscription(TwistStamped, "gnss/vel", self._on_velocity, qos_profile_sensor_data)
        self.create_timer(period, self._refresh)
        self.create_timer(1.0, lambda: self._diagnostics.publish(self._status), clock=conventions.steady_clock())
        conventions.use_sim_time(self)
        self.get_logger().info(f"cable case {case_file}: services ~/solve_depth, ~/solve_length")

    def _case(self, changes: dict[str, Any] | None = None) -> CableCase:
        flat = {name: self.get_parameter(name).value for name in self._case_names}
        flat.update(changes or {})
        case = case_from_parameters(flat, f"{self.get_fully_qualified_name()} parameters")
        if self.get_parameter("follow_gnss_vel").value and self._live_speed_mps is not None:
            case = with_overrides(case, tow_speed_mps=self._live_speed_mps)
        return case

    def _check_parameters(self, params: list[Parameter]) -> SetParametersResult:
        for p in params:
            if p.name == "follow_gnss_vel" and not isinstance(p.value, bool):
                return SetParametersResult(successful=False, reason="follow_gnss_vel: expected true or false")
        changes = {p.name: p.value for p in params if p.name in self._case_names}
        try:
            self._case(changes)
        except InputError as err:
            return SetParametersResult(successful=False, reason=str(err))
        self._dirty = True
        return SetParametersResult(successful=True)

    def _publish(self, solution: CableSolution) -> None:
        stamp = self.get_clock().now().to_msg()
        path = PathMsg()
        path.header.stamp = stamp
        path.header.frame_id = self._frame_prefix + self.get_parameter("frame_id").value
        for x, z in zip(*solution.tow_frame_xz(), strict=True):
            pose = PoseStamped()
            pose.header = path.header
            pose.pose.position.x, pose.pose.position.z = float(x), float(z)
            pose.pose.orientation.w = 1.0
            path.poses.append(pose)
        self._path_pub.publish(path)
        self._depth_pub.publish(Float64(data=solution.vehicle_depth_m))
        self._tension_pub.publish(Float64(data=solution.top_tension_N))
        self._length_pub.publish(Float64(data=solution.length_m))

    def _answer(self, response: Trigger.Response, solve: Callable[[CableCase], CableSolution]) -> Any:
        try:
            solution = solve(self._case())
        except InputError as err:
            response.success, response.message = False, str(err)
            return response
        self._publish(solution)
        response.success, response.message = True, json.dumps(solution.to_dict(arrays=False))
        return response

    def _solve_depth(self, _request: Trigger.Request, response: Trigger.Response) -> Any:
        return self._answer(response, solve_depth)

    def _solve_length(self, _request: Trigger.Request, response: Trigger.Response) -> Any:
        return self._answer(response, solve_length)

    def _on_velocity(self, msg: TwistStamped) -> None:
        if not self.get_parameter("follow_gnss_vel").value:
            return
        velocity = (msg.twist.linear.x, msg.twist.linear.y)
        if not all(low <= v <= high for v, (_, low, high, _) in zip(velocity, VALUE_LIMITS["gnss_vel"],
                                                                     strict=False)):
            self._rejected += 1  # NaN, or beyond the speed of sound: a broken driver; the last valid speed holds
            if self._rejected == 1:
                self.get_logger().warning(f"gnss/vel ({velocity[0]:.6g}, {velocity[1]:.6g}) m/s is not a velocity "
                                          "(non-finite or beyond 343 m/s): ignored (further ones counted)")
            return
        self._live_speed_mps = math.hypot(*velocity)
        self._dirty = True

    def _refresh(self) -> None:
        if not self._dirty:
            return
        self._dirty = False
        try:
            case = self._case()
            solution = solve_depth(case)
        except InputError as err:
            self.get_logger().warning(f"problem 1 not solved: {err}")
            self._status = Status("towed cable", ERROR, f"problem 1 not solved: {err}")
            return
        self._publish(solution)
        self._status = Status("towed cable", OK, f"vehicle at {solution.vehicle_depth_m:.1f} m depth", {
            "tow_speed_mps": case.tow_speed_mps, "length_m": solution.length_m,
            "vehicle_depth_m": solution.vehicle_depth_m, "top_tension_N": solution.top_tension_N,
            "rejected_velocities": self._rejected})


def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run boat_twin cable``."""
    return run_node("cable", CableNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
