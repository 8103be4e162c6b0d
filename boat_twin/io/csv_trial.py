"""A CSV trial: one row per time, columns named by a mapping, into a :class:`~boat_twin.io.trial.Trial`.

The mapping names which CSV column holds each quantity (``--columns time=t,lat=latitude,...`` or a YAML file with
``columns:``, an optional ``calibration:`` and ``origin:``). A quantity's column is a name (the quantity's default
unit and convention, :data:`CSV_QUANTITIES`) or, in the YAML form, ``{column: NAME, unit: U, frame: ned|enu,
sign: cw|ccw}`` (:data:`CSV_UNITS`): each column is converted once, here, to SI, ENU and FLU. Each column becomes
the stream of its trial role, sampled at the rows where its cell is not blank; the streams then go on the trial
grid as a bag's do (:func:`~boat_twin.io.trial.build_trial`: commands held, sensors interpolated, NaN GNSS samples
dropouts, speed from positions when no velocity column is mapped).
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pymap3d

from boat_twin.errors import InputError
from boat_twin.files import load_yaml
from boat_twin.frames import enu_yaw_from_ned
from boat_twin.io.roles import ONE_THRUSTER_NOTE, actuator_roles
from boat_twin.io.trial import COMMAND_ROLES, Stream, Trial, build_trial, empty_second_thruster
from boat_twin.units import KGF_N, KNOT_MPS

CSV_QUANTITIES = {
    "time": "time, s (any origin; increasing; unit s, ms, us or ns)",
    "lat": "latitude, deg (WGS-84)",
    "lon": "longitude, deg (WGS-84)",
    "alt": "ellipsoidal height, m (optional)",
    "x": "local east, m (with y, instead of lat/lon; ENU origin from the mapping's origin, default 0 N 0 E)",
    "y": "local north, m",
    "x_ned": "local north, m (with y_ned: NED positions, instead of lat/lon or x/y; origin as for x/y)",
    "y_ned": "local east, m",
    "vel_east": "velocity over ground east, m/s (or kn, km/h)",
    "vel_north": "velocity over ground north, m/s (or kn, km/h)",
    "speed": "speed over ground, m/s or kn or km/h (with course, or heading/yaw for its direction)",
    "course": "course over ground, deg clockwise from north (frame ned; enu: counter-clockwise from east; or rad)",
    "heading": "heading, deg clockwise from north (compass; frame ned; enu: counter-clockwise from east; or rad)",
    "yaw": "yaw, rad counter-clockwise from east (ENU, REP-103; frame ned: clockwise from north; or deg)",
    "yaw_rate": "yaw rate, rad/s counter-clockwise positive (sign ccw; cw: clockwise, NED; or deg/s)",
    "thrust_left": "left thruster's thrust, N or kgf (or a raw command with a calibration table)",
    "thrust_right": "right thruster's thrust, N or kgf (or raw, calibrated)",
    "angle_left": "left thruster's steering angle, rad or deg (or raw, calibrated); default 0",
    "angle_right": "right thruster's steering angle, rad or deg (or raw, calibrated); default 0",
    "wind_speed": "measured true wind speed over ground, m/s (or kn, km/h): an anemometer (optional)",
    "wind_from": "direction the true wind comes from, deg clockwise from north (meteorological; or rad)",
    "wind_east": "true wind over ground, east component of the air's velocity (where it blows to), m/s",
    "wind_north": "true wind over ground, north component, m/s",
}
"""Quantity a mapping may name → its default unit and meaning (docs/bags-and-trial.md)."""

TIME_UNITS_S = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
ANGLE_UNITS_RAD = {"rad": 1.0, "deg": math.pi / 180.0}
CSV_UNITS: dict[str, dict[str, float]] = {
    "time": TIME_UNITS_S, "length": {"m": 1.0}, "angle": ANGLE_UNITS_RAD,
    "rate": {"rad/s": 1.0, "deg/s": math.pi / 180.0},
    "speed": {"m/s": 1.0, "kn": KNOT_MPS, "km/h": 1.0 / 3.6},
    "force": {"N": 1.0, "kgf": KGF_N, "command": 1.0, "rev/s": 1.0, "rpm": 1.0 / 60.0},
}
"""Unit family → unit name → its size in SI (s, m, rad, rad/s, m/s, N). A thrust column may hold a boat file's
thruster command instead (docs/model.md, "Propulsion and steering"): ``command`` (its table's unit, read as is),
``rev/s`` or ``rpm`` (a propeller's shaft speed, read in rev/s)."""
_COMMAND_UNITS = ("command", "rev/s", "rpm")
"""The force family's units that are a thruster's command, not a force."""
_KIND = {"time": "time", "lat": "angle", "lon": "angle", "alt": "length", "x": "length", "y": "length",
         "x_ned": "length", "y_ned": "length", "vel_east": "speed", "vel_north": "speed", "speed": "speed",
         "course": "angle", "heading": "angle", "yaw": "angle", "yaw_rate": "rate", "thrust_left": "force",
         "thrust_right": "force", "angle_left": "angle", "angle_right": "angle", "wind_speed": "speed",
         "wind_from": "angle", "wind_east": "speed", "wind_north": "speed"}
_DEFAULT_UNIT = {"time": "s", "lat": "deg", "lon": "deg", "course": "deg", "heading": "deg", "yaw": "rad",
                 "yaw_rate": "rad/s", "thrust_left": "N", "thrust_right": "N", "angle_left": "rad",
                 "angle_right": "rad", "wind_from": "deg"}
_DEFAULT_FRAME = {"course": "ned", "heading": "ned", "yaw": "enu"}
"""Angles measured from north clockwise (ned) or from east counter-clockwise (enu), by default."""
TIME_STEP_BOUNDS_S = (5e-4, 10.0)
"""A CSV's median time step between rows must lie within these, s (2 kHz to 0.1 Hz): outside, the time column is
in another unit than the one mapped (milliseconds read as seconds give a 10 Hz log a 100 s step)."""


@dataclass(frozen=True)
class ColumnSpec:
    """One mapped column: its CSV name, its SI scale, and its convention (ENU/NED angle, yaw-rate sign)."""

    column: str
    scale: float = 1.0
    """SI size of one unit of the column (e.g. 1e-3 for a time in ms)."""
    unit: str = ""
    """Unit named in the mapping ('' when it is the quantity's default)."""
    frame: str = ""
    """'ned' (clockwise from north) or 'enu' (counter-clockwise from east): course, heading, yaw."""
    clockwise: bool = False
    """A yaw rate positive clockwise (sign cw, NED): negated into ENU."""
    actuator: str = ""
    """The boat's actuator topic the mapping named this command by ('' for a slot role or a sensor)."""


def parse_columns(spec: str | Path, order: Sequence[str] = ()
                  ) -> tuple[dict[str, ColumnSpec], dict[str, np.ndarray], tuple[float, float, float]]:
    """``--columns``: a YAML file (``columns:``, ``calibration:``, ``origin:``) or ``quantity=column,...``.

    The commands are named by role (``thrust_left``...) or, for a boat file's thrusters and rudders, by their
    command topics (``thrusters/<name>/thrust|cmd|pos``, ``rudders/<name>/angle``), which fill the slots as a bag's
    topics do (:func:`~boat_twin.io.roles.actuator_roles`; ``order``: the boat file's actuator names in its order).
    Returns quantity → :class:`ColumnSpec` (commands under their slot role, each spec naming its actuator),
    command role → (k, 2) calibration table (raw → N, the thruster's unit or rad), and the ENU origin (lat deg,
    lon deg, height m) for local positions."""
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
        raw_columns: dict[str, Any] = {str(k): v for k, v in data["columns"].items()}
        if not isinstance(data.get("calibration") or {}, dict):
            raise InputError(f"{where}: calibration: expected a mapping of command role: table, got "
                             f"{type(data['calibration']).__name__}")
        for role, table in (data.get("calibration") or {}).items():
            calibration[str(role)] = _table(table, f"{where}: calibration.{role}")
        if "origin" in data:
            origin = _origin(data["origin"], f"{where}: origin")
    else:
        where = "--columns"
        raw_columns = {}
        for item in text.split(","):
            key, sep, column = (part.strip() for part in item.partition("="))
            if not sep or not key or not column:
                raise InputError(f"--columns {item!r}: expected QUANTITY=COLUMN, e.g. time=t")
            raw_columns[key] = column
    roles = actuator_roles(raw_columns, f"{where}: columns", order)
    unknown = sorted(set(raw_columns) - set(CSV_QUANTITIES) - set(roles))
    if unknown:
        raise InputError(f"{where}: unknown quantity '{unknown[0]}' (quantities: {', '.join(CSV_QUANTITIES)}, or a "
                         "boat file's thrusters/<name>/thrust|cmd|pos and rudders/<name>/angle)")
    columns = {roles.get(key, key): _spec(roles.get(key, key), value, f"{where}: columns.{key}", key)
               for key, value in raw_columns.items()}
    for key in list(calibration):
        role = roles.get(key, key)
        if role not in COMMAND_ROLES or (roles and key == role):
            raise InputError(f"{where}: calibration for '{key}': only mapped commands ("
                             + (", ".join(roles) if roles else ", ".join(COMMAND_ROLES)) + ") take one")
        if role in columns and columns[role].unit:
            raise InputError(f"{where}: columns.{key}: a calibrated command's table gives its value in SI "
                             "(N or rad) or the thruster's unit; drop its unit")
        calibration[role] = calibration.pop(key)
    _check_mapping(columns, where)
    return columns, calibration, origin


def _spec(quantity: str, value: Any, where: str, key: str) -> ColumnSpec:
    """A column as mapped under ``key`` (the quantity, or a boat's actuator topic read as ``quantity``): a name, or
    ``{column, unit, frame, sign}`` (unit, frame and sign checked; a thruster's ``cmd`` read in its own unit
    by default, its ``thrust`` in N or kgf)."""
    if isinstance(value, (str, int)) and not isinstance(value, bool):
        value = {"column": value}
    if not isinstance(value, dict) or not isinstance(value.get("column"), (str, int)):
        raise InputError(f"{where}: expected a column name or {{column: NAME, unit: U}}")
    allowed = {"column", "unit"} | ({"frame"} if quantity in _DEFAULT_FRAME else set()) | \
        ({"sign"} if quantity == "yaw_rate" else set())
    extra = sorted(set(value) - allowed)
    if extra:
        raise InputError(f"{where}: unknown key '{extra[0]}' (allowed here: {', '.join(sorted(allowed))})")
    units = CSV_UNITS[_KIND[quantity]]
    default = _DEFAULT_UNIT.get(quantity, next(iter(units)))
    if key.endswith("/cmd"):
        units, default = {u: units[u] for u in _COMMAND_UNITS}, "command"
    elif key.endswith("/thrust"):
        units = {u: s for u, s in units.items() if u not in _COMMAND_UNITS}
    unit = str(value.get("unit", default))
    if unit not in units:
        raise InputError(f"{where}: unknown unit '{unit}' (units: {', '.join(units)})")
    frame = str(value.get("frame", _DEFAULT_FRAME.get(quantity, ""))).lower()
    if quantity in _DEFAULT_FRAME and frame not in ("ned", "enu"):
        raise InputError(f"{where}: frame '{frame}': expected ned (clockwise from north) or enu "
                         "(counter-clockwise from east)")
    sign = str(value.get("sign", "ccw")).lower()
    if sign not in ("cw", "ccw"):
        raise InputError(f"{where}: sign '{sign}': expected ccw (counter-clockwise positive, ENU/FLU) or cw "
                         "(clockwise positive, NED)")
    return ColumnSpec(str(value["column"]), units[unit], unit if "unit" in value else "", frame, sign == "cw",
                      key if key != quantity else "")


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


def _check_mapping(columns: dict[str, ColumnSpec], where: str) -> None:
    """What a trial needs: time, a position or velocity, a command; pairs mapped together."""
    if "time" not in columns:
        raise InputError(f"{where}: no 'time' column mapped")
    for a, b in (("lat", "lon"), ("x", "y"), ("x_ned", "y_ned"), ("vel_east", "vel_north"),
                 ("wind_speed", "wind_from"), ("wind_east", "wind_north")):
        if (a in columns) != (b in columns):
            raise InputError(f"{where}: '{a}' and '{b}' go together; map both")
    positions = [k for k in ("lat", "x", "x_ned") if k in columns]
    if len(positions) > 1:
        raise InputError(f"{where}: map positions one way (lat/lon, x/y or x_ned/y_ned), not as "
                         + " and ".join(positions))
    if "speed" in columns and not any(k in columns for k in ("course", "heading", "yaw")):
        raise InputError(f"{where}: 'speed' needs 'course', 'heading' or 'yaw' for its direction")
    if not positions and not any(k in columns for k in ("vel_east", "speed")):
        raise InputError(f"{where}: no position (lat/lon, x/y, x_ned/y_ned) or velocity (vel_east/vel_north, "
                         "speed) mapped")
    if not any(k in columns for k in ("thrust_left", "thrust_right")):
        raise InputError(f"{where}: no thrust column mapped (thrust_left, thrust_right, or a boat file's "
                         "thrusters/<name>/thrust|cmd)")


def _read_columns(path: Path, columns: dict[str, ColumnSpec]) -> dict[str, np.ndarray]:
    """The mapped columns as float arrays in the mapping's units (NaN where a cell is blank); errors name the file,
    row and column."""
    names = {quantity: spec.column for quantity, spec in columns.items()}
    try:
        with path.open(newline="") as fh:
            reader = csv.reader(fh)
            header = [h.strip() for h in next(reader, [])]
            index = {}
            for quantity, name in names.items():
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
                        raise InputError(f"{path}: row {row_no}, column '{names[quantity]}': not a number "
                                         f"({cell[:20]!r})") from None
                    if math.isinf(number):
                        raise InputError(f"{path}: row {row_no}, column '{names[quantity]}': infinite value")
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
    time = columns["time"]
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise InputError(f"{path}: row {lines[bad[0]]}, column '{time.column}': time is blank")
    back = np.flatnonzero(np.diff(t) <= 0)
    if back.size:
        raise InputError(f"{path}: row {lines[back[0] + 1]}, column '{time.column}': time {t[back[0] + 1]:g} "
                         f"{time.unit or 's'} does not increase (previous {t[back[0]]:g} {time.unit or 's'})")
    _check_time_step(path, time, float(np.median(np.diff(t))))
    return data


def _check_time_step(path: Path, time: ColumnSpec, step: float) -> None:
    """Refuse a time column whose median step between rows is no trial's (:data:`TIME_STEP_BOUNDS_S`), naming
    the unit that would make it one (10 Hz to 100 Hz rows)."""
    low, high = TIME_STEP_BOUNDS_S
    step_s = step * time.scale
    if low <= step_s <= high:
        return
    unit = time.unit or "s"
    likely = [name for name, scale in TIME_UNITS_S.items() if 0.005 <= step * scale <= 1.0]
    hint = (f"if it is in {likely[0]}, map it as time: {{column: {time.column}, unit: {likely[0]}}} "
            "(a YAML --columns file)") if likely else "check which column holds the time"
    raise InputError(f"{path}: column '{time.column}' (time, read as {unit}): median step {step_s:.3g} s between "
                     f"rows ({1.0 / step_s:.3g} Hz) is no trial's sampling; {hint}; docs/bags-and-trial.md")


def _stream(t: np.ndarray, *columns: np.ndarray) -> Stream:
    """The rows where the first column is known (a blank cell: not sampled in that row)."""
    values = np.column_stack(columns)
    keep = np.isfinite(values[:, 0])
    return Stream(t[keep], values[keep])


def _si(data: dict[str, np.ndarray], mapping: dict[str, ColumnSpec]) -> dict[str, np.ndarray]:
    """Every column in SI, ENU and FLU: scaled by its unit (time from the first row, that row's time in
    ``time0``); course and heading as ENU yaw (rad), a clockwise yaw
    rate negated; NED positions as east and north."""
    out = {quantity: values * mapping[quantity].scale for quantity, values in data.items()}
    out["time"] = (data["time"] - data["time"][0]) * mapping["time"].scale  # exact for epoch ms or ns in a float
    out["time0"] = np.asarray(data["time"][0] * mapping["time"].scale)
    for quantity in ("course", "heading", "yaw"):
        if quantity in out and mapping[quantity].frame == "ned":
            out[quantity] = enu_yaw_from_ned(out[quantity])
    if "yaw_rate" in out and mapping["yaw_rate"].clockwise:
        out["yaw_rate"] = -out["yaw_rate"]
    if "x_ned" in out:
        out["x"], out["y"] = out.pop("y_ned"), out.pop("x_ned")
    return out


def _wind(data: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray] | None:
    """The measured true wind (east, north: where the air goes, m/s) from its speed and the direction it comes
    from (clockwise from north), or from its components; None without either pair."""
    if "wind_east" in data and "wind_north" in data:
        return data["wind_east"], data["wind_north"]
    if "wind_speed" in data and "wind_from" in data:
        towards = data["wind_from"] + math.pi  # it blows towards the opposite bearing
        return data["wind_speed"] * np.sin(towards), data["wind_speed"] * np.cos(towards)
    return None


def read_csv_trial(path: Path, columns: str | Path, order: Sequence[str] = ()) -> Trial:
    """Read a CSV trial with the ``columns`` mapping (:func:`parse_columns`; ``order``: the boat file's actuator
    names in its order) into a :class:`Trial`."""
    path = Path(path)
    mapping, calibration, origin = parse_columns(columns, order)
    name = {quantity: spec.column for quantity, spec in mapping.items()}
    data = _si(_read_columns(path, mapping), mapping)
    first_s = data.pop("time0")
    t = data["time"]
    streams: dict[str, Stream] = {}
    topics: dict[str, str] = {}
    nan = np.full(t.size, np.nan)
    local = "x" in data
    if "lat" in data:
        streams["gnss_fix"] = _stream(t, np.degrees(data["lat"]), np.degrees(data["lon"]),
                                      data.get("alt", np.zeros(t.size)))
        topics["gnss_fix"] = f"columns {name['lat']}, {name['lon']}"
    elif local:
        lat, lon, alt = pymap3d.enu2geodetic(data["x"], data["y"], np.zeros(t.size), *origin)
        streams["gnss_fix"] = _stream(t, lat, lon, alt)
        ned = "x_ned" in mapping
        topics["gnss_fix"] = (f"columns {name['x_ned']}, {name['y_ned']} (local NED)" if ned
                              else f"columns {name['x']}, {name['y']} (local ENU)")
    yaw = data["heading"] if "heading" in data else data.get("yaw", nan)
    if "vel_east" in data:
        streams["gnss_vel"] = _stream(t, data["vel_east"], data["vel_north"])
        topics["gnss_vel"] = f"columns {name['vel_east']}, {name['vel_north']}"
    elif "speed" in data:
        direction = data.get("course", yaw)
        speed = data["speed"]
        streams["gnss_vel"] = _stream(t, speed * np.cos(direction), speed * np.sin(direction))
        topics["gnss_vel"] = f"column {name['speed']} along " + (
            f"course {name['course']}" if "course" in data else "the heading")
    if "yaw_rate" in data or "yaw" in data or "heading" in data:
        rate = data.get("yaw_rate", nan)
        known = np.isfinite(yaw) | np.isfinite(rate)
        streams["imu"] = Stream(t[known], np.column_stack([yaw, rate, nan, nan])[known])
        topics["imu"] = "columns " + ", ".join(name[k] for k in ("heading", "yaw", "yaw_rate") if k in name)
    wind = _wind(data)
    if wind is not None:
        streams["wind"] = _stream(t, *wind)
        topics["wind"] = "columns " + ", ".join(name[k] for k in ("wind_speed", "wind_from", "wind_east",
                                                                   "wind_north") if k in name)
    for role in COMMAND_ROLES:
        if role in data:
            raw = data[role]
            value = raw if role not in calibration else np.interp(raw, calibration[role][:, 0],
                                                                  calibration[role][:, 1])
            streams[role] = _stream(t, np.where(np.isfinite(raw), value, np.nan))
            actuator = mapping[role].actuator
            topics[role] = (f"column {name[role]}" + (f" ({actuator})" if actuator else "")
                            + (" (calibrated)" if role in calibration else ""))
    single = bool(mapping.get("thrust_left", ColumnSpec("")).actuator) and "thrust_right" not in mapping
    if single:
        empty_second_thruster(streams)
    trial = build_trial(streams, str(path), topics, origin if local else None)
    if single:
        trial.metadata.stream_choices.append(ONE_THRUSTER_NOTE)
    trial.metadata.start_time_s += float(first_s)
    return trial
