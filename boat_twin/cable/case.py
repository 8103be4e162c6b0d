"""A towed-cable case (YAML): water, tow speed, current, cable and vehicle, with validation.

Every bad value is an :class:`InputError` naming the file and the field. See docs/cable.md.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from boat_twin.cable.body import Vehicle, coefficient_from_spec
from boat_twin.cable.current import CurrentProfile, current_from_spec
from boat_twin.cable.drag import CableLoading, DragModel, drag_from_spec
from boat_twin.errors import InputError
from boat_twin.files import load_yaml
from boat_twin.units import SEAWATER_DENSITY_KGPM3
from boat_twin.validation import number

_TOP = {"name", "water_density_kgpm3", "tow_speed_mps", "current", "cable", "vehicle", "target_depth_m"}
_CABLE = {"length_m", "diameter_m", "weight_in_water_Npm", "segment_length_m", "winch_capacity_m", "drag"}
_VEHICLE = {"weight_in_water_N", "a_m", "b_m", "d_m", "cx", "cy"}


@dataclass(frozen=True)
class Cable:
    """The cable: diameter d* (m), weight in water p* (N/m), link length l (m), drag law, optional lengths."""

    diameter_m: float
    weight_in_water_Npm: float
    segment_length_m: float
    drag: DragModel
    length_m: float | None = None
    winch_capacity_m: float | None = None


@dataclass(frozen=True)
class CableCase:
    """One towing situation. ``target_depth_m`` is the depth asked for in problem 2 (optional)."""

    name: str
    water_density_kgpm3: float
    tow_speed_mps: float
    current: CurrentProfile
    cable: Cable
    vehicle: Vehicle
    target_depth_m: float | None = None
    source: str = "case"

    def loading(self) -> CableLoading:
        """The loads on the cable for this case's water, section, drag law, tow speed and current."""
        return CableLoading(self.water_density_kgpm3, self.cable.diameter_m, self.cable.weight_in_water_Npm,
                            self.cable.drag, self.tow_speed_mps, self.current)

    def flow_mps(self, depth_m: float) -> float:
        """V = V_k + V_T(Y) at one depth, m/s."""
        return float(self.tow_speed_mps + self.current.speed_at(depth_m))

    def to_dict(self) -> dict[str, Any]:
        """Plain data that :func:`case_from_dict` reads back (the YAML layout)."""
        cable: dict[str, Any] = {
            "diameter_m": self.cable.diameter_m, "weight_in_water_Npm": self.cable.weight_in_water_Npm,
            "segment_length_m": self.cable.segment_length_m, "drag": self.cable.drag.to_dict(),
        }
        for key in ("length_m", "winch_capacity_m"):
            if getattr(self.cable, key) is not None:
                cable[key] = getattr(self.cable, key)
        v = self.vehicle
        data: dict[str, Any] = {
            "name": self.name, "water_density_kgpm3": self.water_density_kgpm3,
            "tow_speed_mps": self.tow_speed_mps, "current": self.current.to_dict(), "cable": cable,
            "vehicle": {"weight_in_water_N": v.weight_in_water_N, "a_m": v.a_m, "b_m": v.b_m, "d_m": v.d_m,
                        "cx": v.cx.to_spec(), "cy": v.cy.to_spec()},
        }
        if self.target_depth_m is not None:
            data["target_depth_m"] = self.target_depth_m
        return data


def _positive(value: Any, where: str, allow_zero: bool = False) -> float:
    return number(where, value, minimum=0.0) if allow_zero else number(where, value, above=0.0)


def _section(data: Mapping[str, Any], key: str, allowed: set[str], where: str) -> Mapping[str, Any]:
    section = data.get(key)
    if not isinstance(section, Mapping):
        raise InputError(f"{where}: '{key}' must be a mapping")
    unknown = set(section) - allowed
    if unknown:
        raise InputError(f"{where}: unknown field(s) {key}.{sorted(unknown)} (expected {sorted(allowed)})")
    return section


def _optional(section: Mapping[str, Any], key: str, where: str) -> float | None:
    return None if section.get(key) is None else _positive(section[key], where)


def case_from_dict(data: Any, source: str = "case") -> CableCase:
    """Validate and build a case from plain data; ``source`` (a file name) prefixes every error."""
    if not isinstance(data, Mapping):
        raise InputError(f"{source}: expected a mapping of case fields")
    unknown = set(data) - _TOP
    if unknown:
        raise InputError(f"{source}: unknown field(s) {sorted(unknown)} (expected {sorted(_TOP)})")
    cable_d = _section(data, "cable", _CABLE, source)
    vehicle_d = _section(data, "vehicle", _VEHICLE, source)

    def field(section: Mapping[str, Any], prefix: str, key: str, allow_zero: bool = False) -> float:
        if key not in section:
            raise InputError(f"{source}: missing field {prefix}{key}")
        return _positive(section[key], f"{source}: {prefix}{key}", allow_zero)

    cable = Cable(
        diameter_m=field(cable_d, "cable.", "diameter_m"),
        weight_in_water_Npm=field(cable_d, "cable.", "weight_in_water_Npm"),
        segment_length_m=field(cable_d, "cable.", "segment_length_m"),
        drag=drag_from_spec(cable_d.get("drag"), f"{source}: cable.drag"),
        length_m=_optional(cable_d, "length_m", f"{source}: cable.length_m"),
        winch_capacity_m=_optional(cable_d, "winch_capacity_m", f"{source}: cable.winch_capacity_m"),
    )
    vehicle = Vehicle(
        weight_in_water_N=field(vehicle_d, "vehicle.", "weight_in_water_N"),
        a_m=field(vehicle_d, "vehicle.", "a_m"),
        b_m=field(vehicle_d, "vehicle.", "b_m"),
        d_m=field(vehicle_d, "vehicle.", "d_m"),
        cx=coefficient_from_spec(vehicle_d.get("cx"), f"{source}: vehicle.cx"),
        cy=coefficient_from_spec(vehicle_d.get("cy", 0.0), f"{source}: vehicle.cy"),
    )
    density = data.get("water_density_kgpm3", SEAWATER_DENSITY_KGPM3)
    case = CableCase(
        name=str(data.get("name", Path(source).stem)),
        water_density_kgpm3=_positive(density, f"{source}: water_density_kgpm3"),
        tow_speed_mps=field(data, "", "tow_speed_mps", allow_zero=True),
        current=current_from_spec(data.get("current", 0.0), f"{source}: current"),
        cable=cable,
        vehicle=vehicle,
        target_depth_m=_optional(data, "target_depth_m", f"{source}: target_depth_m"),
        source=source,
    )
    return check_case(case)


MAX_LINKS = 200_000
"""Most links a cable may be cut into (length / segment length): 0.25 s and ~50 MB per problem-1 solve here; a
1e-6 m segment on a 300 m cable (3e8 links, 19 GB) is refused before any allocation."""


def check_case(case: CableCase) -> CableCase:
    """Cross-field checks: the length fits the winch, the flow never runs backwards past the vehicle, the link
    count stays within :data:`MAX_LINKS`."""
    cable = case.cable
    longest = max(x for x in (cable.length_m, cable.winch_capacity_m, case.target_depth_m, 0.0) if x is not None)
    if longest / cable.segment_length_m > MAX_LINKS:
        raise InputError(f"{case.source}: cable.segment_length_m = {cable.segment_length_m:g} m cuts "
                         f"{longest:g} m of cable into more than {MAX_LINKS} links; use a longer segment")
    capacity = cable.winch_capacity_m
    if cable.length_m is not None and capacity is not None and cable.length_m > capacity:
        raise InputError(f"{case.source}: cable length {cable.length_m:g} m exceeds the winch capacity "
                         f"cable.winch_capacity_m = {capacity:g} m")
    slowest = case.tow_speed_mps + case.current.min_speed_mps
    if slowest < 0.0:
        raise InputError(f"{case.source}: tow speed {case.tow_speed_mps:g} m/s plus current gives a flow of "
                         f"{slowest:g} m/s < 0 somewhere (a following current faster than the tow)")
    return case


def with_overrides(case: CableCase, *, tow_speed_mps: float | None = None, length_m: float | None = None,
                   segment_length_m: float | None = None, target_depth_m: float | None = None) -> CableCase:
    """The case with some values replaced (e.g. from command-line flags), validated like the file's."""
    cable = case.cable
    if length_m is not None:
        cable = replace(cable, length_m=_positive(length_m, "cable length (m)"))
    if segment_length_m is not None:
        cable = replace(cable, segment_length_m=_positive(segment_length_m, "segment length (m)"))
    new = replace(case, cable=cable)
    if tow_speed_mps is not None:
        new = replace(new, tow_speed_mps=_positive(tow_speed_mps, "tow speed (m/s)", allow_zero=True))
    if target_depth_m is not None:
        new = replace(new, target_depth_m=_positive(target_depth_m, "vehicle depth (m)"))
    return check_case(new)


def load_case(path: Path | str) -> CableCase:
    """Read and validate a case YAML file."""
    path = Path(path)
    return case_from_dict(load_yaml(path), str(path))


UNSET_BY_ZERO = ("cable.length_m", "cable.winch_capacity_m", "target_depth_m")
"""Optional fields that, as flat parameters, always exist and mean "not set" when 0.0."""


def _flatten(data: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    flat: dict[str, Any] = {}
    for key, value in data.items():
        if isinstance(value, Mapping):
            flat.update(_flatten(value, f"{prefix}{key}."))
        else:
            flat[f"{prefix}{key}"] = value
    return flat


def case_parameters(case: CableCase) -> dict[str, Any]:
    """The case as flat parameters (ROS style): ``{"cable.drag.cx": 0.47, "current.depth_m": [...], ...}``.

    Values are floats, float lists or strings; the fields of :data:`UNSET_BY_ZERO` are always present.
    """
    flat = _flatten(case.to_dict())
    for key in UNSET_BY_ZERO:
        flat.setdefault(key, 0.0)
    return flat


def case_from_parameters(flat: Mapping[str, Any], source: str = "parameters") -> CableCase:
    """Inverse of :func:`case_parameters` (sequence values of any type are read as lists), validated."""
    data: dict[str, Any] = {}
    for key, value in flat.items():
        if key in UNSET_BY_ZERO and value == 0.0:
            continue
        node = data
        *parents, leaf = key.split(".")
        for part in parents:
            node = node.setdefault(part, {})
        node[leaf] = list(value) if hasattr(value, "__len__") and not isinstance(value, str) else value
    return case_from_dict(data, source)
