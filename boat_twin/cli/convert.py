"""``boat-twin convert``: a MAVLink log (.tlog, .BIN) as a rosbag2 with the package's topics.

The log's samples are written as they were logged (not resampled): ``gnss/fix`` (NavSatFix, covariance
unknown), ``gnss/vel`` (TwistStamped, ENU velocity over ground), ``imu/data`` (Imu, FLU in ENU, gravity
included; REP-145: covariances unknown, element 0 = −1 where a field is not in the log) and the four thruster
topics (Float64, N and rad, through the calibration). Header stamps and log times are the log's clock
(:mod:`boat_twin.io.mavlink`). The bag is written next to its target and renamed into place.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from boat_twin.cli import verb_help
from boat_twin.cli.options import add_trial_options, parse_remap
from boat_twin.errors import InputError
from boat_twin.files import refuse_input_as_output, regular_input, to_json
from boat_twin.io.roles import COMMAND_ROLES


def run(args: argparse.Namespace) -> int:
    """Handler of ``boat-twin convert``."""
    from boat_twin.io.bags import write_bag
    from boat_twin.io.log_messages import log_messages
    from boat_twin.io.mavlink import is_mavlink_log, read_mavlink_log, trial_from_log

    log_path: Path = args.log
    refuse_input_as_output(args.out, log_path, args.calibration)
    if not is_mavlink_log(log_path):
        raise InputError(f"{log_path}: convert reads MAVLink logs (.tlog telemetry or .BIN DataFlash)")
    if log_path.exists():
        regular_input(log_path, "MAVLink log")
    sys.stderr.write(f"reading {log_path} ...\n")
    log = read_mavlink_log(log_path, args.calibration, remap=parse_remap(args.topic))
    trial = trial_from_log(log)
    summary = trial.metadata.summary_line()
    sys.stderr.write(summary + "\n")
    sys.stderr.write(f"writing {args.out} ...\n")
    counts: dict[str, int] = {}

    def counted() -> Iterator[tuple[str, int, Any]]:
        for item in log_messages(log):
            counts[item[0]] = counts.get(item[0], 0) + 1
            yield item

    total = write_bag(args.out, counted(), storage=args.storage, force=args.force)
    notes = []
    if not {"gnss_fix", "gnss_vel"} & set(log.streams):
        notes.append("the log has no GNSS: boat_twin builds a trial from a bag only with gnss/fix or gnss/vel")
    if not any(role in log.streams or role in log.constants for role in COMMAND_ROLES):
        notes.append("no commands mapped (give --calibration): the bag has no thruster topics")
    if args.json:
        sys.stdout.write(to_json({
            "source": str(log_path), "out": str(args.out), "messages": total, "topics": counts,
            "summary": summary, "missing": trial.metadata.missing, "gaps": trial.metadata.gaps,
            "start_time_s": trial.metadata.start_time_s, "time_base": log.report.time_base, "notes": notes,
        }) + "\n")
        return 0
    lines = [f"wrote {args.out}: {total} messages"] + [f"  /{topic}: {n}" for topic, n in sorted(counts.items())]
    lines += [f"note: {note}" for note in notes]
    sys.stdout.write("\n".join(lines) + "\n")
    return 0


def register(subparsers: Any) -> None:
    """Add the ``convert`` verb."""
    p = subparsers.add_parser(
        "convert",
        help=verb_help("convert"),
        description="Read an ArduPilot/MAVLink log (telemetry .tlog or DataFlash .BIN) and write its trial as a "
        "rosbag2 (MCAP by default): gnss/fix, gnss/vel, imu/data (world east-north-up, body forward-left-up; SI "
        "units) and, with --calibration, the thruster topics (N, rad). Samples keep the log's own time stamps.",
    )
    p.add_argument("log", type=Path, metavar="LOG", help="MAVLink telemetry log (.tlog) or DataFlash log (.BIN)")
    p.add_argument("--out", type=Path, required=True, metavar="BAG",
                   help="output bag: a directory, or a file ending in .mcap")
    p.add_argument("--storage", choices=("mcap", "sqlite3"), default="mcap", help="rosbag2 storage (default mcap)")
    p.add_argument("--force", action="store_true", help="overwrite an existing output")
    p.add_argument("--json", action="store_true", help="machine-readable summary on stdout")
    add_trial_options(p, bags=False)
    p.set_defaults(handler=run)
