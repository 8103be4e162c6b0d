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
"""

from __future__ import annotations

import errno
import ipaddress
import math
import select
import socket
import struct
import sys
import time
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any, BinaryIO

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from boat_twin.errors import InputError
from boat_twin.files import OutputClaim
from boat_twin.io import messages
from boat_twin.twin.live import LiveTwin
from boat_twin.vessel.scenarios import Scenario
from boat_twin.vessel.simulate import OUTPUT_RATE_HZ

DEFAULT_URL = "udpout:127.0.0.1:14550"
"""Default target: a ground station on this machine (QGroundControl and MAVProxy listen on UDP 14550)."""

HEARTBEAT_RATE_HZ = 1.0
"""HEARTBEAT rate, Hz: ArduPilot sends one per second on every link."""

STREAMS: dict[str, tuple[str, ...]] = {
    "EXT_STAT": ("SYS_STATUS", "GPS_RAW_INT"),
    "POSITION": ("GLOBAL_POSITION_INT",),
    "RC_CHAN": ("SERVO_OUTPUT_RAW",),
    "EXTRA1": ("ATTITUDE",),
    "EXTRA2": ("VFR_HUD",),
    "EXTRA3": ("SYSTEM_TIME",),
}
"""ArduPilot telemetry stream groups (``SRn_<group>``) and the messages of each that this twin sends."""

ROVER_DEFAULT_RATES_HZ: dict[str, float] = dict.fromkeys(STREAMS, 1.0)
"""ArduPilot Rover's default stream rates, Hz: 1 for each group (GCS_MAVLink_Parameters.cpp, see above)."""

MAX_STREAM_RATE_HZ = 50.0
"""Highest rate a ground station may request, Hz (the SRn_* parameters' range, 0-50)."""

DATA_STREAM_GROUPS: dict[int, str | None] = {
    mavlink2.MAV_DATA_STREAM_RAW_SENSORS: None,
    mavlink2.MAV_DATA_STREAM_EXTENDED_STATUS: "EXT_STAT",
    mavlink2.MAV_DATA_STREAM_RC_CHANNELS: "RC_CHAN",
    mavlink2.MAV_DATA_STREAM_RAW_CONTROLLER: None,
    mavlink2.MAV_DATA_STREAM_POSITION: "POSITION",
    mavlink2.MAV_DATA_STREAM_EXTRA1: "EXTRA1",
    mavlink2.MAV_DATA_STREAM_EXTRA2: "EXTRA2",
    mavlink2.MAV_DATA_STREAM_EXTRA3: "EXTRA3",
}
"""REQUEST_DATA_STREAM ids → stream group (None: a group whose messages this twin does not produce)."""

PWM_NEUTRAL_US = 1500
"""Neutral PWM (RCn_TRIM default), µs."""
PWM_HALF_RANGE_US = 400
"""PWM span from neutral to full scale, µs: 1100-1900 (ArduPilot's RCn_MIN/RCn_MAX defaults)."""
RC_STEERING_CHANNEL = 1
"""RC channel that steers (ArduPilot Rover: RCMAP_ROLL default 1)."""
RC_THROTTLE_CHANNEL = 3
"""RC channel of the throttle (RCMAP_THROTTLE default 3)."""
OVERRIDE_TIMEOUT_S = 3.0
"""An override lapses after this long without a refresh, simulated s (ArduPilot RC_OVERRIDE_TIME default)."""
STALE_FIX_S = 1.0
"""GPS_RAW_INT reports NO_FIX (and SYS_STATUS an unhealthy GPS) when the last fix is older than this, s."""
ROVER_MODE_MANUAL = 0
"""ArduPilot Rover custom_mode number of MANUAL: the twin obeys thrust and steering as commanded."""
MAX_DATAGRAMS_PER_POLL = 1000
"""At most this many datagrams are taken in per poll (a flood cannot starve the simulation)."""
MAX_PACKETS_PER_POLL = 1000
"""At most this many MAVLink packets are taken in per poll, however many each datagram holds (a datagram of a few
hundred packets each would otherwise multiply the work, and the .tlog, per tick): further datagrams wait in the
socket, and the packets of the datagram that crosses the cap beyond it are dropped (``LinkStats.flood_dropped``)."""
UDP_MAX_DATAGRAM = 65535

COMMAND_MAPPING = (
    "MANUAL_CONTROL y [-1000, 1000] -> steering fraction (+ right); z [-1000, 1000] -> throttle fraction",
    "RC_CHANNELS_OVERRIDE ch1 -> steering, ch3 -> throttle: fraction = (PWM - 1500) / 400, clipped to [-1, 1]",
    "throttle fraction f -> thrust f * bollard_thrust_N on both outboards",
    "steering fraction s -> angle s * max_steering_rad on both outboards (+: bow to starboard)",
)
"""The command mapping, one line per rule (for help texts and reports)."""

_SENSORS_PRESENT = (
    mavlink2.MAV_SYS_STATUS_SENSOR_3D_GYRO
    | mavlink2.MAV_SYS_STATUS_SENSOR_3D_ACCEL
    | mavlink2.MAV_SYS_STATUS_SENSOR_3D_MAG
    | mavlink2.MAV_SYS_STATUS_SENSOR_GPS
    | mavlink2.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
    | mavlink2.MAV_SYS_STATUS_AHRS
)
_INT16_MAX = 32767
_UINT16_MAX = 65535


@dataclass
class LinkStats:
    """Counters of one link; ``dropped`` is everything malformed that was thrown away."""

    datagrams_received: int = 0
    packets_received: int = 0
    """Well-formed packets (valid CRC, known id), whatever their content."""
    commands_applied: int = 0
    """MANUAL_CONTROL and RC_CHANNELS_OVERRIDE packets addressed to this boat and applied."""
    ignored: int = 0
    """Well-formed packets not for this boat or of a type it does not handle."""
    bad_data: int = 0
    """pymavlink BAD_DATA events: bad CRC, bad prefix bytes, wrong length, bad flags."""
    unknown_id: int = 0
    """Well-framed packets whose message id is not in the ardupilotmega dialect."""
    truncated: int = 0
    """Datagrams that ended inside a packet (the partial packet is dropped)."""
    rejected_sender: int = 0
    """Datagrams from a host other than the ground station's (udpout mode)."""
    flood_dropped: int = 0
    """Well-formed packets beyond :data:`MAX_PACKETS_PER_POLL` in one poll, dropped unread (a flood)."""
    packets_sent: int = 0
    """Packets handed to the network."""
    send_errors: int = 0
    packets_logged: int = 0
    """Records written to the .tlog (sent and received packets)."""

    @property
    def dropped(self) -> int:
        """Malformed input thrown away: bad data, unknown ids, truncated packets."""
        return self.bad_data + self.unknown_id + self.truncated

    def as_dict(self) -> dict[str, int]:
        """Plain counters (for --json)."""
        out = {f.name: getattr(self, f.name) for f in fields(self)}
        out["dropped"] = self.dropped
        return out


@dataclass(frozen=True)
class Endpoint:
    """A parsed MAVLink URL: ``mode`` 'udpout' (send to host:port) or 'udpin' (listen on host:port)."""

    mode: str
    host: str
    port: int
    sockaddr: tuple[Any, ...]
    family: int
    loopback: bool


def parse_url(url: str, allow_remote: bool = False) -> Endpoint:
    """Parse ``udpout:HOST:PORT`` / ``udpin:HOST:PORT`` (``udp:`` = udpin, as pymavlink); refuse non-loopback
    hosts unless ``allow_remote``. Raises InputError (one line) on anything else."""
    scheme, sep, rest = url.partition(":")
    scheme = {"udp": "udpin"}.get(scheme, scheme)
    if not sep or scheme not in ("udpout", "udpin"):
        raise InputError(f"MAVLink URL {url!r}: expected udpout:HOST:PORT or udpin:HOST:PORT")
    host, sep, port_text = rest.rpartition(":")
    host = host.strip("[]")
    if not sep or not host:
        raise InputError(f"MAVLink URL {url!r}: expected {scheme}:HOST:PORT")
    try:
        port = int(port_text)
    except ValueError:
        raise InputError(f"MAVLink URL {url!r}: port {port_text!r} is not a number") from None
    lowest = 0 if scheme == "udpin" else 1
    if not lowest <= port <= 65535:
        raise InputError(f"MAVLink URL {url!r}: port must be {lowest}-65535")
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_DGRAM)
    except (socket.gaierror, UnicodeError) as err:
        raise InputError(f"MAVLink URL {url!r}: cannot resolve host {host!r} ({err})") from None
    family, _, _, _, sockaddr = infos[0]
    loopback = all(ipaddress.ip_address(str(info[4][0]).split("%")[0]).is_loopback for info in infos)
    if not loopback and not allow_remote:
        raise InputError(
            f"MAVLink URL {url!r}: {host} is not a loopback address; pass --allow-remote "
            "(mavlink_allow_remote) to expose the twin beyond this machine"
        )
    return Endpoint(scheme, host, port, tuple(sockaddr), family, loopback)


def parse_stream_rates(items: list[str]) -> dict[str, float]:
    """``["POSITION=10", "ALL=4"]`` (repeated ``--mavlink-rate``) → ``{"POSITION": 10.0, ...}``; later items win."""
    rates: dict[str, float] = {}
    for item in items:
        group, sep, value = item.partition("=")
        group = group.strip().upper()
        try:
            rate = float(value)
        except ValueError:
            rate = math.nan
        if not sep or (group not in STREAMS and group != "ALL"):
            raise InputError(f"--mavlink-rate {item!r}: expected GROUP=HZ with GROUP one of ALL, {', '.join(STREAMS)}")
        if not 0.0 <= rate <= MAX_STREAM_RATE_HZ:
            raise InputError(f"--mavlink-rate {item!r}: the rate must be a number of Hz from 0 to "
                             f"{MAX_STREAM_RATE_HZ:g}")
        rates.update(dict.fromkeys(STREAMS, rate) if group == "ALL" else {group: rate})
    return rates


def fraction_from_pwm(pwm_us: float) -> float:
    """RC PWM (µs) to a fraction in [-1, 1]: (PWM − 1500) / 400, clipped."""
    return max(-1.0, min(1.0, (float(pwm_us) - PWM_NEUTRAL_US) / PWM_HALF_RANGE_US))


def pwm_from_fraction(fraction: float) -> int:
    """A fraction of full scale (clipped to [-1, 1]) to PWM, µs: 1500 + 400·f (1100-1900)."""
    f = max(-1.0, min(1.0, fraction)) if math.isfinite(fraction) else 0.0
    return int(round(PWM_NEUTRAL_US + PWM_HALF_RANGE_US * f))


def servo_calibration(vessel: Any) -> dict[str, Any]:
    """The calibration map (boat_twin.io.mavlink's YAML format) of this link's SERVO_OUTPUT_RAW layout for
    ``vessel`` (VesselParams): servo1/2 steering left/right, servo3/4 thrust left/right, linear 1100-1900 µs."""
    lo, hi = PWM_NEUTRAL_US - PWM_HALF_RANGE_US, PWM_NEUTRAL_US + PWM_HALF_RANGE_US
    def table(full_scale: float) -> list[list[float]]:
        return [[lo, -float(full_scale)], [hi, float(full_scale)]]

    return {"commands": {
        "thrust_left": {"source": "SERVO3", "table": table(vessel.bollard_thrust_N)},
        "thrust_right": {"source": "SERVO4", "table": table(vessel.bollard_thrust_N)},
        "angle_left": {"source": "SERVO1", "table": table(vessel.max_steering_rad)},
        "angle_right": {"source": "SERVO2", "table": table(vessel.max_steering_rad)},
    }}


def ned_attitude(qx: float, qy: float, qz: float, qw: float) -> tuple[float, float, float]:
    """(roll, pitch, yaw) of the FRD body in NED, rad (ZYX, yaw in [-π, π]), from the FLU-in-ENU quaternion.

    With R the FLU→ENU rotation, the FRD→NED rotation is A·R·B (A swaps east/north and negates up, B negates
    the body y and z axes); its ZYX angles are roll = ENU roll, pitch = −ENU pitch, yaw = atan2(r00, r10).
    """
    r00 = 1.0 - 2.0 * (qy * qy + qz * qz)
    r10 = 2.0 * (qx * qy + qz * qw)
    r20 = 2.0 * (qx * qz - qy * qw)
    r21 = 2.0 * (qy * qz + qx * qw)
    r22 = 1.0 - 2.0 * (qx * qx + qy * qy)
    roll = math.atan2(r21, r22)
    pitch = math.asin(max(-1.0, min(1.0, r20)))
    yaw = math.atan2(r00, r10)
    return roll, pitch, yaw


def compass_deg(north: float, east: float) -> float:
    """Direction of the (north, east) vector clockwise from north, deg in [0, 360)."""
    return math.degrees(math.atan2(east, north)) % 360.0


def _cdeg(deg: float) -> int:
    """A compass angle in centidegrees, 0-35999 (UINT16_MAX when not finite)."""
    return round(deg % 360.0 * 100.0) % 36000 if math.isfinite(deg) else _UINT16_MAX


def _int(value: float, lo: int, hi: int, unknown: int) -> int:
    """Round and clip to a field's range; NaN/inf → the field's 'unknown' value."""
    if not math.isfinite(value):
        return unknown
    return int(max(lo, min(hi, round(value))))


class _Stream:
    """One scheduled stream: sends when the simulated time reaches ``due_s``."""

    def __init__(self, rate_hz: float) -> None:
        self.rate_hz = rate_hz
        self.due_s = 0.0

    def set_rate(self, rate_hz: float, now_s: float) -> None:
        self.rate_hz = rate_hz
        self.due_s = now_s

    def is_due(self, now_s: float) -> bool:
        return self.rate_hz > 0.0 and now_s + 1e-6 >= self.due_s

    def sent(self, now_s: float) -> None:
        self.due_s += 1.0 / self.rate_hz
        if self.due_s <= now_s:  # after a stall or a rate above the tick rate: no bursts
            self.due_s = now_s + 1.0 / self.rate_hz


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
        rates = dict(ROVER_DEFAULT_RATES_HZ)
        for name, rate in (rates_hz or {}).items():
            if name not in STREAMS:
                raise InputError(f"MAVLink stream {name!r}: unknown (streams: {', '.join(STREAMS)})")
            if not (math.isfinite(rate) and 0.0 <= rate <= MAX_STREAM_RATE_HZ):
                raise InputError(f"MAVLink stream {name}: rate must be 0-{MAX_STREAM_RATE_HZ:g} Hz, got {rate!r}")
            rates[name] = float(rate)
        self.endpoint = parse_url(url, allow_remote) if url is not None else None
        self.twin = twin
        self.scenario = scenario
        self._helm = scenario.helm(1) if scenario is not None else None
        self.system_id = system_id
        self.component_id = component_id
        self.stats = LinkStats()
        self.streams = {name: _Stream(rate) for name, rate in rates.items()}
        self._heartbeat = _Stream(HEARTBEAT_RATE_HZ)
        self._base = [0.0, 0.0, 0.0, 0.0]
        self._throttle: tuple[float, float] | None = None  # (fraction, simulated time of the last refresh)
        self._steering: tuple[float, float] | None = None
        self._fix: dict[str, float] | None = None
        self._vel: tuple[float, float, float] | None = None
        self._attitude: tuple[float, float, float, float, float, float] | None = None
        self._peer: tuple[Any, ...] | None = None
        self._sock: socket.socket | None = None
        self._tlog: BinaryIO | None = None
        self._tlog_claim: OutputClaim | None = None
        self._mav = mavlink2.MAVLink(self, system_id, component_id)
        self._stamp_s = twin.time_s
        if scenario is not None and twin.tick_index == 0:  # the scenario's initial condition, as in batch
            twin.state[:, 3] = scenario.initial_surge_mps
        if self.endpoint is not None:
            self._sock = self._open_socket(self.endpoint)
        if tlog is not None:
            try:
                self._tlog_claim = OutputClaim(Path(tlog), overwrite, "tlog")
                self._tlog = (self._tlog_claim.scratch / Path(tlog).name).open("wb")
            except BaseException:
                self.close(complete=False)
                raise

    # ------------------------------------------------------------------ transport
    def _open_socket(self, ep: Endpoint) -> socket.socket:
        sock = socket.socket(ep.family, socket.SOCK_DGRAM)
        try:
            if ep.mode == "udpin":
                sock.bind(ep.sockaddr)
            else:
                local = "::1" if ep.family == socket.AF_INET6 else "127.0.0.1"
                sock.bind((local, 0) if ep.loopback else ("", 0))
                self._peer = ep.sockaddr
        except OSError as err:
            sock.close()
            raise InputError(f"MAVLink {ep.mode}:{ep.host}:{ep.port}: cannot bind ({err.strerror})") from None
        sock.setblocking(False)
        return sock

    @property
    def sim_time_s(self) -> float:
        """Simulated time of the next tick since the first, s (exact tick arithmetic, not epoch differences)."""
        return self.twin.tick_index / OUTPUT_RATE_HZ

    @property
    def local_address(self) -> tuple[Any, ...] | None:
        """The bound (host, port) of the link's socket (e.g. the ephemeral port of ``udpin:127.0.0.1:0``)."""
        return self._sock.getsockname() if self._sock is not None else None

    def write(self, buf: bytes | bytearray) -> None:
        """Called by pymavlink for every packet this boat sends: to the network and to the .tlog."""
        self._log(buf)
        if self._sock is None or self._peer is None:
            return
        try:
            self._sock.sendto(bytes(buf), self._peer)
            self.stats.packets_sent += 1
        except OSError:  # no route, buffer full, ICMP refusal from an earlier send: the next tick retries
            self.stats.send_errors += 1

    def _log(self, buf: bytes | bytearray) -> None:
        if self._tlog is not None:
            self._tlog.write(struct.pack(">Q", max(0, round(self._stamp_s * 1e6))) + bytes(buf))
            self.stats.packets_logged += 1

    def close(self, complete: bool = True) -> None:
        """Close the socket and the .tlog (idempotent). The .tlog, written next to its name, is moved into place
        if ``complete``; otherwise it is dropped and an old file of that name stays as it was."""
        if self._sock is not None:
            self._sock.close()
            self._sock = None
        tlog, self._tlog = self._tlog, None
        claim, self._tlog_claim = self._tlog_claim, None
        try:
            if tlog is not None:
                tlog.close()  # flushes: a full disk fails here too
            if claim is not None and complete:
                claim.commit(claim.scratch / claim.path.name)
        finally:
            if claim is not None:
                claim.release()  # the scratch and the lock go, whatever failed

    def __enter__(self) -> MavlinkBoat:
        return self

    def __exit__(self, exc_type: object, *exc: object) -> None:
        self.close(complete=exc_type is None)

    # ------------------------------------------------------------------ input
    def poll(self, timeout_s: float = 0.0) -> int:
        """Take in every pending datagram (waiting up to ``timeout_s`` for the first); returns how many."""
        self._stamp_s = self.twin.time_s
        if self._sock is None:
            return 0
        if timeout_s > 0.0:
            readable, _, _ = select.select([self._sock], [], [], timeout_s)
            if not readable:
                return 0
        count = packets = 0
        for _ in range(MAX_DATAGRAMS_PER_POLL):
            if packets >= MAX_PACKETS_PER_POLL:
                break
            try:
                data, sender = self._sock.recvfrom(UDP_MAX_DATAGRAM)
            except (BlockingIOError, InterruptedError):
                break
            except OSError as err:  # e.g. ECONNREFUSED for an earlier send (ICMP): consumed, not an input
                if err.errno in (errno.ECONNREFUSED, errno.ECONNRESET, errno.EHOSTUNREACH, errno.ENETUNREACH):
                    continue
                break
            count += 1
            self.stats.datagrams_received += 1
            packets += max(1, self._receive_datagram(data, sender, MAX_PACKETS_PER_POLL - packets))
        return count

    def _receive_datagram(self, data: bytes, sender: tuple[Any, ...], budget: int) -> int:
        """Parse one datagram and act on at most ``budget`` of its packets (the rest are counted as dropped);
        returns how many packets it held."""
        assert self.endpoint is not None
        if self.endpoint.mode == "udpout" and sender[0] != self.endpoint.sockaddr[0]:
            self.stats.rejected_sender += 1
            return 1
        parser = mavlink2.MAVLink(None)  # one parser per datagram: a bad datagram cannot spoil the next
        parser.robust_parsing = True
        try:
            packets = parser.parse_buffer(data) or []
        except Exception:  # noqa: BLE001 (pymavlink may raise other errors on hostile input)
            self.stats.bad_data += 1
            return 1
        if parser.buf_len() > 0:
            self.stats.truncated += 1
        accepted = False
        self.stats.flood_dropped += max(0, len(packets) - budget)
        for msg in packets[:budget]:
            if isinstance(msg, mavlink2.MAVLink_bad_data):
                self.stats.bad_data += 1
            elif isinstance(msg, mavlink2.MAVLink_unknown):
                self.stats.unknown_id += 1
            else:
                self.stats.packets_received += 1
                accepted = True
                self._log(msg.get_msgbuf())
                self._handle(msg)
        if accepted and self.endpoint.mode == "udpin":
            self._peer = sender
        return len(packets)

    def _for_us(self, system: int, component: int | None = None) -> bool:
        return system in (0, self.system_id) and (component is None or component in (0, self.component_id))

    def _handle(self, msg: Any) -> None:
        kind = msg.get_type()
        now = self.sim_time_s
        if kind == "MANUAL_CONTROL" and msg.target == self.system_id:
            if msg.y != _INT16_MAX:
                self._steering = (max(-1.0, min(1.0, msg.y / 1000.0)), now)
            if msg.z != _INT16_MAX:
                self._throttle = (max(-1.0, min(1.0, msg.z / 1000.0)), now)
            self.stats.commands_applied += 1
        elif kind == "RC_CHANNELS_OVERRIDE" and msg.target_system == self.system_id:
            for channel, attr in ((RC_STEERING_CHANNEL, "_steering"), (RC_THROTTLE_CHANNEL, "_throttle")):
                pwm = getattr(msg, f"chan{channel}_raw")
                if pwm == 0:
                    setattr(self, attr, None)  # released: back to the base command
                elif pwm != _UINT16_MAX:
                    setattr(self, attr, (fraction_from_pwm(pwm), now))
            self.stats.commands_applied += 1
        elif kind in ("COMMAND_LONG", "COMMAND_INT") and self._for_us(msg.target_system, msg.target_component):
            self._mav.command_ack_send(msg.command, mavlink2.MAV_RESULT_UNSUPPORTED, 0, 0,
                                       msg.get_srcSystem(), msg.get_srcComponent())
        elif kind == "REQUEST_DATA_STREAM" and self._for_us(msg.target_system, msg.target_component):
            self._request_data_stream(msg.req_stream_id, msg.req_message_rate, msg.start_stop, now)
        elif kind == "PARAM_REQUEST_LIST" and self._for_us(msg.target_system, msg.target_component):
            names = list(self._params())
            for index, name in enumerate(names):
                self._send_param(name, index, len(names))
        elif kind == "PARAM_REQUEST_READ" and self._for_us(msg.target_system, msg.target_component):
            names = list(self._params())
            name = _param_name(msg.param_id)
            if name in names:
                self._send_param(name, names.index(name), len(names))
            elif 0 <= msg.param_index < len(names) and not name:
                self._send_param(names[msg.param_index], msg.param_index, len(names))
        elif kind == "PARAM_SET" and self._for_us(msg.target_system, msg.target_component):
            self._param_set(_param_name(msg.param_id), msg.param_value, now)
        else:
            self.stats.ignored += 1

    def _request_data_stream(self, stream_id: int, rate_hz: int, start_stop: int, now: float) -> None:
        """ArduPilot's handling: start_stop 0 stops, 1 sets ``rate_hz``; id 0 (ALL) sets every group."""
        if start_stop not in (0, 1):
            return
        rate = min(float(rate_hz), MAX_STREAM_RATE_HZ) if start_stop == 1 else 0.0
        if stream_id == mavlink2.MAV_DATA_STREAM_ALL:
            targets = list(self.streams)
        else:
            group = DATA_STREAM_GROUPS.get(stream_id)
            targets = [group] if group else []
        for name in targets:
            self.streams[name].set_rate(rate, now)

    def _params(self) -> dict[str, float]:
        """The read-only parameters this boat reports (SR0_* rates settable), ArduPilot names."""
        values = {"SYSID_THISMAV": float(self.system_id), "RC_OVERRIDE_TIME": OVERRIDE_TIMEOUT_S}
        values.update({f"SR0_{name}": stream.rate_hz for name, stream in self.streams.items()})
        return values

    def _send_param(self, name: str, index: int, count: int) -> None:
        self._mav.param_value_send(name.encode(), self._params()[name], mavlink2.MAV_PARAM_TYPE_REAL32, count,
                                   index)

    def _param_set(self, name: str, value: float, now: float) -> None:
        names = list(self._params())
        if name not in names:
            return
        if name.startswith("SR0_") and math.isfinite(value):
            self.streams[name[4:]].set_rate(max(0.0, min(MAX_STREAM_RATE_HZ, float(value))), now)
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
            self._absorb()
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
                    if self._sock is not None:
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
    def _absorb(self) -> None:
        """Keep the latest GNSS fix, GNSS velocity and IMU attitude the twin measured this tick (its sensor
        models' measurements, not its ROS messages)."""
        gnss, imu = self.twin.tick_gnss, self.twin.tick_imu
        if gnss is not None and len(gnss):
            var = gnss.position_covariance_m2[-1]
            self._fix = {"stamp_s": float(gnss.stamp_s[-1]), "lat": float(gnss.lat_deg[-1]),
                         "lon": float(gnss.lon_deg[-1]), "alt": float(gnss.alt_m[-1]),
                         "h_std": math.sqrt(max(0.0, (var[0] + var[1]) / 2.0)), "v_std": math.sqrt(max(0.0, var[2]))}
            self._vel = (float(gnss.vel_east_mps[-1]), float(gnss.vel_north_mps[-1]), float(gnss.vel_up_mps[-1]))
        if imu is not None and len(imu):
            x, y, z, w = imu.quaternion_xyzw[-1].tolist()
            p, q, r = imu.gyro_radps[-1].tolist()
            self._attitude = (*ned_attitude(x, y, z, w), p, -q, -r)

    def _fix_fresh(self) -> bool:
        return self._fix is not None and self._stamp_s - self._fix["stamp_s"] <= STALE_FIX_S + 1e-6

    def _send_due(self, t_rel: float) -> None:
        if self._heartbeat.is_due(t_rel):
            self._send_heartbeat()
            self._heartbeat.sent(t_rel)
        for name, stream in self.streams.items():
            if stream.is_due(t_rel):
                sent = [self._send(kind, t_rel) for kind in STREAMS[name]]
                if any(sent):
                    stream.sent(t_rel)

    def _send_heartbeat(self) -> None:
        base_mode = (mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink2.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
                     | mavlink2.MAV_MODE_FLAG_SAFETY_ARMED)
        self._mav.heartbeat_send(mavlink2.MAV_TYPE_SURFACE_BOAT, mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA, base_mode,
                                 ROVER_MODE_MANUAL, mavlink2.MAV_STATE_ACTIVE)
        if self._tlog is not None:
            self._tlog.flush()  # the partial .tlog of a killed run lags by at most a second

    def _send(self, kind: str, t_rel: float) -> bool:
        """Send one message of ``kind`` if its data exist; True when sent."""
        boot_ms = _int(t_rel * 1000.0, 0, 2**32 - 1, 0)
        mav, fix, vel, att = self._mav, self._fix, self._vel, self._attitude
        gnss = self.twin.config.gnss
        if kind == "SYS_STATUS":
            health = _SENSORS_PRESENT if self._fix_fresh() else _SENSORS_PRESENT & ~mavlink2.MAV_SYS_STATUS_SENSOR_GPS
            s = self.stats
            total = s.packets_received + s.dropped
            drop_rate = _int(10000.0 * s.dropped / total, 0, 10000, 0) if total else 0
            mav.sys_status_send(_SENSORS_PRESENT, _SENSORS_PRESENT, health, 0, _UINT16_MAX, -1, -1, drop_rate,
                                min(s.dropped, _UINT16_MAX), 0, 0, 0, 0)
        elif kind == "SYSTEM_TIME":
            mav.system_time_send(_int(self._stamp_s * 1e6, 0, 2**64 - 1, 0), boot_ms)
        elif kind == "SERVO_OUTPUT_RAW":
            c, vessel = self.twin.commands, self.twin.config.vessel
            pwm = [pwm_from_fraction(c[2] / vessel.max_steering_rad), pwm_from_fraction(c[3] / vessel.max_steering_rad),
                   pwm_from_fraction(c[0] / vessel.bollard_thrust_N), pwm_from_fraction(c[1] / vessel.bollard_thrust_N)]
            mav.servo_output_raw_send(boot_ms * 1000 % 2**32, 0, *pwm, 0, 0, 0, 0)
        elif kind == "GPS_RAW_INT":
            if fix is None or vel is None:
                mav.gps_raw_int_send(boot_ms * 1000, mavlink2.GPS_FIX_TYPE_NO_FIX, 0, 0, 0, _UINT16_MAX, _UINT16_MAX,
                                     _UINT16_MAX, _UINT16_MAX, 255)
                return True
            speed = math.hypot(vel[0], vel[1])
            mav.gps_raw_int_send(
                _int(fix["stamp_s"] * 1e6, 0, 2**64 - 1, 0),
                mavlink2.GPS_FIX_TYPE_3D_FIX if self._fix_fresh() else mavlink2.GPS_FIX_TYPE_NO_FIX,
                _int(fix["lat"] * 1e7, -900_000_000, 900_000_000, 0),
                _int(fix["lon"] * 1e7, -1_800_000_000, 1_800_000_000, 0),
                _int(fix["alt"] * 1000.0, -(2**31), 2**31 - 1, 0),
                _UINT16_MAX, _UINT16_MAX,  # HDOP, VDOP: not modelled
                _int(speed * 100.0, 0, _UINT16_MAX - 1, _UINT16_MAX),
                _cdeg(compass_deg(vel[1], vel[0])),
                255,  # satellites: not modelled
                _int(fix["alt"] * 1000.0, -(2**31), 2**31 - 1, 0),
                _int(fix["h_std"] * 1000.0, 0, 2**32 - 1, 0),
                _int(fix["v_std"] * 1000.0, 0, 2**32 - 1, 0),
                _int(gnss.velocity_stdev_mps * 1000.0, 0, 2**32 - 1, 0),
                0, 0,
            )
        elif kind == "GLOBAL_POSITION_INT":
            if fix is None or vel is None:
                return False
            hdg = _cdeg(math.degrees(att[2])) if att else _UINT16_MAX
            mav.global_position_int_send(
                boot_ms,
                _int(fix["lat"] * 1e7, -900_000_000, 900_000_000, 0),
                _int(fix["lon"] * 1e7, -1_800_000_000, 1_800_000_000, 0),
                _int(fix["alt"] * 1000.0, -(2**31), 2**31 - 1, 0),
                _int((fix["alt"] - gnss.origin_alt_m) * 1000.0, -(2**31), 2**31 - 1, 0),
                _int(vel[1] * 100.0, -_INT16_MAX, _INT16_MAX, 0),
                _int(vel[0] * 100.0, -_INT16_MAX, _INT16_MAX, 0),
                _int(-vel[2] * 100.0, -_INT16_MAX, _INT16_MAX, 0),
                hdg,
            )
        elif kind == "ATTITUDE":
            if att is None:
                return False
            mav.attitude_send(boot_ms, *att)
        elif kind == "VFR_HUD":
            if att is None or vel is None or fix is None:
                return False
            c, vessel = self.twin.commands, self.twin.config.vessel
            speed = math.hypot(vel[0], vel[1])
            throttle = _int(50.0 * (c[0] + c[1]) / vessel.bollard_thrust_N, 0, 100, 0)
            mav.vfr_hud_send(speed, speed, _int(math.degrees(att[2]) % 360.0, 0, 360, 0) % 360, throttle,
                             fix["alt"], vel[2])
        return True


def _param_name(raw: Any) -> str:
    """A PARAM_* id field (bytes or str, NUL-padded) as a str."""
    if isinstance(raw, bytes):
        raw = raw.decode("ascii", "replace")
    return str(raw).rstrip("\x00")


def progress_to_stderr(line: str) -> None:
    """Progress callback for :meth:`MavlinkBoat.run`: the line on stderr."""
    sys.stderr.write(line + "\n")
    sys.stderr.flush()
