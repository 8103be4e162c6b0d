"""Command-line options shared by the verbs: reading a trial (--topic, --namespace, --calibration) and building the
twin configuration (--config, --model, --current). Cheap to import (the libraries load when a verb runs), so that
``--help`` answers at once."""

from __future__ import annotations

import argparse
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

from boat_twin.errors import InputError
from boat_twin.files import ReportSet, refuse_input_as_output
from boat_twin.io.roles import TRIAL_ROLES

if TYPE_CHECKING:
    from boat_twin.config import TwinConfig
    from boat_twin.io.trial import Trial

TRIAL_HELP = ("recorded trial: rosbag2 directory (MCAP or sqlite3), bare .mcap file, MAVLink telemetry log (.tlog), "
              "DataFlash log (.BIN) or CSV table (.csv, with --columns)")
"""Help text for a verb's TRIAL argument."""


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
        parser.add_argument("--namespace", default="", metavar="NS",
                            help="namespace the bag's topics were recorded under")
    parser.add_argument(
        "--calibration", type=Path, metavar="FILE",
        help="MAVLink logs: YAML map from logged PWM (SERVO/RC channels) or MANUAL_CONTROL axes to thrust (N) and "
        "steering angle (rad) per engine; examples in config/mavlink/. Without it, commands are missing.")
    if bags:
        parser.add_argument(
            "--columns", metavar="MAP",
            help="CSV trials: which column holds what, as QUANTITY=COLUMN,... (quantities: time s, lat/lon deg or "
            "x/y m, vel_east/vel_north or speed m/s with course deg, heading deg or yaw rad, yaw_rate rad/s, "
            "thrust_left/thrust_right N, angle_left/angle_right rad) or a YAML file with columns:, calibration: "
            "(raw command → N or rad tables, e.g. PWM) and origin:; docs/bags-and-trial.md")


def trial_from_args(path: Path | str, args: argparse.Namespace) -> Trial:
    """:func:`~boat_twin.io.sources.read_trial_file` with the options :func:`add_trial_options` added."""
    from boat_twin.io.sources import read_trial_file

    return read_trial_file(path, remap=parse_remap(getattr(args, "topic", None)),
                           namespace=getattr(args, "namespace", "") or "",
                           calibration=getattr(args, "calibration", None), columns=getattr(args, "columns", None))


def twin_config_from_args(args: argparse.Namespace) -> TwinConfig:
    """:func:`~boat_twin.config.load_twin_config` from --config, --model and --current (where the verb has them)."""
    from boat_twin.config import load_twin_config

    current = getattr(args, "current", None)
    return load_twin_config(args.config, args.model, tuple(current) if current else None)


def trial_inputs(args: argparse.Namespace) -> list[Path]:
    """The files a verb reading trials takes in (trials, --calibration, a --columns YAML, --config, --model,
    --boat, --validate): none may lie inside its --out."""
    trials = getattr(args, "trial", None)
    paths = list(trials) if isinstance(trials, list) else [trials]
    paths += list(getattr(args, "validate", None) or [])
    columns = getattr(args, "columns", None)
    if columns and str(columns).endswith((".yaml", ".yml")):
        paths.append(Path(columns))
    paths += [getattr(args, name, None) for name in ("calibration", "config", "model", "boat")]
    return [Path(p) for p in paths if p is not None]


@contextmanager
def claim_out_dir(out: Path | None, names: tuple[str, ...], force: bool,
                  inputs: list[Path] | tuple[Path, ...] = ()) -> Iterator[ReportSet | None]:
    """--out DIR checked before any work and held for the run, as one output (:class:`~boat_twin.files.ReportSet`):
    the report files ``names`` already there are refused without --force, a file given as --out is refused, an
    input inside DIR is refused, a second run writing reports into DIR at the same time is refused. The caller
    writes into ``.staging``; leaving the ``with`` normally swaps the whole new set in, an error or an interrupt
    keeps the old one."""
    if out is None:
        yield None
        return
    refuse_input_as_output(out, *inputs)
    with ReportSet(out, names, force) as reports:
        yield reports
        reports.commit()
