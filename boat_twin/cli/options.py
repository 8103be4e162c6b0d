"""Command-line options shared by the verbs: reading a trial (--topic, --namespace, --calibration) and building the
twin configuration (--config, --model, --current). Cheap to import (the libraries load when a verb runs), so that
``--help`` answers at once."""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

from boat_twin.errors import InputError
from boat_twin.files import ReportSet, refuse_input_as_output, to_json
from boat_twin.io.roles import TRIAL_ROLES

if TYPE_CHECKING:
    from boat_twin.config import TwinConfig
    from boat_twin.fleet.jobs import ReadOptions
    from boat_twin.io.trial import Trial

TRIAL_HELP = ("recorded trial: rosbag2 directory (MCAP or sqlite3), bare .mcap file, MAVLink telemetry log (.tlog), "
              "DataFlash log (.BIN) or CSV table (.csv, with --columns)")
"""Help text for a verb's TRIAL argument."""


def parse_remap(items: list[str] | None, source: str = "--topic") -> dict[str, str]:
    """``["gnss_vel=/gps/vel", ...]`` (repeated --topic values) → ``{"gnss_vel": "/gps/vel"}``; ``source`` names
    where the items came from in an error (a node: ``parameter topics``)."""
    remap: dict[str, str] = {}
    for item in items or []:
        role, sep, topic = item.partition("=")
        role, topic = role.strip(), topic.strip()
        if not sep or not role or not topic:
            raise InputError(f"{source} {item!r}: expected ROLE=TOPIC, e.g. gnss_vel=/gps/vel")
        if role not in TRIAL_ROLES:
            raise InputError(f"{source} {item!r}: unknown role '{role}' (roles: {', '.join(TRIAL_ROLES)})")
        remap[role] = topic
    return remap


def add_trial_options(parser: argparse.ArgumentParser, *, bags: bool = True) -> None:
    """Add --topic ROLE=TOPIC (repeatable), --namespace, --calibration FILE, --columns MAP and --start/--end S to
    a verb that reads trials (``bags=False``: a verb that reads MAVLink logs only: --topic and --calibration)."""
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
            "x/y (east/north) or x_ned/y_ned m, vel_east/vel_north or speed m/s with course deg, heading deg or yaw "
            "rad, yaw_rate rad/s counter-clockwise, thrust_left/thrust_right N, angle_left/angle_right rad) or a "
            "YAML file with columns: (a column, or {column: C, unit: U, frame: ned|enu, sign: cw|ccw}, e.g. time "
            "in ms, heading in deg NED), calibration: (raw command → N or rad tables, e.g. PWM) and origin:; "
            "docs/bags-and-trial.md")
        parser.add_argument("--start", type=float, metavar="S",
                            help="use the trial from S seconds after its start (e.g. to leave out idling)")
        parser.add_argument("--end", type=float, metavar="S",
                            help="use the trial up to S seconds after its start")


def trial_from_args(path: Path | str, args: argparse.Namespace) -> Trial:
    """The trial at ``path`` read with the options :func:`add_trial_options` added (:func:`read_options_from_args`),
    cut to --start/--end."""
    return read_options_from_args(args).read(Path(path))


def read_options_from_args(args: argparse.Namespace) -> ReadOptions:
    """How a verb reads its trials (one, or each of a batch): --topic, --namespace, --calibration, --columns,
    --start/--end, and a --config boat file's per-actuator command topics filling the slots in its own order
    (:func:`~boat_twin.io.messages.actuator_order`)."""
    from boat_twin.fleet.jobs import ReadOptions

    order: tuple[str, ...] = ()
    if getattr(args, "config", None) is not None:
        from boat_twin.config import load_twin_config
        from boat_twin.io.messages import actuator_order

        order = actuator_order(load_twin_config(args.config).vessel.propulsion)
    calibration = getattr(args, "calibration", None)
    return ReadOptions(parse_remap(getattr(args, "topic", None)), getattr(args, "namespace", "") or "",
                       str(calibration) if calibration is not None else None, getattr(args, "columns", None),
                       start_s=getattr(args, "start", None), end_s=getattr(args, "end", None), order=order)


def twin_config_from_args(args: argparse.Namespace) -> TwinConfig:
    """:func:`~boat_twin.config.load_twin_config` from --config, --model and --current (where the verb has them)."""
    from boat_twin.config import load_twin_config

    current = getattr(args, "current", None)
    return load_twin_config(args.config, args.model, tuple(current) if current else None)


def assumed_config(args: argparse.Namespace) -> list[str]:
    """The report warning of a verb run without --config or --model: the built-in boat was assumed."""
    if args.config is None and args.model is None:
        return ["no --config or --model: the built-in boat (its mass, resistance, turning, engines and sensors) "
                "was assumed, not given"]
    return []


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


def add_fleet_options(parser: argparse.ArgumentParser, what: str) -> None:
    """Add --each, --scheduler and --workers to a verb that runs on trials (``what``: its action, e.g.
    "identify")."""
    from boat_twin.fleet.engine import LOCAL, SCHEDULER_HELP

    parser.add_argument(
        "--each", action="store_true",
        help=f"{what} every trial on its own, in parallel (TRIAL: several trials, directories of trials or quoted "
        "glob patterns such as 'logs/**/*.mcap'): each trial's report in --out DIR/<trial name>/, one row per "
        "trial in DIR/summary.csv and DIR/summary.json (columns: docs/fleet.md); a failing trial is reported in "
        "its row; a trial whose report is complete is skipped (resume; --force redoes it)")
    parser.add_argument("--scheduler", default=LOCAL, metavar="WHERE", help="with --each: " + SCHEDULER_HELP)
    parser.add_argument("--workers", type=int, metavar="N",
                        help="with --each and --scheduler local: worker processes (default: one per core)")


def run_each(args: argparse.Namespace, job: Any) -> int:
    """``--each``: ``job`` (:mod:`boat_twin.fleet.jobs`) on every trial of ``args.trial`` into --out, on the
    --scheduler's workers; a line per failed trial and a summary line; exit 2 when a trial failed."""
    from boat_twin.fleet.batch import Progress, run_batch
    from boat_twin.fleet.engine import open_client
    from boat_twin.fleet.trials import expand_trials, name_trials

    if args.out is None:
        raise InputError("--each needs --out DIR: each trial's report goes to DIR/<trial name>/, the summary to "
                         "DIR/summary.csv and DIR/summary.json")
    if not args.trial:
        raise InputError("--each: give the trials (files, rosbag2 directories, directories of trials or a quoted "
                         "glob pattern)")
    if args.out.exists() and not args.out.is_dir():
        raise InputError(f"{args.out}: --out must be a directory for the reports, and this is a file")
    found = expand_trials(args.trial, csv=getattr(args, "columns", None) is not None, skip=args.out.resolve())
    tasks = name_trials(found)
    bar = None if args.json else Progress(job.verb, len(tasks))
    with open_client(args.scheduler, args.workers, quiet=args.json) as client:
        result = run_batch(job, tasks, args.out, client, force=args.force,
                           progress=bar.update if bar is not None else None)
    failed = result.failed
    if args.json:
        sys.stdout.write(to_json(result.rows) + "\n")
    else:
        for row in failed:
            sys.stderr.write(f"{row['trial']}: error: {row['error']}\n")
        others = Counter(row["status"] for row in result.rows if row["status"] not in ("ok", "error"))
        ok = len(result.rows) - len(failed) - sum(others.values())
        also = "".join(f", {n} {status.replace('_', ' ')}" for status, n in sorted(others.items()))
        sys.stdout.write(f"{job.verb}: {len(result.rows)} trial(s), {ok} ok{also} "
                         f"({result.resumed} complete from an earlier run), {len(failed)} failed; summary "
                         f"{result.summary_csv}\n")
    if failed:
        raise InputError(f"{len(failed)} of {len(result.rows)} trial(s) failed, each named with its error in "
                         f"{result.summary_csv} (first: {failed[0]['trial']})")
    return 0


def add_foxglove_options(parser: argparse.ArgumentParser, what: str, allow_remote: bool = True) -> None:
    """Add --foxglove [HOST:PORT] and --foxglove-speed to a verb that can show ``what`` in Foxglove (and
    --allow-remote, unless the verb has its own: ``allow_remote`` False)."""
    from boat_twin.view.address import DEFAULT_HOST, DEFAULT_PORT, VIEW_MCAP

    parser.add_argument(
        "--foxglove", nargs="?", const="", metavar="HOST:PORT",
        help=f"show {what} live in Foxglove (needs foxglove-sdk: pip install '.[view]'): a Foxglove WebSocket "
        f"server on HOST:PORT (default {DEFAULT_HOST}:{DEFAULT_PORT}, loopback; port 0: any free port, printed); "
        f"with --out the same channels go to DIR/{VIEW_MCAP} (channels and the saved layout: docs/live-twin.md)")
    parser.add_argument("--foxglove-speed", type=float, default=1.0, metavar="FACTOR",
                        help="with --foxglove: stream seconds per wall-clock second (default 1: real time; 0: as "
                        "fast as it runs)")
    if allow_remote:
        parser.add_argument("--allow-remote", action="store_true",
                            help="allow a --foxglove address that is not loopback (serves the boat's position to "
                            "the network)")


def foxglove_address(args: argparse.Namespace) -> tuple[str, int] | None:
    """--foxglove's (host, port), None without it; the SDK checked to be there (one line if not)."""
    if args.foxglove is None:
        return None
    from boat_twin.view.address import parse_address, require_sdk

    if not (args.foxglove_speed >= 0.0 and args.foxglove_speed < float("inf")):
        raise InputError(f"--foxglove-speed must be a number >= 0 (0: as fast as it runs), got {args.foxglove_speed}")
    address = parse_address(args.foxglove, allow_remote=args.allow_remote)
    require_sdk()
    return address


def announce_view(url: str | None) -> None:
    """Say where the live view listens (stderr, so that --json stays clean)."""
    if url is not None:
        sys.stderr.write(f"foxglove: live view on {url} (Foxglove: Open connection, Foxglove WebSocket; layout "
                         "config/foxglove/twin_layout.json)\n")
        sys.stderr.flush()
