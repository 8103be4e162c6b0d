"""What a twin normally gets wrong: its prediction error on clean recordings of its own boat (issue 42).

``identify`` measures it on the recordings it identified the twin from (each predicted by a twin identified
without it, :mod:`boat_twin.diagnose.model_error`) and writes it into twin.yaml's ``model_error`` section;
``diagnose`` compares a recording's misfit with it (docs/diagnosis.md, "Diagnosis against the twin's own error").
Per signal of the diagnosis' replay, the error's standard deviation at a sample is

    stdev = √(floor² + (per_speed · speed)² + (per_yaw_rate · |yaw rate|)²)

(``floor`` in the signal's unit, ``per_speed`` in its unit per m/s of speed over ground, ``per_yaw_rate`` in its
unit per rad/s), its integrated autocorrelation time ``correlation_time_s`` and ``structure_r2``, the held-out R² of
the twin's residual on the boat's situation that the training recordings show (the structure the twin normally
leaves). A config without the section has zero model error: the diagnosis' yardstick is the sensors' noise alone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from boat_twin.errors import InputError

MODEL_ERROR_SIGNALS = ("vel_east_mps", "vel_north_mps", "yaw_rate_radps", "heading_rad", "accel_x_mps2")
"""The signals a model-error description may hold (the diagnosis replay's: GNSS velocity, gyro, IMU heading and
the accelerometer's surge specific force; a missing one, or one the training recordings did not log, has zero
error)."""


@dataclass(frozen=True)
class SignalError:
    """One signal's model error (module docstring)."""

    floor: float = 0.0
    per_speed: float = 0.0
    per_yaw_rate: float = 0.0
    correlation_time_s: float = 0.0
    structure_r2: float = 0.0

    def stdev(self, speed_mps: np.ndarray, yaw_rate_radps: np.ndarray) -> np.ndarray:
        """The error's standard deviation at each sample (the signal's unit)."""
        return np.sqrt(self.floor**2 + (self.per_speed * speed_mps) ** 2 + (self.per_yaw_rate * yaw_rate_radps) ** 2)

    @property
    def zero(self) -> bool:
        """No spread at any speed or turn rate."""
        return self.floor == 0.0 and self.per_speed == 0.0 and self.per_yaw_rate == 0.0


@dataclass(frozen=True)
class ModelError:
    """A twin's model-error description: signal → :class:`SignalError` (absent: zero) and what it was measured
    on."""

    signals: tuple[tuple[str, SignalError], ...] = ()
    recordings: int = 0
    """How many recordings it was measured on."""
    heldout: bool = False
    """Each recording was predicted by a twin identified without it (False: the twin fitted to them, or by hand)."""

    def of(self, signal: str) -> SignalError:
        """The error of ``signal`` (zero when not described)."""
        return dict(self.signals).get(signal, SignalError())

    @property
    def zero(self) -> bool:
        """No model error at all: the diagnosis judges against the sensors' noise alone (today's rule)."""
        return all(error.zero for _, error in self.signals)

    def to_dict(self) -> dict[str, Any]:
        """Plain data of twin.yaml's ``model_error`` section (:func:`model_error_from_dict` reads it back)."""
        return {"recordings": self.recordings, "heldout": self.heldout,
                "signals": {name: {f.name: float(getattr(error, f.name)) for f in fields(SignalError)}
                            for name, error in self.signals}}


def model_error_from_dict(data: Any, where: str) -> ModelError:
    """twin.yaml's ``model_error`` section, checked: one clear error naming the field."""
    if data is None:
        return ModelError()
    if not isinstance(data, dict):
        raise InputError(f"{where}: 'model_error' must be a mapping (recordings, heldout, signals)")
    unknown = sorted(set(data) - {"recordings", "heldout", "signals"})
    if unknown:
        raise InputError(f"{where}: unknown model_error field '{unknown[0]}' (expected recordings, heldout, signals)")
    signals = data.get("signals") or {}
    if not isinstance(signals, dict):
        raise InputError(f"{where}: model_error.signals must be a mapping of signal → error")
    return ModelError(tuple((name, _signal_error(name, value, where)) for name, value in signals.items()),
                      _count(data.get("recordings", 0), where), bool(data.get("heldout", False)))


def _count(value: Any, where: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise InputError(f"{where}: model_error.recordings must be a count >= 0, got {value!r}")
    return value


def _signal_error(name: str, value: Any, where: str) -> SignalError:
    if name not in MODEL_ERROR_SIGNALS:
        raise InputError(f"{where}: model_error.signals: unknown signal '{name}' (expected "
                         f"{', '.join(MODEL_ERROR_SIGNALS)})")
    if not isinstance(value, dict):
        raise InputError(f"{where}: model_error.signals.{name} must be a mapping")
    known = {f.name for f in fields(SignalError)}
    numbers = {}
    for key, number in value.items():
        if key not in known:
            raise InputError(f"{where}: model_error.signals.{name}: unknown field '{key}' (expected "
                             f"{', '.join(sorted(known))})")
        if isinstance(number, bool) or not isinstance(number, (int, float)) or not math.isfinite(number) \
                or number < 0:
            raise InputError(f"{where}: model_error.signals.{name}.{key} must be a finite number >= 0, got {number!r}")
        numbers[key] = float(number)
    return SignalError(**numbers)
