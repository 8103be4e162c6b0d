"""Any recorded trial file into a Trial: MAVLink logs (.tlog, .BIN) or bags, and the command-line options
every verb that reads a trial shares (--topic, --namespace, --calibration).

Readers are imported when a file is read, so that building the command line stays cheap.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from boat_twin.errors import InputError
from boat_twin.io.trial import COMMAND_ROLES, SENSOR_ROLES

if TYPE_CHECKING:
    from boat_twin.io.mavlink import Calibration
    from boat_twin.io.trial import Trial

TRIAL_ROLES = COMMAND_ROLES + SENSOR_ROLES
"""Roles a --topic remap may name."""
TRIAL_HELP = ("recorded trial: rosbag2 directory (MCAP or sqlite3), bare .mcap file, MAVLink telemetry log (.tlog) "
              "or DataFlash log (.BIN)")
"""Help text for a verb's TRIAL argument."""


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


def parse_remap(items: list[str] | None) -> dict[str, str]:
    """``["gnss_vel=/gps/vel", ...]`` (repeated --topic values) → ``{"gnss_vel": "/gps/vel"}``."""
    remap: dict[str, str] = {}
    for item in items or []:
        role, sep, topic = item.partition("=")
        role, topic = role.strip(), topic.strip()
        if not sep or not role or not topic:
            raise InputError(f"--topic {item!r}: expected ROLE=TOPIC, e.g. gnss_vel=/gps/vel")
        if role not in TRIAL_ROLES:
            raise InputError(f"--topic {item!r}: unknown role '{role}' (roles: {', '.join(TRIAL_ROLES)})")
        remap[role] = topic
    return remap


def add_trial_options(parser: argparse.ArgumentParser, *, bags: bool = True) -> None:
    """Add --topic ROLE=TOPIC (repeatable), --namespace and --calibration FILE to a verb that reads trials
    (``bags=False``: a verb that reads MAVLink logs only, without --namespace)."""
    mavlink = "GLOBAL_POSITION_INT (default) or GPS_RAW_INT in a .tlog"
    parser.add_argument(
        "--topic", action="append", default=[], metavar="ROLE=TOPIC",
        help=f"where a role comes from: a bag topic (e.g. gnss_vel=/gps/vel; roles: {', '.join(TRIAL_ROLES)}) or, "
        f"for a MAVLink log, the message of gnss_fix or gnss_vel: {mavlink}" if bags
        else f"the message gnss_fix or gnss_vel comes from (e.g. gnss_vel=GPS_RAW_INT): {mavlink}")
    if bags:
        parser.add_argument("--namespace", default="", help="namespace the bag's topics were recorded under")
    parser.add_argument(
        "--calibration", type=Path, metavar="FILE",
        help="MAVLink logs: YAML map from logged PWM (SERVO/RC channels) or MANUAL_CONTROL axes to thrust (N) and "
        "steering angle (rad) per engine; examples in config/mavlink/. Without it, commands are missing.")


def trial_from_args(path: Path | str, args: argparse.Namespace) -> Trial:
    """:func:`read_trial_file` with the options :func:`add_trial_options` added."""
    return read_trial_file(path, remap=parse_remap(getattr(args, "topic", None)),
                           namespace=getattr(args, "namespace", "") or "",
                           calibration=getattr(args, "calibration", None))
