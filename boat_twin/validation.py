"""Checks of user input, one message style: ``<where>: expected a finite number, got 'x'`` or
``<where>: must be > 0, got -1``. Every failure raises :class:`~boat_twin.errors.InputError` naming ``where``
(a file and field, a flag, a parameter)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import fields
from typing import Any, TypeVar

import numpy as np

from boat_twin.errors import InputError

C = TypeVar("C")

THRUST_LIMIT_N = 1e6
"""Largest thrust magnitude any input may hold, N: 500 times the seed boat's bollard thrust. One bound for every
reader (bags, MAVLink logs, CSV trials and command files, the live identifier, vessel.bollard_thrust_N): beyond
is a decoding or unit error."""

__all__ = ["THRUST_LIMIT_N", "config_from_mapping", "integer", "number", "number_list", "vector3"]


def number(where: str, value: Any, *, minimum: float | None = None, maximum: float | None = None,
           above: float | None = None, below: float | None = None) -> float:
    """``value`` as a finite float within inclusive (minimum, maximum) and exclusive (above, below) bounds."""
    try:
        result = float(value) if isinstance(value, (int, float, np.integer, np.floating)) else math.nan
    except OverflowError:  # an integer beyond the float range
        result = math.nan
    if isinstance(value, bool) or not math.isfinite(result):
        raise InputError(f"{where}: expected a finite number, got {value!r}")
    for bound, fails, relation in (
        (minimum, lambda b: result < b, ">="), (maximum, lambda b: result > b, "<="),
        (above, lambda b: result <= b, ">"), (below, lambda b: result >= b, "<"),
    ):
        if bound is not None and fails(bound):
            raise InputError(f"{where}: must be {relation} {bound:g}, got {result:g}")
    return result


def integer(where: str, value: int, *, minimum: int, maximum: int) -> int:
    """``value`` as an integer within inclusive bounds."""
    if not minimum <= value <= maximum:
        raise InputError(f"{where}: must be an integer from {minimum} to {maximum}, got {value}")
    return value


def number_list(where: str, value: Any, *, min_length: int = 1) -> tuple[float, ...]:
    """``value`` as a tuple of at least ``min_length`` finite floats."""
    if isinstance(value, (str, bytes, Mapping)) or not hasattr(value, "__len__") or len(value) < min_length:
        raise InputError(f"{where}: expected a list of at least {min_length} number(s), got {value!r}")
    return tuple(number(f"{where}[{i}]", v) for i, v in enumerate(value))


def vector3(where: str, value: Any) -> tuple[float, float, float]:
    """``value`` as a tuple of three finite floats."""
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 3:
        raise InputError(f"{where}: expected a list of 3 numbers, got {value!r}")
    x, y, z = (number(f"{where}[{i}]", v) for i, v in enumerate(value))
    return x, y, z


def config_from_mapping(cls: type[C], data: Any, section: str) -> C:
    """Build the config dataclass ``cls`` from a YAML mapping; unknown keys raise InputError naming them."""
    if not isinstance(data, Mapping):
        raise InputError(f"{section}: expected a mapping of field: value, got {type(data).__name__}")
    known = [f.name for f in fields(cls)]  # type: ignore[arg-type]
    for key in data:
        if key not in known:
            raise InputError(f"{section}.{key}: unknown field (known: {', '.join(known)})")
    return cls(**data)
