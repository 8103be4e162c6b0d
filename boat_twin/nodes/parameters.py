"""Node parameters declared up front, typed as a ROS user writes them on the command line.

``ros2 run ... -p memory_s:=600`` hands rclpy an INTEGER; a parameter declared with a float default would then
raise InvalidParameterTypeException and kill the node with a traceback. Parameters are therefore declared with
dynamic typing and converted here, once: an integer is accepted for a double, anything else unusable raises
:class:`~boat_twin.errors.InputError` naming the parameter (the node runner turns it into one line, exit 2).
"""

from __future__ import annotations

from typing import Any

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node

from boat_twin.errors import InputError
from boat_twin.validation import number


def declare(node: Node, name: str, default: Any, description: str, *, read_only: bool = True) -> Any:
    """Declare ``name`` (any type accepted: converted by the typed helpers below) and return its value."""
    descriptor = ParameterDescriptor(description=description, read_only=read_only, dynamic_typing=True)
    return node.declare_parameter(name, default, descriptor).value


def double(node: Node, name: str, default: float, description: str, *, above: float | None = None,
           maximum: float | None = None) -> float:
    """Declare a read-only double parameter (integers accepted) and return it checked."""
    return number(f"parameter {name}", declare(node, name, default, description), above=above, maximum=maximum)


def integer(node: Node, name: str, default: int, description: str, *, minimum: int | None = None,
            maximum: int | None = None) -> int:
    """Declare a read-only integer parameter and return it checked (a whole double such as 3.0 is accepted)."""
    value = declare(node, name, default, description)
    where = f"parameter {name}"
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not float(value).is_integer():
        raise InputError(f"{where}: expected an integer, got {value!r}")
    result = int(value)
    if (minimum is not None and result < minimum) or (maximum is not None and result > maximum):
        raise InputError(f"{where}: must be from {minimum} to {maximum}, got {result}")
    return result


def boolean(node: Node, name: str, default: bool, description: str, *, read_only: bool = True) -> bool:
    """Declare a boolean parameter and return it checked."""
    value = declare(node, name, default, description, read_only=read_only)
    if not isinstance(value, bool):
        raise InputError(f"parameter {name}: expected true or false, got {value!r}")
    return value


def string(node: Node, name: str, default: str, description: str) -> str:
    """Declare a read-only string parameter and return it checked."""
    value = declare(node, name, default, description)
    if not isinstance(value, str):
        raise InputError(f"parameter {name}: expected a string, got {value!r}")
    return value


def refuse_undeclared(node: Node) -> None:
    """Refuse a parameter given to ``node`` (``-p sead:=5``, a params file) that it does not declare: a
    misspelt name would otherwise be ignored without a word. Called once the node has declared all of its own."""
    declared = node.get_parameters_by_prefix("")
    given = getattr(node, "_parameter_overrides", {})  # rclpy keeps the overrides for this node here
    unknown = sorted(name for name in given if name not in declared)
    if unknown:
        listed = ", ".join(sorted(name for name in declared if name != "use_sim_time"))
        raise InputError(f"parameter {unknown[0]}: not a parameter of node {node.get_name()} (its parameters: "
                         f"{listed}, use_sim_time)")
