"""A towed body behind the boat: the surge drag of issue 4's cable model, tabulated for the dynamics kernel.

The load at the tow point comes from :func:`boat_twin.cable.problems.tow_load` (the lumped-link cable and the
towed vehicle of Babanin & Melkonyan 2025) at the boat's speed through the water; its horizontal part acts as
extra surge resistance. ``drag_scale`` scales that load: the towed system's size relative to the case (drag
grows with the square of the body's and cable's size at a given speed).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from boat_twin.cable.case import load_case, with_overrides
from boat_twin.cable.problems import tow_load
from boat_twin.errors import InputError
from boat_twin.vessel.dynamics import resistance_grid_mps
from boat_twin.vessel.params import VesselParams

TOW_CURVE_STEP_MPS = 0.25
"""Speed step of the solved tow-load curve, m/s; the kernel interpolates linearly between solutions."""


def default_case_path() -> str:
    """The packaged tow case: the Table 1 vehicle and cable on 50 m, in still water."""
    return str(resources.files("boat_twin.data") / "tow_case.yaml")


@dataclass(frozen=True)
class TowConfig:
    """What the boat tows (the twin configuration's optional ``tow`` section)."""

    case: str = ""
    """Cable case YAML (see docs/cable.md); empty: the packaged Table 1 vehicle on 50 m of cable."""
    cable_length_m: float = 50.0
    """Cable paid out, m."""
    drag_scale: float = 1.0
    """Towed system's drag relative to the case, -: (size ratio)² of body and cable."""

    def __post_init__(self) -> None:
        for name in ("cable_length_m", "drag_scale"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
                raise InputError(f"tow '{name}' must be a positive number, got {value!r}")

    @classmethod
    def from_dict(cls, data: Any, where: str) -> TowConfig:
        """From the YAML mapping; unknown keys are an error naming them."""
        if not isinstance(data, dict):
            raise InputError(f"{where}: 'tow' must be a mapping with case, cable_length_m, drag_scale")
        unknown = sorted(set(data) - {"case", "cable_length_m", "drag_scale"})
        if unknown:
            raise InputError(f"{where}: unknown tow field '{unknown[0]}'")
        return cls(**data)

    def to_dict(self) -> dict[str, Any]:
        """Plain data for YAML."""
        return {"case": self.case, "cable_length_m": self.cable_length_m, "drag_scale": self.drag_scale}


@lru_cache(maxsize=16)
def _unit_curve(case_path: str, cable_length_m: float, max_speed_mps: float) -> tuple[np.ndarray, np.ndarray]:
    """(speeds, horizontal tow load at drag_scale 1) from rest to ``max_speed_mps``, m/s and N."""
    case = load_case(Path(case_path))
    speeds = np.arange(0.0, max_speed_mps + TOW_CURVE_STEP_MPS, TOW_CURVE_STEP_MPS)
    loads = np.zeros_like(speeds)
    for i, speed in enumerate(speeds[1:], start=1):
        loads[i] = tow_load(with_overrides(case, length_m=cable_length_m), float(speed)).horizontal_N
    return speeds, loads


def tow_drag_N(tow: TowConfig, speed_mps: np.ndarray, max_speed_mps: float) -> np.ndarray:
    """Surge drag of the towed system at speeds through water ``speed_mps`` (≥ 0, ≤ ``max_speed_mps``), N."""
    speeds, loads = _unit_curve(tow.case or default_case_path(), float(tow.cable_length_m), float(max_speed_mps))
    return tow.drag_scale * np.interp(np.abs(speed_mps), speeds, loads)


def tow_drag_table(tow: TowConfig | None, params: VesselParams) -> np.ndarray | None:
    """The tow drag on the kernel's resistance grid (:func:`resistance_grid_mps`), N; None without a tow."""
    if tow is None:
        return None
    return tow_drag_N(tow, resistance_grid_mps(params), params.resistance.max_speed_mps)
