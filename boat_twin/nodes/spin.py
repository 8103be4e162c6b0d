"""The one way a boat_twin node starts and stops: init, build, spin, clean shutdown; bad input → exit 2."""

from __future__ import annotations

import sys
from collections.abc import Callable

import rclpy
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node

from boat_twin.errors import InputError
from boat_twin.nodes.parameters import refuse_undeclared


def run_node(name: str, factory: Callable[[], Node], args: list[str] | None = None) -> int:
    """Build the node with ``factory`` and spin it until shutdown; a bad parameter or file is one line, exit 2."""
    rclpy.init(args=args)
    try:
        node = factory()
        try:
            refuse_undeclared(node)
        except InputError:
            node.destroy_node()
            raise
    except (InputError, ParameterException) as err:
        sys.stderr.write(f"{name}: error: {' '.join(str(err).split())}\n")
        rclpy.try_shutdown()
        return 2
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        while not getattr(node, "done", False):  # a node that ends by itself (the player) sets ``done``
            executor.spin_once(timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception:  # noqa: BLE001 - a callback racing the shutdown (Ctrl-C, SIGTERM) is no failure
        if rclpy.ok():
            raise
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    return 0
