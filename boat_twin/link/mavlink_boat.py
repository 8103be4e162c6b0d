"""The twin as a MAVLink surface boat: telemetry out, manual control in, over UDP with pymavlink's dialect.

:class:`MavlinkBoat` wraps a :class:`~boat_twin.twin.live.LiveTwin` and speaks to a ground station (QGroundControl,
MAVProxy) the way an ArduPilot Rover boat does, so the same ground station and joystick set-up drives either.

**Streams.** HEARTBEAT (MAV_TYPE_SURFACE_BOAT, MAV_AUTOPILOT_ARDUPILOTMEGA, Rover mode MANUAL, armed) at 1 Hz,
and ArduPilot's telemetry stream groups (the ``SRn_*`` parameters) with the messages this twin can fill:
EXT_STAT (SYS_STATUS, GPS_RAW_INT), POSITION (GLOBAL_POSITION_INT), RC_CHAN (SERVO_OUTPUT_RAW), EXTRA1
(ATTITUDE), EXTRA2 (VFR_HUD), EXTRA3 (SYSTEM_TIME). Default rates: ArduPilot Rover's, 1 Hz for every group
(``AP_MAV_DEFAULT_STREAM_RATE_*`` for APM_BUILD_Rover in libraries/GCS_MAVLink/GCS_MAVLink_Parameters.cpp,
ArduPilot/ardupilot commit 022bfbe; the message lists per group are from the same file). A ground station
may change them as with ArduPilot: REQUEST_DATA_STREAM (MAVProxy and QGroundControl send it on connect) or
PARAM_SET of ``SR0_*``; rates above the twin's 10 Hz tick are capped at one message per tick. Times are
simulated time: with ``speed`` > 1 the rates are per simulated second.

**Values** come from the twin's simulated sensors, never from the truth: GPS_RAW_INT and GLOBAL_POSITION_INT
from the latest GNSS fix and velocity (``gnss/fix``, ``gnss/vel``: the fix describes the antenna
``latency_s`` earlier); ATTITUDE and headings from the UM7 (``imu/data``). Conversions from REP-103:
north = ENU y, east = ENU x, down = −up; the FLU body becomes FRD (y, z negated), so roll is unchanged,
pitch and the y/z rates change sign, and NED yaw = π/2 − ENU yaw; compass headings (0-360°, clockwise from
north) are that yaw in degrees. Altitudes are WGS-84 ellipsoidal heights (the twin has no geoid model;
MAVLink's ``alt`` asks for MSL). VFR_HUD airspeed is the GPS ground speed, as ArduPilot reports it without an
airspeed sensor (GCS_MAVLINK::vfr_hud_airspeed).

**Commands** (:data:`COMMAND_MAPPING`): as ArduPilot Rover maps them (GCS_MAVLINK_Rover::
handle_manual_control_axes; RCMAP defaults): MANUAL_CONTROL ``y`` (−1000 left … 1000 right) steers and ``z``
(−1000 astern … 1000 ahead) is the throttle; RC_CHANNELS_OVERRIDE channel 1 steers and channel 3 is the
throttle, PWM 1100-1900 µs with 1500 neutral (ArduPilot's RCn_MIN/TRIM/MAX defaults). A throttle fraction f
commands f × bollard thrust on both outboards (the engine model limits astern thrust); a steering fraction s
commands s × max steering angle on both (positive: bow to starboard). An axis not given (INT16_MAX, UINT16_MAX)
keeps its value; RC channel value 0 releases the override. Overrides lapse after :data:`OVERRIDE_TIMEOUT_S`
of simulated time without a refresh (ArduPilot's RC_OVERRIDE_TIME default, 3 s); the axis then returns to the
base command (:meth:`MavlinkBoat.set_command`, a scenario, or zero). SERVO_OUTPUT_RAW reports the commands as
PWM: servo1/servo2 the left/right steering angle, servo3/servo4 the left/right thrust, 1500 ± 400 µs at full
scale (:func:`pwm_from_fraction`). COMMAND_LONG and COMMAND_INT addressed to this boat are answered with
COMMAND_ACK MAV_RESULT_UNSUPPORTED (the twin implements no commands).

**Safety.** Addresses are loopback unless ``allow_remote`` (``--allow-remote``). With ``udpout`` the boat
accepts packets only from the ground station's host. Malformed input (bad CRC, bad prefix, wrong length,
truncated, unknown message id) is dropped and counted in :class:`LinkStats`, never raised.

**Parts.** :class:`MavlinkBoat` turns packets into commands and steps the twin; what it is made of lives apart:
the datagrams and the .tlog in :mod:`boat_twin.link.transport`, when each message is due in
:mod:`boat_twin.link.schedule`, the messages themselves in :mod:`boat_twin.link.encoding`.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from boat_twin.errors import InputError
from boat_twin.io import messages
from boat_twin.link.encoding import (
    PWM_HALF_RANGE_US,
    PWM_NEUTRAL_US,
    TelemetryEncoder,
    compass_deg,
    fraction_from_pwm,
    ned_attitude,
    pwm_from_fraction,
    servo_calibration,
)
from boat_twin.link.schedule import (
    MAX_STREAM_RATE_HZ,
    ROVER_DEFAULT_RATES_HZ,
    STREAMS,
    Schedule,
    parse_stream_rates,
)
from boat_twin.link.transport import DEFAULT_URL, MAX_PACKETS_PER_POLL, Endpoint, LinkStats, Transport, parse_url
from boat_twin.twin.live import LiveTwin
from boat_twin.vessel.scenarios import Scenario
from boat_twin.vessel.simulate import OUTPUT_RATE_HZ

__all__ = ["COMMAND_MAPPING", "DEFAULT_URL", "MAX_PACKETS_PER_POLL", "MAX_STREAM_RATE_HZ", "OVERRIDE_TIMEOUT_S",
           "PWM_HALF_RANGE_US", "PWM_NEUTRAL_US", "ROVER_DEFAULT_RATES_HZ", "STREAMS", "Endpoint", "LinkStats",
           "MavlinkBoat", "compass_deg", "fraction_from_pwm", "ned_attitude", "parse_stream_rates", "parse_url",
           "progress_to_stderr", "pwm_from_fraction", "servo_calibration"]
"""The link's public names, those of its parts included (callers import them here)."""

RC_STEERING_CHANNEL = 1
"""RC channel that steers (ArduPilot Rover: RCMAP_ROLL default 1)."""
RC_THROTTLE_CHANNEL = 3
"""RC channel of the throttle (RCMAP_THROTTLE default 3)."""
OVERRIDE_TIMEOUT_S = 3.0
"""An override lapses after this long without a refresh, simulated s (ArduPilot RC_OVERRIDE_TIME default)."""

COMMAND_MAPPING = (
    "MANUAL_CONTROL y [-1000, 1000] -> steering fraction (+ right); z [-1000, 1000] -> throttle fraction",
    "RC_CHANNELS_OVERRIDE ch1 -> steering, ch3 -> throttle: fraction = (PWM - 1500) / 400, clipped to [-1, 1]",
    "throttle fraction f -> thrust f * bollard_thrust_N on both outboards",
    "steering fraction s -> angle s * max_steering_rad on both outboards (+: bow to starboard)",
)
"""The command mapping, one line per rule (for help texts and reports)."""


_INT16_MAX = 32767
_UINT16_MAX = 65535


class MavlinkBoat:
    """A :class:`LiveTwin` as a MAVLink surface boat: ``step(n)`` in simulated time, ``run()`` in real time.

    ``url``: :data:`DEFAULT_URL` form (None: no network, e.g. only a .tlog). ``tlog``: record every packet sent
    and received as MAVProxy does (8-byte big-endian µs since the Unix epoch, then the packet), stamped with
    the twin's time (``twin.epoch_s`` + simulated time; pass a Unix epoch to the twin for wall-clock stamps).
    ``scenario``: base commands per tick (its helm's ``command(t, states)``, asked once per output tick, t since
    the first tick; its initial surge
    speed is given to a fresh twin, as the batch simulation does) that overrides from the ground station
    replace while active. ``rates_hz``: stream group → Hz (default Rover's).
    """

    def __init__(
        self,
        twin: LiveTwin,
        url: str | None = DEFAULT_URL,
        *,
        allow_remote: bool = False,
        tlog: Path | None = None,
        overwrite: bool = False,
        scenario: Scenario | None = None,
        rates_hz: Mapping[str, float] | None = None,
        system_id: int = 1,
        component_id: int = mavlink2.MAV_COMP_ID_AUTOPILOT1,
    ) -> None:
        if not (1 <= system_id <= 255 and 0 <= component_id <= 255):
            raise InputError(f"MAVLink system id must be 1-255 and component id 0-255, got {system_id}, "
                             f"{component_id}")
        self.schedule = Schedule(rates_hz)
        endpoint = parse_url(url, allow_remote) if url is not None else None
        self.twin = twin
        self.scenario = scenario
        self._helm = scenario.helm(1) if scenario is not None else None
        self.system_id = system_id
        self.component_id = component_id
        self.stats = LinkStats()
        self._base = [0.0, 0.0, 0.0, 0.0]
        self._throttle: tuple[float, float] | None = None  # (fraction, simulated time of the last refresh)
        self._steering: tuple[float, float] | None = None
        if scenario is not None and twin.tick_index == 0:  # the scenario's initial condition, as in batch
            twin.state[:, 3] = scenario.initial_surge_mps
        self.transport = Transport(endpoint, self.stats, tlog, overwrite, stamp_s=twin.time_s)
        self._mav = mavlink2.MAVLink(self.transport, system_id, component_id)
        self.encoder = TelemetryEncoder(self._mav, twin, self.stats)

    @property
    def sim_time_s(self) -> float:
        """Simulated time of the next tick since the first, s (exact tick arithmetic, not epoch differences)."""
        return self.twin.tick_index / OUTPUT_RATE_HZ

    @property
    def local_address(self) -> tuple[Any, ...] | None:
        """The bound (host, port) of the link's socket (e.g. the ephemeral port of ``udpin:127.0.0.1:0``)."""
        return self.transport.local_address

    def close(self, complete: bool = True) -> None:
        """Close the socket and the .tlog (idempotent). The .tlog, written next to its name, is moved into place
        if ``complete``; otherwise it is dropped and an old file of that name stays as it was."""
        self.transport.close(complete)

    def __enter__(self) -> MavlinkBoat:
        return self

    def __exit__(self, exc_type: object, *exc: object) -> None:
        self.close(complete=exc_type is None)

    # ------------------------------------------------------------------ input
    def poll(self, timeout_s: float = 0.0) -> int:
        """Take in every pending datagram (waiting up to ``timeout_s`` for the first); returns how many."""
        self.transport.stamp_s = self.twin.time_s
        return self.transport.poll(self._handle, timeout_s)

    def _for_us(self, system: int, component: int | None = None) -> bool:
        return system in (0, self.system_id) and (component is None or component in (0, self.component_id))

    def _handle(self, msg: Any) -> None:
        kind = msg.get_type()
        now = self.sim_time_s
        if kind == "MANUAL_CONTROL" and msg.target == self.system_id:
            self._manual_control(msg, now)
        elif kind == "RC_CHANNELS_OVERRIDE" and msg.target_system == self.system_id:
            self._rc_override(msg, now)
        elif kind in ("COMMAND_LONG", "COMMAND_INT") and self._for_us(msg.target_system, msg.target_component):
            self._mav.command_ack_send(msg.command, mavlink2.MAV_RESULT_UNSUPPORTED, 0, 0,
                                       msg.get_srcSystem(), msg.get_srcComponent())
        elif kind == "REQUEST_DATA_STREAM" and self._for_us(msg.target_system, msg.target_component):
            self.schedule.request_data_stream(msg.req_stream_id, msg.req_message_rate, msg.start_stop, now)
        elif kind == "PARAM_REQUEST_LIST" and self._for_us(msg.target_system, msg.target_component):
            names = list(self._params())
            for index, name in enumerate(names):
                self._send_param(name, index, len(names))
        elif kind == "PARAM_REQUEST_READ" and self._for_us(msg.target_system, msg.target_component):
            self._param_read(_param_name(msg.param_id), msg.param_index)
        elif kind == "PARAM_SET" and self._for_us(msg.target_system, msg.target_component):
            self._param_set(_param_name(msg.param_id), msg.param_value, now)
        else:
            self.stats.ignored += 1

    def _manual_control(self, msg: Any, now: float) -> None:
        if msg.y != _INT16_MAX:
            self._steering = (max(-1.0, min(1.0, msg.y / 1000.0)), now)
        if msg.z != _INT16_MAX:
            self._throttle = (max(-1.0, min(1.0, msg.z / 1000.0)), now)
        self.stats.commands_applied += 1

    def _rc_override(self, msg: Any, now: float) -> None:
        for channel, attr in ((RC_STEERING_CHANNEL, "_steering"), (RC_THROTTLE_CHANNEL, "_throttle")):
            pwm = getattr(msg, f"chan{channel}_raw")
            if pwm == 0:
                setattr(self, attr, None)  # released: back to the base command
            elif pwm != _UINT16_MAX:
                setattr(self, attr, (fraction_from_pwm(pwm), now))
        self.stats.commands_applied += 1

    def _params(self) -> dict[str, float]:
        """The read-only parameters this boat reports (SR0_* rates settable), ArduPilot names."""
        values = {"SYSID_THISMAV": float(self.system_id), "RC_OVERRIDE_TIME": OVERRIDE_TIMEOUT_S}
        values.update({f"SR0_{name}": rate for name, rate in self.schedule.rates_hz().items()})
        return values

    def _send_param(self, name: str, index: int, count: int) -> None:
        self._mav.param_value_send(name.encode(), self._params()[name], mavlink2.MAV_PARAM_TYPE_REAL32, count,
                                   index)

    def _param_read(self, name: str, index: int) -> None:
        names = list(self._params())
        if name in names:
            self._send_param(name, names.index(name), len(names))
        elif 0 <= index < len(names) and not name:
            self._send_param(names[index], index, len(names))

    def _param_set(self, name: str, value: float, now: float) -> None:
        names = list(self._params())
        if name not in names:
            return
        if name.startswith("SR0_") and math.isfinite(value):
            self.schedule.set_rate(name[4:], value, now)
        self._send_param(name, names.index(name), len(names))  # echo the value in force (ArduPilot does)

    # ------------------------------------------------------------------ commands
    def set_command(self, index: int, value: float) -> None:
        """Set a base command (0 thrust_left_N, 1 thrust_right_N, 2 angle_left_rad, 3 angle_right_rad); held.

        Overrides from the ground station take precedence while active."""
        if math.isfinite(value):
            self._base[index] = float(value)

    def override(self) -> dict[str, float | None]:
        """Active override fractions: ``{"throttle": f or None, "steering": s or None}``."""
        return {"throttle": self._throttle[0] if self._throttle else None,
                "steering": self._steering[0] if self._steering else None}

    def _apply_commands(self, t_rel: float) -> None:
        for attr in ("_throttle", "_steering"):
            value = getattr(self, attr)
            if value is not None and t_rel - value[1] > OVERRIDE_TIMEOUT_S + 1e-6:
                setattr(self, attr, None)
        if self._helm is not None:
            row = self._helm.command(t_rel, self.twin.state)[0]
            base = [float(v) for v in row]
        else:
            base = list(self._base)
        vessel = self.twin.config.vessel
        if self._throttle is not None:
            base[0] = base[1] = self._throttle[0] * vessel.bollard_thrust_N
        if self._steering is not None:
            base[2] = base[3] = self._steering[0] * vessel.max_steering_rad
        for index, value in enumerate(base):
            self.twin.set_command(index, value)

    # ------------------------------------------------------------------ stepping
    def step(self, n_ticks: int = 1) -> list[messages.Message]:
        """Advance ``n_ticks`` output ticks: take in pending packets, set the commands, tick the twin, send what
        is due. Returns the twin's ROS messages of these ticks (``(topic, stamp_ns, message)``)."""
        out: list[messages.Message] = []
        for _ in range(n_ticks):
            self.poll()  # also stamps this tick's .tlog records
            t_rel = self.sim_time_s
            self._apply_commands(t_rel)
            tick = self.twin.tick()
            self.encoder.absorb()
            self._send_due(t_rel)
            out += tick
        return out

    def ticks(self, duration_s: float | None = None, speed: float = 1.0, stop: Callable[[], bool] | None = None,
              progress: Callable[[str], None] | None = None, progress_every_s: float = 10.0,
              ) -> Iterator[list[messages.Message]]:
        """Step at real time × ``speed`` (0 or inf: as fast as possible) for ``duration_s`` simulated seconds
        (None: until ``stop()`` is true), answering packets while it waits; yields each tick's ROS messages.
        ``progress(line)`` is called every ``progress_every_s`` of wall time with :meth:`summary_line`."""
        if math.isnan(speed) or speed < 0.0:
            raise InputError(f"--mavlink-speed must be a non-negative factor, got {speed!r}")
        if duration_s is not None and not (math.isfinite(duration_s) and duration_s >= 0.0):
            raise InputError(f"--duration must be a non-negative number of seconds, got {duration_s!r}")
        n_total = None if duration_s is None else int(math.floor(duration_s * OUTPUT_RATE_HZ + 1e-9)) + 1
        period_s = math.inf if speed == 0.0 or math.isinf(speed) else 1.0 / (OUTPUT_RATE_HZ * speed)
        start = time.monotonic()
        next_report = start + progress_every_s
        done = 0
        while (n_total is None or done < n_total) and not (stop is not None and stop()):
            if math.isfinite(period_s):
                target = start + done * period_s
                while (remaining := target - time.monotonic()) > 0.0:
                    if self.transport.has_socket:
                        self.poll(remaining)
                    else:
                        time.sleep(remaining)
            yield self.step(1)
            done += 1
            if progress is not None and time.monotonic() >= next_report:
                next_report += progress_every_s
                progress(self.summary_line())

    def run(self, duration_s: float | None = None, speed: float = 1.0, stop: Callable[[], bool] | None = None,
            progress: Callable[[str], None] | None = None, progress_every_s: float = 10.0) -> int:
        """:meth:`ticks` without keeping the messages. Returns the number of ticks run."""
        return sum(1 for _ in self.ticks(duration_s, speed, stop, progress, progress_every_s))

    def summary_line(self) -> str:
        """One line: simulated time, packets out and in, drops."""
        s = self.stats
        t = max(self.twin.tick_index - 1, 0) / OUTPUT_RATE_HZ  # the last tick run
        return (f"t = {t:.1f} s: {s.packets_sent} packets sent, {s.packets_logged} logged, "
                f"{s.packets_received} received ({s.commands_applied} commands), {s.dropped} malformed dropped")

    # ------------------------------------------------------------------ output
    def _send_heartbeat(self) -> None:
        self.encoder.heartbeat()
        self.transport.flush_log()  # the partial .tlog of a killed run lags by at most a second

    def _send_due(self, t_rel: float) -> None:
        stamp_s = self.transport.stamp_s
        self.schedule.send_due(t_rel, self._send_heartbeat, lambda kind: self.encoder.send(kind, t_rel, stamp_s))


def _param_name(raw: Any) -> str:
    """A PARAM_* id field (bytes or str, NUL-padded) as a str."""
    if isinstance(raw, bytes):
        raw = raw.decode("ascii", "replace")
    return str(raw).rstrip("\x00")


def progress_to_stderr(line: str) -> None:
    """Progress callback for :meth:`MavlinkBoat.run`: the line on stderr."""
    sys.stderr.write(line + "\n")
    sys.stderr.flush()
