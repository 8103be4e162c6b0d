"""Loads on the cable per unit length: weight in water plus hydrodynamic drag, two selectable drag laws.

Coordinates (the paper's "reversed motion" view, Babanin & Melkonyan 2025): the cable is at rest and the
water streams past it *aft* (away from the boat) at V = V_k + V_T(Y). Forces are given as (aft, down)
components in N/m. A cable element's direction is its angle β above the horizontal, rising from the vehicle
toward the boat (β = 90° is a vertical cable).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from boat_twin.cable.current import CurrentProfile
from boat_twin.errors import InputError
from boat_twin.validation import number

SPHERE_CX = 0.47
"""Drag coefficient (-) of the sphere lumped on each cable element, on the area d·l (the paper's eq. 6
text: "for a sphere cx = 0.47", the subcritical-Reynolds-number sphere value)."""

NORMAL_CN = 1.5
"""Normal drag coefficient (-) of a bare armoured cable on the projected area d per metre. The DTIC report
"Hydrodynamic Loading on Armored Towcables" finds a constant C_R = 1.5, independent of Reynolds number, fits
measured bare armoured tow-cable loading; a smooth circular cylinder gives about 1.2 (Hoerner 1965, ch. 3)."""

TANGENTIAL_CT = 0.02
"""Tangential (skin-friction) drag coefficient (-) on the wetted area π·d per metre: mid-range of the
0.01-0.03 spread of bare-cable values in the cable-dynamics literature (see the survey of Choo & Casarella
1973, J. Hydronautics 7(4)). An assumption, not a measurement for this cable."""


@dataclass(frozen=True)
class SphereDrag:
    """The paper's law: each element drags like a sphere, R = cx·ρV|V|/2·d·l, horizontal, whatever β."""

    cx: float = SPHERE_CX

    def per_length(self, density_kgpm3: float, diameter_m: float, flow_mps: np.ndarray,
                   angle_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Drag (aft, down) in N/m for flow ``flow_mps``; ``angle_rad`` is ignored by this law."""
        aft = self.cx * 0.5 * density_kgpm3 * diameter_m * flow_mps * np.abs(flow_mps)
        return aft, np.zeros_like(aft)

    def to_dict(self) -> dict[str, Any]:
        """``{"model": "sphere", "cx": ...}``."""
        return {"model": "sphere", "cx": self.cx}


@dataclass(frozen=True)
class NormalTangentialDrag:
    """Cross-flow law: ½ρ·Cn·d·V_n|V_n| normal and ½ρ·Ct·π·d·V_t|V_t| along the cable, both per metre."""

    cn: float = NORMAL_CN
    ct: float = TANGENTIAL_CT

    def per_length(self, density_kgpm3: float, diameter_m: float, flow_mps: np.ndarray,
                   angle_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Drag (aft, down) in N/m on a cable at ``angle_rad`` above the horizontal in flow ``flow_mps``."""
        s, c = np.sin(angle_rad), np.cos(angle_rad)
        vn, vt = flow_mps * s, flow_mps * c
        normal = 0.5 * density_kgpm3 * self.cn * diameter_m * vn * np.abs(vn)
        tangential = 0.5 * density_kgpm3 * self.ct * math.pi * diameter_m * vt * np.abs(vt)
        return normal * s + tangential * c, -normal * c + tangential * s

    def to_dict(self) -> dict[str, Any]:
        """``{"model": "normal_tangential", "cn": ..., "ct": ...}``."""
        return {"model": "normal_tangential", "cn": self.cn, "ct": self.ct}


DragModel = SphereDrag | NormalTangentialDrag


def drag_from_spec(spec: Any, where: str = "cable.drag") -> DragModel:
    """Read ``{model: sphere, cx}`` or ``{model: normal_tangential, cn, ct}`` (missing values: defaults)."""
    if spec is None:
        return SphereDrag()
    if not isinstance(spec, Mapping):
        raise InputError(f"{where}: expected a mapping with a 'model' key")
    model = spec.get("model", "sphere")
    fields = {"sphere": ("cx",), "normal_tangential": ("cn", "ct")}.get(model) if isinstance(model, str) else None
    if fields is None:
        raise InputError(f"{where}.model: unknown drag model {model!r} (sphere or normal_tangential)")
    unknown = set(spec) - {"model", *fields}
    if unknown:
        raise InputError(f"{where}: unknown field(s) {sorted(unknown)} for model {model} (expected {fields})")
    values = {}
    for key in fields:
        if key in spec:
            values[key] = number(f"{where}.{key}", spec[key], minimum=0.0)
    return SphereDrag(**values) if model == "sphere" else NormalTangentialDrag(**values)


@dataclass(frozen=True)
class CableLoading:
    """Everything that loads the cable: water, cable section, drag law, tow speed and current."""

    density_kgpm3: float
    diameter_m: float
    weight_Npm: float  # weight in water per metre, N/m (the paper's p*)
    drag: DragModel
    tow_speed_mps: float
    current: CurrentProfile

    def flow_mps(self, depth_m: np.ndarray | float) -> np.ndarray:
        """Flow speed past the cable at ``depth_m``: V = V_k + V_T(Y) (paper eq. 9), m/s."""
        return self.tow_speed_mps + self.current.speed_at(depth_m)

    def per_length(self, depth_m: np.ndarray, angle_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Total load (aft, down) in N/m on cable at ``depth_m`` lying at ``angle_rad``: drag + weight."""
        flow = self.flow_mps(depth_m)
        aft, down = self.drag.per_length(self.density_kgpm3, self.diameter_m, flow, angle_rad)
        return aft, down + self.weight_Npm
