"""Any recorded trial file into a Trial: MAVLink logs (.tlog, .BIN), CSV tables (.csv) or bags.

Readers are imported when a file is read, so that importing this module stays cheap.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from boat_twin.errors import InputError
from boat_twin.files import check_trial_path

if TYPE_CHECKING:
    from boat_twin.io.mavlink import Calibration
    from boat_twin.io.trial import Trial

LOG_SUFFIXES = (".tlog", ".bin")
"""File name endings (case-insensitive) read as MAVLink logs: telemetry logs and DataFlash logs."""


def is_mavlink_log(path: Path) -> bool:
    """Whether ``path`` is read as a MAVLink log (by its ending: .tlog, .bin, .BIN): here, not in the MAVLink
    reader, so that reading a bag does not import that reader."""
    return Path(path).suffix.lower() in LOG_SUFFIXES


def read_trial_file(
    path: Path | str,
    *,
    remap: dict[str, str] | None = None,
    namespace: str = "",
    calibration: Path | str | Calibration | None = None,
    origin: tuple[float, float, float] | None = None,
    columns: str | Path | None = None,
    order: Sequence[str] = (),
) -> Trial:
    """Read ``path`` as a :class:`~boat_twin.io.trial.Trial`: .tlog/.BIN/.bin through
    :func:`boat_twin.io.mavlink.read_mavlink_trial` (``calibration`` maps PWM to N and rad; ``remap`` picks a
    sensor role's message), anything else through :func:`boat_twin.io.bags.read_trial` (``remap`` and
    ``namespace`` pick topics; a calibration is refused there); a .csv through
    :func:`boat_twin.io.csv_trial.read_csv_trial` with its ``columns`` mapping. ``order``: the boat file's actuator
    names in its order (:func:`~boat_twin.io.messages.actuator_order`), which fill a bag's or calibration's
    per-actuator command slots."""
    path = Path(path)
    check_trial_path(path)
    if path.suffix.lower() == ".csv":
        if columns is None:
            raise InputError(f"{path}: a CSV trial needs --columns (e.g. time=t,lat=lat,lon=lon,thrust_left=tl,"
                             "thrust_right=tr; docs/bags-and-trial.md)")
        if remap:
            raise InputError(f"{path}: --topic applies to bags and MAVLink logs; a CSV's columns are named by "
                             "--columns")
        from boat_twin.io.csv_trial import read_csv_trial

        return read_csv_trial(path, columns, order)
    if columns is not None:
        raise InputError(f"{path}: --columns applies to CSV trials (.csv), not to bags or MAVLink logs")
    if is_mavlink_log(path):
        from boat_twin.io.mavlink import read_mavlink_trial

        cal = Path(calibration) if isinstance(calibration, str) else calibration
        return read_mavlink_trial(path, cal, remap=remap, namespace=namespace, origin=origin, order=order)
    if calibration is not None:
        raise InputError(f"{path}: --calibration applies to MAVLink logs (.tlog, .BIN), not to bags")
    from boat_twin.io.bags import read_trial

    return read_trial(path, remap=remap, namespace=namespace, origin=origin, order=order)
