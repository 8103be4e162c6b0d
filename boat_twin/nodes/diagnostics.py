"""/diagnostics as diagnostic_updater publishes them, so that a diagnostic_aggregator or rqt_robot_monitor
tells the nodes of several boats apart.

diagnostic_updater's conventions: one diagnostic_msgs/DiagnosticStatus per task on the absolute topic
``/diagnostics``, named ``<node>: <task>`` where ``<node>`` is the fully qualified node name without its leading
slash (``boat1/simulator: simulation``; diagnostic_updater's ``use_fqn`` naming), ``hardware_id`` set, levels
OK / WARN / ERROR / STALE, values as key/value strings, published about once a second. The ``hardware_id``
parameter names the boat; it defaults to (and when empty is) the namespace without its slash (``boat1``),
``boat_twin`` in the root namespace.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.node import Node

from boat_twin.nodes import parameters

OK, WARN, ERROR, STALE = (DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR,
                          DiagnosticStatus.STALE)


@dataclass
class Status:
    """One task's state: ``level`` (OK, WARN, ERROR, STALE), a one-line ``message`` and named ``values``
    (sent JSON-encoded, so numbers and lists read back as they were; anything else as its text)."""

    task: str
    level: bytes
    message: str
    values: dict[str, Any] = field(default_factory=dict)


class Diagnostics:
    """Declares ``hardware_id`` and publishes a node's task statuses on /diagnostics."""

    def __init__(self, node: Node) -> None:
        self.node = node
        default_id = node.get_namespace().strip("/") or "boat_twin"
        self.hardware_id = parameters.string(node, "hardware_id", default_id,
                                             "hardware_id of /diagnostics (empty: the namespace)") or default_id
        self.prefix = node.get_fully_qualified_name().lstrip("/")
        self.publisher = node.create_publisher(DiagnosticArray, "/diagnostics", 10)

    def publish(self, *statuses: Status) -> None:
        array = DiagnosticArray(status=[DiagnosticStatus(
            name=f"{self.prefix}: {s.task}", hardware_id=self.hardware_id, level=s.level, message=s.message,
            values=[KeyValue(key=k, value=json.dumps(v, default=str)) for k, v in s.values.items()]) for s in statuses])
        array.header.stamp = self.node.get_clock().now().to_msg()
        self.publisher.publish(array)
