"""rclpy adapters: the only modules that import rclpy. Console-script entry points live here so that a machine
without ROS gets one clear line instead of an ImportError traceback (named ``*_main``: a function named like a
submodule would be replaced by that submodule once it is imported).

Ctrl-C or SIGTERM while the node's modules load (numpy, scipy, numba, rclpy: a second or more) ends the
process quietly, exit 0: the handlers go in before any heavy import (and a stop that a C extension printed and
replaced by its own ImportError, numba's, is still a stop: :class:`boat_twin.errors.PrintedStops`); the node
runner then installs its own (:mod:`boat_twin.nodes.spin`).
"""

from __future__ import annotations

import importlib
import importlib.util
import signal
import sys
from types import FrameType

from boat_twin.errors import PrintedStops


class _EarlyStop(BaseException):
    """A signal before the node runs (not an Exception: no library handler swallows it)."""


def _early_stop(_signum: int, _frame: FrameType | None) -> None:
    raise _EarlyStop


def _run(name: str) -> int:
    previous = {sig: signal.signal(sig, _early_stop) for sig in (signal.SIGINT, signal.SIGTERM)}
    printed = PrintedStops((_EarlyStop,))
    previous_excepthook, sys.excepthook = sys.excepthook, printed
    try:
        if importlib.util.find_spec("rclpy") is None:
            sys.stderr.write(f"{name}: error: rclpy is not installed: source a ROS 2 Jazzy install, or "
                             "pip install 'boat_twin[ros]' for its PyPI wheels\n")
            return 2
        return int(importlib.import_module(f"boat_twin.nodes.{name}").main())
    except _EarlyStop:  # the node runner replaces the handlers first thing: this is before it runs
        return 0
    except Exception:
        if printed.stops:  # a C extension printed the early stop and raised its own error (numba's import)
            return 0
        raise
    finally:
        sys.excepthook = previous_excepthook
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def simulator_main() -> int:
    """``ros2 run boat_twin simulator``."""
    return _run("simulator")


def identifier_main() -> int:
    """``ros2 run boat_twin identifier``."""
    return _run("identifier")


def cable_main() -> int:
    """``ros2 run boat_twin cable``."""
    return _run("cable")


def player_main() -> int:
    """``ros2 run boat_twin player``."""
    return _run("player")


def shadow_main() -> int:
    """``ros2 run boat_twin shadow``."""
    return _run("shadow")


def bag_player_main() -> int:
    """``ros2 run boat_twin bag_player``."""
    return _run("bag_player")
