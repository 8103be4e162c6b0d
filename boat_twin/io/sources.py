"""Any recorded trial file into a Trial: MAVLink logs (.tlog, .BIN), CSV tables (.csv) or bags.

Readers are imported when a file is read, so that importing this module stays cheap.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from boat_twin.errors import InputError
from boat_twin.files import load_yaml, regular_input

if TYPE_CHECKING:
    from boat_twin.io.mavlink import Calibration
    from boat_twin.io.trial import Trial



def check_trial_path(path: Path) -> None:
    """A trial is a regular file, or a directory (a rosbag2) of regular files: a FIFO, a device or a socket,
    itself or as a bag's metadata.yaml or storage file, is refused (reading it could block forever); a bag's
    metadata.yaml must pass the YAML bounds of :func:`~boat_twin.files.load_yaml` (an alias bomb is refused)."""
    if not (path.exists() or path.is_symlink()):
        return  # each reader names a missing file its own way
    regular_input(path, "trial file")
    if path.is_dir():
        for entry in sorted(path.iterdir()):
            if entry.name == "metadata.yaml" or entry.suffix in (".mcap", ".db3"):
                regular_input(entry, "bag file")
        if (path / "metadata.yaml").is_file():
            load_yaml(path / "metadata.yaml")  # the YAML bounds (size, depth, aliases) before rosbags parses it


def read_trial_file(
    path: Path | str,
    *,
    remap: dict[str, str] | None = None,
    namespace: str = "",
    calibration: Path | str | Calibration | None = None,
    origin: tuple[float, float, float] | None = None,
    columns: str | Path | None = None,
) -> Trial:
    """Read ``path`` as a :class:`~boat_twin.io.trial.Trial`: .tlog/.BIN/.bin through
    :func:`boat_twin.io.mavlink.read_mavlink_trial` (``calibration`` maps PWM to N and rad; ``remap`` picks a
    sensor role's message), anything else through :func:`boat_twin.io.bags.read_trial` (``remap`` and
    ``namespace`` pick topics; a calibration is refused there); a .csv through
    :func:`boat_twin.io.csv_trial.read_csv_trial` with its ``columns`` mapping."""
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

        return read_csv_trial(path, columns)
    if columns is not None:
        raise InputError(f"{path}: --columns applies to CSV trials (.csv), not to bags or MAVLink logs")
    from boat_twin.io.mavlink import is_mavlink_log

    if is_mavlink_log(path):
        from boat_twin.io.mavlink import read_mavlink_trial

        cal = Path(calibration) if isinstance(calibration, str) else calibration
        return read_mavlink_trial(path, cal, remap=remap, namespace=namespace, origin=origin)
    if calibration is not None:
        raise InputError(f"{path}: --calibration applies to MAVLink logs (.tlog, .BIN), not to bags")
    from boat_twin.io.bags import read_trial

    return read_trial(path, remap=remap, namespace=namespace, origin=origin)
