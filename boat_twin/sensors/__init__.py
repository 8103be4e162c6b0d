"""Sensor models (GNSS receiver, UM7 AHRS): ground truth -> seeded, noisy measurements.

This module holds what both models share: config validation, reading a config from a YAML mapping,
rate decimation and coloured (Gauss-Markov) noise. The models live in :mod:`boat_twin.sensors.gnss`
and :mod:`boat_twin.sensors.um7`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import fields
from typing import Any, TypeVar

import numpy as np

from boat_twin.errors import InputError

__all__ = ["RATE_TOLERANCE", "config_from_mapping", "decimation_step", "gauss_markov", "number", "vector3"]

C = TypeVar("C")

RATE_TOLERANCE = 1e-6
"""Relative tolerance when checking that a sensor rate divides the truth output rate."""


def number(where: str, value: Any, *, minimum: float | None = None, maximum: float | None = None,
           above: float | None = None, below: float | None = None) -> float:
    """``value`` as a finite float within inclusive (minimum, maximum) and exclusive (above, below) bounds.

    Anything else raises InputError naming ``where``.
    """
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InputError(f"{where}: expected a number, got {value!r}")
    result = float(value)
    if not math.isfinite(result):
        raise InputError(f"{where}: must be finite, got {result}")
    for bound, fails, relation in (
        (minimum, lambda b: result < b, ">="), (maximum, lambda b: result > b, "<="),
        (above, lambda b: result <= b, ">"), (below, lambda b: result >= b, "<"),
    ):
        if bound is not None and fails(bound):
            raise InputError(f"{where}: must be {relation} {bound:g}, got {result:g}")
    return result


def vector3(where: str, value: Any) -> tuple[float, float, float]:
    """``value`` as a tuple of three finite floats, else InputError naming ``where``."""
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


def decimation_step(t_s: np.ndarray, rate_hz: float, where: str) -> int:
    """Keep every k-th truth sample for a sensor at ``rate_hz``; k must be a whole number >= 1.

    Raises InputError naming ``where`` if the rate exceeds the truth rate or does not divide it.
    """
    if t_s.size < 2:
        return 1
    dt_s = float(np.median(np.diff(t_s)))
    truth_rate_hz = 1.0 / dt_s
    ratio = truth_rate_hz / rate_hz
    step = round(ratio)
    if step < 1 or abs(ratio - step) > RATE_TOLERANCE * ratio:
        raise InputError(
            f"{where}: {rate_hz:g} Hz must divide the {truth_rate_hz:g} Hz truth output rate "
            f"(one sample in every whole number of truth samples)"
        )
    return step


def gauss_markov(rng: np.random.Generator, n: int, dims: int, stdev: float | np.ndarray, dt_s: float,
                 correlation_time_s: float) -> np.ndarray:
    """Zero-mean stationary noise, shape (n, dims), stdev ``stdev`` per column.

    ``correlation_time_s`` 0 gives white noise; otherwise a first-order Gauss-Markov process
    e[k] = a e[k-1] + sqrt(1 - a^2) stdev w[k], a = exp(-dt/tau), started in its stationary distribution.
    """
    white = rng.standard_normal((n, dims))
    if correlation_time_s <= 0.0 or n == 0:
        return white * stdev
    from scipy.signal import lfilter

    a = math.exp(-dt_s / correlation_time_s)
    drive = white * math.sqrt(1.0 - a * a)
    drive[0] = white[0]
    return lfilter([1.0], [1.0, -a], drive, axis=0) * stdev
