"""Formats only: ROS 2 messages (rosbags typestore), rosbag2 / MCAP bags, MAVLink logs, CSV tables, and the Trial
every analysis reads. Modules: ``messages`` (topics, builders, CDR), ``bags`` (write_bag, read_trial), ``trial``
(Trial, build_trial), ``mavlink`` (MAVLink logs; its parts ``mavlink_calibration``, ``tlog``, ``dataflash``,
``mavlink_log``, ``mavlink_trial``), ``csv_trial`` (a CSV table by a column mapping), ``roles`` (the streams' role
names), ``sources`` (read_trial_file: any trial file), ``span`` (trial_between: a stretch of a trial, --start/--end),
``log_messages`` (a MAVLink log as the package's messages)."""

from __future__ import annotations

from boat_twin.lazy import lazy_exports

_EXPORTS = {
    "Trial": "boat_twin.io.trial",
    "TrialMetadata": "boat_twin.io.trial",
    "build_trial": "boat_twin.io.trial",
    "load_calibration": "boat_twin.io.mavlink",
    "read_csv_trial": "boat_twin.io.csv_trial",
    "read_mavlink_trial": "boat_twin.io.mavlink",
    "read_trial": "boat_twin.io.bags",
    "read_trial_file": "boat_twin.io.sources",
    "trial_between": "boat_twin.io.span",
    "write_bag": "boat_twin.io.bags",
}
"""Public name → its module, imported on first use (importing the package stays cheap: `--help` reads
:mod:`boat_twin.io.roles` alone)."""

__all__ = sorted(_EXPORTS)


__getattr__ = lazy_exports(__name__, _EXPORTS)
