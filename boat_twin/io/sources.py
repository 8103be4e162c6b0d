"""Any recorded trial file into a Trial: MAVLink logs (.tlog, .BIN) or bags.

Readers are imported when a file is read, so that importing this module stays cheap.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from boat_twin.errors import InputError

if TYPE_CHECKING:
    from boat_twin.io.mavlink import Calibration
    from boat_twin.io.trial import Trial



def read_trial_file(
    path: Path | str,
    *,
    remap: dict[str, str] | None = None,
    namespace: str = "",
    calibration: Path | str | Calibration | None = None,
    origin: tuple[float, float, float] | None = None,
) -> Trial:
    """Read ``path`` as a :class:`~boat_twin.io.trial.Trial`: .tlog/.BIN/.bin through
    :func:`boat_twin.io.mavlink.read_mavlink_trial` (``calibration`` maps PWM to N and rad; ``remap`` picks a
    sensor role's message), anything else through :func:`boat_twin.io.bags.read_trial` (``remap`` and
    ``namespace`` pick topics; a calibration is refused there)."""
    path = Path(path)
    from boat_twin.io.mavlink import is_mavlink_log

    if is_mavlink_log(path):
        from boat_twin.io.mavlink import read_mavlink_trial

        cal = Path(calibration) if isinstance(calibration, str) else calibration
        return read_mavlink_trial(path, cal, remap=remap, namespace=namespace, origin=origin)
    if calibration is not None:
        raise InputError(f"{path}: --calibration applies to MAVLink logs (.tlog, .BIN), not to bags")
    from boat_twin.io.bags import read_trial

    return read_trial(path, remap=remap, namespace=namespace, origin=origin)
