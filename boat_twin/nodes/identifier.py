"""ROS 2 node ``identifier``: online thrust-speed identification from live topics. Thin wiring only.

Subscribes: thrusters/{left,right}/thrust and pos (std_msgs/Float64), gnss/vel (geometry_msgs/TwistStamped).
Publishes at 1 Hz: identification/coefficients (std_msgs/Float64MultiArray, layout labels c0..cN, mass) and
/diagnostics (diagnostic_msgs/DiagnosticArray). Services: ~/reset, ~/save (std_srvs/Trigger).
Parameters: order (int, 3), memory_s (forgetting time constant, s), model_path (YAML written by ~/save).
"""

from __future__ import annotations

import json
from pathlib import Path

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import TwistStamped
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from std_msgs.msg import Float64, Float64MultiArray, MultiArrayDimension
from std_srvs.srv import Trigger

from boat_twin.ident.live import LiveIdentifier
from boat_twin.io.messages import COMMAND_TOPICS, TOPIC_GNSS_VEL
from boat_twin.nodes.spin import run_node


class IdentifierNode(Node):
    """Wires topics and services to a LiveIdentifier."""

    def __init__(self) -> None:
        super().__init__("identifier")
        order = int(self.declare_parameter("order", 3).value)
        memory_s = float(self.declare_parameter("memory_s", 3600.0).value)
        self.model_path = Path(self.declare_parameter("model_path", "identified_model.yaml").value)
        self.ident = LiveIdentifier(order, memory_s)
        for index, topic in enumerate(COMMAND_TOPICS):
            self.create_subscription(Float64, topic, lambda m, i=index: self.ident.set_command(i, m.data), 10)
        self.create_subscription(TwistStamped, TOPIC_GNSS_VEL, self.on_velocity, qos_profile_sensor_data)
        self.coefficients_pub = self.create_publisher(Float64MultiArray, "identification/coefficients", 10)
        self.diagnostics_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self.create_service(Trigger, "~/reset", self.on_reset)
        self.create_service(Trigger, "~/save", self.on_save)
        self.create_timer(1.0, self.on_publish)

    def on_velocity(self, msg: TwistStamped) -> None:
        stamp = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        self.ident.on_velocity(stamp, msg.twist.linear.x, msg.twist.linear.y)

    def on_publish(self) -> None:
        labels, values = self.ident.coefficients()
        out = Float64MultiArray(data=values)
        out.layout.dim = [MultiArrayDimension(label=",".join(labels), size=len(values), stride=len(values))]
        self.coefficients_pub.publish(out)
        status = self.ident.status()
        ok = status["coefficients"] is not None
        diag = DiagnosticStatus(name="boat_twin: thrust-speed identification", hardware_id="boat_twin",
                                level=DiagnosticStatus.OK if ok else DiagnosticStatus.WARN,
                                message="identified" if ok else "waiting for steady points",
                                values=[KeyValue(key=k, value=json.dumps(v)) for k, v in status.items()])
        array = DiagnosticArray(status=[diag])
        array.header.stamp = self.get_clock().now().to_msg()
        self.diagnostics_pub.publish(array)

    def on_reset(self, _request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        self.ident.reset()
        response.success, response.message = True, "identifier reset"
        return response

    def on_save(self, _request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        response.success = self.ident.save(self.model_path)
        response.message = str(self.model_path) if response.success else "not enough steady points yet"
        return response


def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run boat_twin identifier``."""
    return run_node("identifier", IdentifierNode, args)
