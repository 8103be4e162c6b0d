"""The one way a boat_twin node starts and stops: init, build, spin, clean shutdown; bad input → exit 2."""

from __future__ import annotations

import sys
from collections.abc import Callable

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

from boat_twin.errors import InputError


def run_node(name: str, factory: Callable[[], Node], args: list[str] | None = None) -> int:
    """Build the node with ``factory`` and spin it until shutdown; a bad parameter or file is one line, exit 2."""
    rclpy.init(args=args)
    try:
        node = factory()
    except InputError as err:
        sys.stderr.write(f"{name}: error: {err}\n")
        rclpy.try_shutdown()
        return 2
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0
