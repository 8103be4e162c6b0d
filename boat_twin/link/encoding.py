"""What the MAVLink boat says, encoded: the twin's latest measurements (never its truth) as ArduPilot Rover's
telemetry messages, FLU/ENU turned into FRD/NED, commands as servo PWM (the conventions:
:mod:`boat_twin.link.mavlink_boat`)."""

from __future__ import annotations

import math
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from boat_twin.link.transport import LinkStats
from boat_twin.twin.live import LiveTwin

PWM_NEUTRAL_US = 1500
"""Neutral PWM (RCn_TRIM default), µs."""
PWM_HALF_RANGE_US = 400
"""PWM span from neutral to full scale, µs: 1100-1900 (ArduPilot's RCn_MIN/RCn_MAX defaults)."""
STALE_FIX_S = 1.0
"""GPS_RAW_INT reports NO_FIX (and SYS_STATUS an unhealthy GPS) when the last fix is older than this, s."""
ROVER_MODE_MANUAL = 0
"""ArduPilot Rover custom_mode number of MANUAL: the twin obeys thrust and steering as commanded."""

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



class TelemetryEncoder:
    """Keeps the twin's latest GNSS fix, velocity and attitude (:meth:`absorb`, each tick) and sends them through
    ``mav`` (pymavlink's encoder) as the messages :meth:`send` names; ``stats`` feed SYS_STATUS."""

    def __init__(self, mav: Any, twin: LiveTwin, stats: LinkStats) -> None:
        self.mav = mav
        self.twin = twin
        self.stats = stats
        self._fix: dict[str, float] | None = None
        self._vel: tuple[float, float, float] | None = None
        self._attitude: tuple[float, float, float, float, float, float] | None = None

    def absorb(self) -> None:
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

    def fix_fresh(self, stamp_s: float) -> bool:
        """Whether the last fix is at most :data:`STALE_FIX_S` older than ``stamp_s``."""
        return self._fix is not None and stamp_s - self._fix["stamp_s"] <= STALE_FIX_S + 1e-6

    def heartbeat(self) -> None:
        """HEARTBEAT: a surface boat, ArduPilot, Rover mode MANUAL, armed, active."""
        base_mode = (mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink2.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
                     | mavlink2.MAV_MODE_FLAG_SAFETY_ARMED)
        self.mav.heartbeat_send(mavlink2.MAV_TYPE_SURFACE_BOAT, mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA, base_mode,
                                ROVER_MODE_MANUAL, mavlink2.MAV_STATE_ACTIVE)

    def send(self, kind: str, t_rel: float, stamp_s: float) -> bool:
        """Send one message of ``kind`` (a :data:`~boat_twin.link.schedule.STREAMS` message) at ``t_rel`` s since
        the first tick (its boot time) and Unix ``stamp_s``, if its data exist; True when sent."""
        boot_ms = _int(t_rel * 1000.0, 0, 2**32 - 1, 0)
        encoders = {"SYS_STATUS": self._sys_status, "SYSTEM_TIME": self._system_time,
                    "SERVO_OUTPUT_RAW": self._servo_output_raw, "GPS_RAW_INT": self._gps_raw_int,
                    "GLOBAL_POSITION_INT": self._global_position_int, "ATTITUDE": self._attitude_message,
                    "VFR_HUD": self._vfr_hud}
        encoder = encoders.get(kind)
        return encoder(boot_ms, stamp_s) if encoder is not None else True

    def _sys_status(self, boot_ms: int, stamp_s: float) -> bool:
        health = _SENSORS_PRESENT if self.fix_fresh(stamp_s) else _SENSORS_PRESENT & ~mavlink2.MAV_SYS_STATUS_SENSOR_GPS
        s = self.stats
        total = s.packets_received + s.dropped
        drop_rate = _int(10000.0 * s.dropped / total, 0, 10000, 0) if total else 0
        self.mav.sys_status_send(_SENSORS_PRESENT, _SENSORS_PRESENT, health, 0, _UINT16_MAX, -1, -1, drop_rate,
                                 min(s.dropped, _UINT16_MAX), 0, 0, 0, 0)
        return True

    def _system_time(self, boot_ms: int, stamp_s: float) -> bool:
        self.mav.system_time_send(_int(stamp_s * 1e6, 0, 2**64 - 1, 0), boot_ms)
        return True

    def _servo_output_raw(self, boot_ms: int, stamp_s: float) -> bool:
        c, vessel = self.twin.commands, self.twin.config.vessel
        pwm = [pwm_from_fraction(c[2] / vessel.max_steering_rad), pwm_from_fraction(c[3] / vessel.max_steering_rad),
               pwm_from_fraction(c[0] / vessel.bollard_thrust_N), pwm_from_fraction(c[1] / vessel.bollard_thrust_N)]
        self.mav.servo_output_raw_send(boot_ms * 1000 % 2**32, 0, *pwm, 0, 0, 0, 0)
        return True

    def _gps_raw_int(self, boot_ms: int, stamp_s: float) -> bool:
        fix, vel = self._fix, self._vel
        if fix is None or vel is None:
            self.mav.gps_raw_int_send(boot_ms * 1000, mavlink2.GPS_FIX_TYPE_NO_FIX, 0, 0, 0, _UINT16_MAX,
                                      _UINT16_MAX, _UINT16_MAX, _UINT16_MAX, 255)
            return True
        speed = math.hypot(vel[0], vel[1])
        self.mav.gps_raw_int_send(
            _int(fix["stamp_s"] * 1e6, 0, 2**64 - 1, 0),
            mavlink2.GPS_FIX_TYPE_3D_FIX if self.fix_fresh(stamp_s) else mavlink2.GPS_FIX_TYPE_NO_FIX,
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
            _int(self.twin.config.gnss.velocity_stdev_mps * 1000.0, 0, 2**32 - 1, 0),
            0, 0,
        )
        return True

    def _global_position_int(self, boot_ms: int, stamp_s: float) -> bool:
        fix, vel, att = self._fix, self._vel, self._attitude
        if fix is None or vel is None:
            return False
        hdg = _cdeg(math.degrees(att[2])) if att else _UINT16_MAX
        self.mav.global_position_int_send(
            boot_ms,
            _int(fix["lat"] * 1e7, -900_000_000, 900_000_000, 0),
            _int(fix["lon"] * 1e7, -1_800_000_000, 1_800_000_000, 0),
            _int(fix["alt"] * 1000.0, -(2**31), 2**31 - 1, 0),
            _int((fix["alt"] - self.twin.config.gnss.origin_alt_m) * 1000.0, -(2**31), 2**31 - 1, 0),
            _int(vel[1] * 100.0, -_INT16_MAX, _INT16_MAX, 0),
            _int(vel[0] * 100.0, -_INT16_MAX, _INT16_MAX, 0),
            _int(-vel[2] * 100.0, -_INT16_MAX, _INT16_MAX, 0),
            hdg,
        )
        return True

    def _attitude_message(self, boot_ms: int, stamp_s: float) -> bool:
        if self._attitude is None:
            return False
        self.mav.attitude_send(boot_ms, *self._attitude)
        return True

    def _vfr_hud(self, boot_ms: int, stamp_s: float) -> bool:
        fix, vel, att = self._fix, self._vel, self._attitude
        if att is None or vel is None or fix is None:
            return False
        c, vessel = self.twin.commands, self.twin.config.vessel
        speed = math.hypot(vel[0], vel[1])
        throttle = _int(50.0 * (c[0] + c[1]) / vessel.bollard_thrust_N, 0, 100, 0)
        self.mav.vfr_hud_send(speed, speed, _int(math.degrees(att[2]) % 360.0, 0, 360, 0) % 360, throttle,
                              fix["alt"], vel[2])
        return True
