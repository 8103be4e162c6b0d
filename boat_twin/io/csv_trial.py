"""A CSV trial: one row per time, columns named by a mapping, into a :class:`~boat_twin.io.trial.Trial`.

The mapping names which CSV column holds each quantity (``--columns time=t,lat=latitude,...`` or a YAML file with
``columns:`` and an optional ``calibration:``); the units are fixed per quantity (:data:`CSV_QUANTITIES`). Each
column becomes the stream of its trial role, sampled at the rows where its cell is not blank; the streams then go
on the trial grid as a bag's do (:func:`~boat_twin.io.trial.build_trial`: commands held, sensors interpolated,
NaN GNSS samples dropouts, speed from positions when no velocity column is mapped).
"""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any

import numpy as np
import pymap3d

from boat_twin.errors import InputError
from boat_twin.files import load_yaml
from boat_twin.frames import enu_yaw_from_ned
from boat_twin.io.trial import COMMAND_ROLES, Stream, Trial, build_trial

CSV_QUANTITIES = {
    "time": "time, s (any origin; increasing)",
    "lat": "latitude, deg (WGS-84)",
    "lon": "longitude, deg (WGS-84)",
    "alt": "ellipsoidal height, m (optional)",
    "x": "local east, m (with y, instead of lat/lon; ENU origin from the mapping's origin, default 0 N 0 E)",
    "y": "local north, m",
    "vel_east": "velocity over ground east, m/s",
    "vel_north": "velocity over ground north, m/s",
    "speed": "speed over ground, m/s (with course, or heading/yaw for its direction)",
    "course": "course over ground, deg clockwise from north",
    "heading": "heading, deg clockwise from north (compass)",
    "yaw": "yaw, rad counter-clockwise from east (ENU, REP-103)",
    "yaw_rate": "yaw rate, rad/s counter-clockwise positive",
    "thrust_left": "left thruster's thrust, N (or a raw command with a calibration table)",
    "thrust_right": "right thruster's thrust, N (or raw, calibrated)",
    "angle_left": "left thruster's steering angle, rad (or raw, calibrated); default 0",
    "angle_right": "right thruster's steering angle, rad (or raw, calibrated); default 0",
}
"""Quantity a mapping may name → its unit and meaning (docs/bags-and-trial.md)."""


def parse_columns(spec: str | Path) -> tuple[dict[str, str], dict[str, np.ndarray], tuple[float, float, float]]:
    """``--columns``: a YAML file (``columns:``, ``calibration:``, ``origin:``) or ``quantity=column,...``.

    Returns quantity → CSV column, command role → (k, 2) calibration table (raw → N or rad), and the ENU origin
    (lat deg, lon deg, height m) for local x/y positions."""
    text = str(spec)
    calibration: dict[str, np.ndarray] = {}
    origin = (0.0, 0.0, 0.0)
    if text.endswith((".yaml", ".yml")):
        data = load_yaml(Path(text))
        where = text
        if not isinstance(data, dict) or not isinstance(data.get("columns"), dict):
            raise InputError(f"{where}: expected a mapping with 'columns' (quantity: CSV column)")
        unknown = sorted(set(data) - {"columns", "calibration", "origin"})
        if unknown:
            raise InputError(f"{where}: unknown key '{unknown[0]}' (allowed: columns, calibration, origin)")
        columns = {str(k): str(v) for k, v in data["columns"].items()}
        if not isinstance(data.get("calibration") or {}, dict):
            raise InputError(f"{where}: calibration: expected a mapping of command role: table, got "
                             f"{type(data['calibration']).__name__}")
        for role, table in (data.get("calibration") or {}).items():
            calibration[str(role)] = _table(table, f"{where}: calibration.{role}")
        if "origin" in data:
            origin = _origin(data["origin"], f"{where}: origin")
    else:
        where = "--columns"
        columns = {}
        for item in text.split(","):
            key, sep, column = (part.strip() for part in item.partition("="))
            if not sep or not key or not column:
                raise InputError(f"--columns {item!r}: expected QUANTITY=COLUMN, e.g. time=t")
            columns[key] = column
    unknown = sorted(set(columns) - set(CSV_QUANTITIES))
    if unknown:
        raise InputError(f"{where}: unknown quantity '{unknown[0]}' (quantities: {', '.join(CSV_QUANTITIES)})")
    for role in calibration:
        if role not in COMMAND_ROLES:
            raise InputError(f"{where}: calibration for '{role}': only commands ({', '.join(COMMAND_ROLES)}) take one")
    _check_mapping(columns, where)
    return columns, calibration, origin


def _table(table: Any, where: str) -> np.ndarray:
    try:
        arr = np.asarray(table, dtype=float)
    except (TypeError, ValueError):
        arr = np.empty(0)
    if arr.ndim != 2 or arr.shape[1] != 2 or arr.shape[0] < 2 or not np.all(np.isfinite(arr)) \
            or not np.all(np.diff(arr[:, 0]) > 0):
        raise InputError(f"{where}: expected at least two [raw, value] pairs with raw increasing")
    return arr


def _origin(value: Any, where: str) -> tuple[float, float, float]:
    if not isinstance(value, list) or len(value) not in (2, 3) or \
            not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
        raise InputError(f"{where}: expected [lat_deg, lon_deg] or [lat_deg, lon_deg, height_m]")
    return (float(value[0]), float(value[1]), float(value[2]) if len(value) == 3 else 0.0)


def _check_mapping(columns: dict[str, str], where: str) -> None:
    """What a trial needs: time, a position or velocity, a command; pairs mapped together."""
    def has(*keys: str) -> bool:
        return all(k in columns for k in keys)
    if "time" not in columns:
        raise InputError(f"{where}: no 'time' column mapped")
    for a, b in (("lat", "lon"), ("x", "y"), ("vel_east", "vel_north")):
        if (a in columns) != (b in columns):
            raise InputError(f"{where}: '{a}' and '{b}' go together; map both")
    if has("lat") and has("x"):
        raise InputError(f"{where}: map positions as lat/lon or as x/y, not both")
    if "speed" in columns and not any(k in columns for k in ("course", "heading", "yaw")):
        raise InputError(f"{where}: 'speed' needs 'course', 'heading' or 'yaw' for its direction")
    if not any(k in columns for k in ("lat", "x", "vel_east", "speed")):
        raise InputError(f"{where}: no position (lat/lon, x/y) or velocity (vel_east/vel_north, speed) mapped")
    if not any(k in columns for k in ("thrust_left", "thrust_right")):
        raise InputError(f"{where}: no thrust column mapped (thrust_left, thrust_right)")


def _read_columns(path: Path, columns: dict[str, str]) -> dict[str, np.ndarray]:
    """The mapped columns as float arrays (NaN where a cell is blank); errors name the file, row and column."""
    try:
        with path.open(newline="") as fh:
            reader = csv.reader(fh)
            header = [h.strip() for h in next(reader, [])]
            index = {}
            for quantity, name in columns.items():
                if name not in header:
                    raise InputError(f"{path}: column '{name}' (for {quantity}) is not in the header; it has: "
                                     + ", ".join(header))
                index[quantity] = header.index(name)
            rows: list[list[float]] = []
            lines: list[int] = []
            for row_no, row in enumerate(reader, start=2):
                if not row or all(not cell.strip() for cell in row):
                    continue
                values = []
                for quantity, k in index.items():
                    cell = row[k].strip() if k < len(row) else ""
                    if not cell:
                        values.append(math.nan)
                        continue
                    try:
                        number = float(cell)
                    except ValueError:
                        raise InputError(f"{path}: row {row_no}, column '{columns[quantity]}': not a number "
                                         f"({cell[:20]!r})") from None
                    if math.isinf(number):
                        raise InputError(f"{path}: row {row_no}, column '{columns[quantity]}': infinite value")
                    values.append(number)
                rows.append(values)
                lines.append(row_no)
    except OSError as err:
        raise InputError(f"{path}: cannot read ({err.strerror})") from None
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a text CSV file") from None
    except csv.Error as err:
        raise InputError(f"{path}: malformed CSV ({err})") from None
    if len(rows) < 2:
        raise InputError(f"{path}: fewer than two data rows")
    table = np.array(rows)
    data = {quantity: table[:, j] for j, quantity in enumerate(index)}
    t = data["time"]
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise InputError(f"{path}: row {lines[bad[0]]}, column '{columns['time']}': time is blank")
    back = np.flatnonzero(np.diff(t) <= 0)
    if back.size:
        raise InputError(f"{path}: row {lines[back[0] + 1]}, column '{columns['time']}': time {t[back[0] + 1]:g} s "
                         f"does not increase (previous {t[back[0]]:g} s)")
    return data


def _stream(t: np.ndarray, *columns: np.ndarray) -> Stream:
    """The rows where the first column is known (a blank cell: not sampled in that row)."""
    values = np.column_stack(columns)
    keep = np.isfinite(values[:, 0])
    return Stream(t[keep], values[keep])


def read_csv_trial(path: Path, columns: str | Path) -> Trial:
    """Read a CSV trial with the ``columns`` mapping (:func:`parse_columns`) into a :class:`Trial`."""
    path = Path(path)
    mapping, calibration, origin = parse_columns(columns)
    data = _read_columns(path, mapping)
    t = data["time"]
    streams: dict[str, Stream] = {}
    topics: dict[str, str] = {}
    nan = np.full(t.size, np.nan)
    if "lat" in mapping:
        streams["gnss_fix"] = _stream(t, data["lat"], data["lon"], data.get("alt", np.zeros(t.size)))
        topics["gnss_fix"] = f"columns {mapping['lat']}, {mapping['lon']}"
    elif "x" in mapping:
        lat, lon, alt = pymap3d.enu2geodetic(data["x"], data["y"], np.zeros(t.size), *origin)
        streams["gnss_fix"] = _stream(t, lat, lon, alt)
        topics["gnss_fix"] = f"columns {mapping['x']}, {mapping['y']} (local ENU)"
    yaw = enu_yaw_from_ned(np.radians(data["heading"])) if "heading" in mapping else data.get("yaw", nan)
    if "vel_east" in mapping:
        streams["gnss_vel"] = _stream(t, data["vel_east"], data["vel_north"])
        topics["gnss_vel"] = f"columns {mapping['vel_east']}, {mapping['vel_north']}"
    elif "speed" in mapping:
        direction = enu_yaw_from_ned(np.radians(data["course"])) if "course" in mapping else yaw
        speed = data["speed"]
        streams["gnss_vel"] = _stream(t, speed * np.cos(direction), speed * np.sin(direction))
        topics["gnss_vel"] = f"column {mapping['speed']} along " + (
            f"course {mapping['course']}" if "course" in mapping else "the heading")
    if "yaw_rate" in mapping or "yaw" in mapping or "heading" in mapping:
        rate = data.get("yaw_rate", nan)
        known = np.isfinite(yaw) | np.isfinite(rate)
        streams["imu"] = Stream(t[known], np.column_stack([yaw, rate, nan, nan])[known])
        topics["imu"] = "columns " + ", ".join(mapping[k] for k in ("heading", "yaw", "yaw_rate") if k in mapping)
    for role in COMMAND_ROLES:
        if role in mapping:
            raw = data[role]
            value = raw if role not in calibration else np.interp(raw, calibration[role][:, 0],
                                                                  calibration[role][:, 1])
            streams[role] = _stream(t, np.where(np.isfinite(raw), value, np.nan))
            topics[role] = f"column {mapping[role]}" + (" (calibrated)" if role in calibration else "")
    return build_trial(streams, str(path), topics, origin if "x" in mapping else None)
