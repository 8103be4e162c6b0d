"""The one way a boat_twin node starts and stops: init, build, spin, clean shutdown; bad input → exit 2.

Ctrl-C (SIGINT) and SIGTERM stop the spin loop through a flag, with rclpy's own signal handlers off: the node's
context is still up when it stops, so a node can say its last word (the ``player`` sends zero thrust) in
``on_stop()`` before it is destroyed. Exit code 0, no traceback.
"""

from __future__ import annotations

import signal
import sys
from collections.abc import Callable
from types import FrameType

import rclpy
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from boat_twin.errors import InputError
from boat_twin.nodes.parameters import refuse_undeclared


class StopRequest:
    """Set by SIGINT or SIGTERM (installed on construction)."""

    def __init__(self) -> None:
        self.requested = False
        self._previous = {sig: signal.signal(sig, self._handle) for sig in (signal.SIGINT, signal.SIGTERM)}

    def _handle(self, _signum: int, _frame: FrameType | None) -> None:
        self.requested = True

    def restore(self) -> None:
        """Put back the handlers found on construction."""
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)


def run_node(name: str, factory: Callable[[], Node], args: list[str] | None = None) -> int:
    """Build the node with ``factory`` and spin it until a signal or the node's ``done``; a bad parameter or
    file is one line, exit 2."""
    stop = StopRequest()
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
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
        stop.restore()
        return 2
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        while not stop.requested and not getattr(node, "done", False):  # the player ends by itself: ``done``
            executor.spin_once(timeout_sec=0.1)
    except ExternalShutdownException:
        pass
    finally:
        on_stop = getattr(node, "on_stop", None)
        if on_stop is not None and rclpy.ok():
            on_stop()
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
        stop.restore()
    return 0
