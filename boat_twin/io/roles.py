"""The roles a trial's streams play (names only, free of heavy imports: the command line lists them in --help)."""

import re
from collections.abc import Iterable, Sequence

from boat_twin.errors import InputError

COMMAND_ROLES = ("thrust_left", "thrust_right", "angle_left", "angle_right")
"""Command streams, each one scalar per message (N, a thruster's own unit, or rad)."""
SENSOR_ROLES = ("gnss_fix", "gnss_vel", "imu")
"""Measured streams: GNSS fix (lat, lon, alt), GNSS velocity (east, north), IMU (yaw, yaw rate, ax, ay)."""
MEASURED_INPUT_ROLES = ("wind",)
"""Measured inputs a recording may carry: the true wind over ground (east, north; the air's velocity, m/s) from
an anemometer, a known input of the diagnosis."""
TRIAL_ROLES = COMMAND_ROLES + SENSOR_ROLES + MEASURED_INPUT_ROLES
"""Roles a topic remap may name."""

ACTUATOR_TOPIC = re.compile(r"^(thrusters/\w+/(thrust|cmd|pos)|rudders/\w+/angle)$")
"""A boat file's per-actuator command topics (:func:`~boat_twin.io.messages.command_topics`): std_msgs/Float64."""
ONE_THRUSTER_NOTE = "thrust_right: 0 (a single thruster's topic: the boat file's second slot is empty)"
"""The stream choice noted where a boat file's single thruster leaves the second thrust slot empty."""


def actuator_slots(names: Iterable[str], order: Sequence[str] = ()) -> list[tuple[str, str]]:
    """(command role, actuator) for a boat's per-actuator command names (:data:`ACTUATOR_TOPIC`): thrusters in
    ``order`` (the boat file's actuator names as its propulsion section lists them: the slots
    :func:`~boat_twin.io.messages.command_topics` gives), names not in it after them alphabetically (without a boat
    file: all in name order); rudders before steered thrusters; at most two of each (the kernel's slots). What the
    bag reader and the MAVLink calibration map read alike."""
    rank = {name: i for i, name in enumerate(order)}
    found = sorted(names, key=lambda t: (rank.get(t.split("/")[1], len(rank)), t))
    thrusts = [t for t in found if t.startswith("thrusters/") and not t.endswith("/pos")]
    angles = [t for t in found if t.startswith("rudders/")] or [t for t in found if t.endswith("/pos")]
    return [*zip(COMMAND_ROLES[:2], thrusts[:2], strict=False), *zip(COMMAND_ROLES[2:], angles[:2], strict=False)]


def actuator_roles(keys: Iterable[str], where: str, order: Sequence[str] = ()) -> dict[str, str]:
    """Actuator name → command role for a mapping whose keys name a boat's actuators (:data:`ACTUATOR_TOPIC`:
    a MAVLink calibration's ``commands``, a CSV's ``columns``) instead of the slot roles; empty when none does.
    The slots as :func:`actuator_slots` fills them; one clear error (``where``: the file and section) for a mix of
    both namings or an actuator beyond the kernel's slots."""
    keys = [str(k) for k in keys]
    named = [k for k in keys if ACTUATOR_TOPIC.match(k)]
    if not named:
        return {}
    slots = [k for k in keys if k in COMMAND_ROLES]
    if slots:
        raise InputError(f"{where}.{slots[0]}: name the commands either by role (thrust_left...) or by the boat's "
                         "actuators (thrusters/<name>/...), not both")
    roles = {name: role for role, name in actuator_slots(named, order)}
    extra = [k for k in named if k not in roles]
    if extra:
        raise InputError(f"{where}.{extra[0]}: the twin has two thruster and two steering slots; this is one more")
    return roles
