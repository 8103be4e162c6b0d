"""CH Robotics (Redshift Labs) UM7 AHRS model: what the ROS 2 ``um7`` driver publishes from the true motion.

Conventions follow the ROS 2 driver (github.com/ros-drivers/um7, ``src/um7_driver.cpp``, ``tf_ned_to_enu``
default true) and REP-103/REP-145 where the driver is known to be wrong:

- ``imu/data`` (sensor_msgs/Imu, frame ``imu_link``): orientation of the FLU body in the ENU world (REP-103;
  the driver's own NED->ENU quaternion shuffle is an open bug, ros-drivers/um7 #13), angular velocity in rad/s
  and acceleration in m/s^2 in the FLU body, gravity included (+g on z at rest, REP-145).
- ``imu/mag`` (sensor_msgs/MagneticField): the field in the FLU body, in tesla as the message defines (the
  driver passes on the UM7's unit-norm, dimensionless processed field).
- ``imu/rpy`` (geometry_msgs/Vector3Stamped): radians (driver scale 0.0109863 deg/LSB times pi/180), laid out
  as the driver's ENU mode does: x = NED pitch = -pitch, y = NED roll = roll, z = -NED yaw = yaw - pi/2
  (counter-clockwise from north, wrapped to [-pi, pi)); pitch, roll, yaw here are REP-103 angles.
- ``imu/temperature`` (std_msgs/Float32, no header): degrees Celsius.

The boat model is 3-DOF: true roll = pitch = 0, angular velocity (0, 0, r), acceleration (ax, ay, +g).
``imu_link`` coincides with ``base_link`` (no lever arm).

Pieces: :func:`expected_imu` / :func:`expected_gyro` (noise-free outputs, gravity and constant bias included;
any array shape), :class:`Um7Noise` (orientation Gauss-Markov state, gyro bias random walk state, white noise;
``step()`` per sample or ``run(n)``), :func:`imu_samples` (expected + errors -> :class:`ImuMeasurements`).
:class:`Um7Model` composes them over a batch record.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from boat_twin.frames import ned_yaw_from_enu, quaternion_xyzw, wrap_pi
from boat_twin.sensors import DrawKind, GaussMarkov, decimation_step, positioned_generators
from boat_twin.units import STANDARD_GRAVITY_MPS2
from boat_twin.validation import config_from_mapping, number, vector3
from boat_twin.vessel.truth import TruthSeries

WMM2020_VLADIVOSTOK_ENU_TESLA = (-4.892e-6, 26.225e-6, -45.635e-6)
"""Geomagnetic field (east, north, up), T: WMM2020 at 43.07 N, 131.90 E, 0 m, epoch 2020.0
(declination -10.57 deg, inclination 59.69 deg, total 52 860 nT)."""


GYRO_FULL_SCALE_RADPS = math.radians(2000.0)
"""±2000 °/s: the largest full scale of MEMS gyros (the UM7's included); a noise or drift beyond is no gyro."""
ACCEL_FULL_SCALE_MPS2 = 16.0 * STANDARD_GRAVITY_MPS2
"""±16 g: the largest full scale of MEMS accelerometers; a noise beyond it is no accelerometer."""
UM7_LIMITS: dict[str, dict[str, float]] = {
    "rate_hz": {"above": 0.0},
    "gyro_stdev_radps": {"minimum": 0.0, "maximum": GYRO_FULL_SCALE_RADPS},
    "gyro_bias_walk_radps_per_sqrt_s": {"minimum": 0.0, "maximum": GYRO_FULL_SCALE_RADPS},
    "accel_stdev_mps2": {"minimum": 0.0, "maximum": ACCEL_FULL_SCALE_MPS2},
    "roll_pitch_stdev_rad": {"minimum": 0.0, "maximum": math.pi},
    "yaw_stdev_rad": {"minimum": 0.0, "maximum": math.pi},
    "orientation_correlation_time_s": {"minimum": 0.0},
    "mag_stdev_tesla": {"minimum": 0.0, "maximum": 1e-4},
    "temperature_celsius": {"minimum": -40.0, "maximum": 85.0},
}
"""Range of each scalar field: stdevs up to the sensor's full scale (angles up to π, the magnetometer's up to
100 µT, about twice the strongest geomagnetic field); the temperature within the UM7's −40…85 °C operating
range (datasheet)."""


@dataclass(frozen=True)
class Um7Config:
    """A UM7 (UM7-LT, as on the paper's boat) with the ROS 2 driver's defaults; SI units, validated."""

    rate_hz: float = 10.0
    """Output rate, Hz; must divide the truth output rate. The paper logged at 10 Hz (driver: 20 Hz)."""
    gyro_stdev_radps: float = math.radians(0.06)
    """Angular rate white noise stdev per axis, rad/s: 0.06 deg/s, the driver's default (from hardware)."""
    gyro_bias_radps: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """Constant gyro bias (x, y, z) in the FLU body, rad/s. 0: the driver zeroes the gyros on start-up."""
    gyro_bias_walk_radps_per_sqrt_s: float = 0.0
    """Gyro bias random walk, rad/s per sqrt(s): the bias drifts by this times sqrt(elapsed s). 0 = off."""
    accel_stdev_mps2: float = 4.0e-3 * STANDARD_GRAVITY_MPS2
    """Acceleration white noise stdev per axis, m/s^2: 4 mg, the driver's default (from hardware)."""
    roll_pitch_stdev_rad: float = math.radians(3.0)
    """Roll and pitch estimate error stdev, rad: 3 deg, UM7 datasheet dynamic accuracy (driver default)."""
    yaw_stdev_rad: float = math.radians(3.0)
    """Yaw (heading) estimate error stdev, rad: 3 deg, as the driver's default orientation_z_stdev."""
    orientation_correlation_time_s: float = 0.0
    """Correlation time of the orientation error, s (first-order Gauss-Markov); 0 = white per sample."""
    magnetic_field_enu_tesla: tuple[float, float, float] = WMM2020_VLADIVOSTOK_ENU_TESLA
    """Local geomagnetic field (east, north, up), T: WMM2020 near the default GNSS origin (Vladivostok)."""
    mag_stdev_tesla: float = 0.5e-6
    """Magnetometer white noise stdev per axis, T: about 1 % of the field, assumed (no published figure)."""
    temperature_celsius: float = 25.0
    """Reported board temperature, deg C; constant, assumed."""

    def __post_init__(self) -> None:
        for name, limits in UM7_LIMITS.items():
            object.__setattr__(self, name, number(f"um7.{name}", getattr(self, name), **limits))
        for name in ("gyro_bias_radps", "magnetic_field_enu_tesla"):
            object.__setattr__(self, name, vector3(f"um7.{name}", getattr(self, name)))

    @classmethod
    def from_dict(cls, data: Any) -> Um7Config:
        """From a YAML mapping (section ``um7``); unknown or bad fields raise InputError naming them."""
        return config_from_mapping(cls, data, "um7")


@dataclass(frozen=True)
class ImuMeasurements:
    """UM7 outputs, time-ordered; per-sample arrays have n rows, covariance diagonals are per series."""

    stamp_s: np.ndarray
    """Header stamp, s since the start of the trial, shape (n,)."""
    quaternion_xyzw: np.ndarray
    """Estimated orientation of the FLU body in ENU (x, y, z, w), w >= 0, shape (n, 4)."""
    yaw_rad: np.ndarray
    """Estimated ENU yaw (counter-clockwise from east), rad, unwrapped, shape (n,)."""
    gyro_radps: np.ndarray
    """Angular velocity in the FLU body, rad/s, shape (n, 3)."""
    accel_mps2: np.ndarray
    """Specific force in the FLU body, gravity included (+g on z at rest), m/s^2, shape (n, 3)."""
    mag_tesla: np.ndarray
    """Magnetic field in the FLU body, T, shape (n, 3)."""
    rpy_rad: np.ndarray
    """``imu/rpy`` as the driver lays it out: (-pitch, roll, yaw - pi/2 wrapped to [-pi, pi)), rad, (n, 3)."""
    temperature_celsius: np.ndarray
    """Board temperature, deg C, shape (n,)."""
    orientation_covariance_rad2: np.ndarray
    """Diagonal of the orientation covariance about x, y, z, rad^2, shape (3,)."""
    gyro_covariance_radps2: np.ndarray
    """Diagonal of the angular velocity covariance, (rad/s)^2, shape (3,)."""
    accel_covariance_mps2_2: np.ndarray
    """Diagonal of the acceleration covariance, (m/s^2)^2, shape (3,)."""
    mag_covariance_tesla2: np.ndarray
    """Diagonal of the magnetic field covariance, T^2, shape (3,)."""

    def __len__(self) -> int:
        return int(self.stamp_s.size)


@dataclass(frozen=True)
class ExpectedImu:
    """What the UM7 reads without noise: arrays of the inputs' shape (...), vectors with a last axis of 3."""

    yaw_rad: np.ndarray
    """ENU yaw of the orientation estimate (roll = pitch = 0: 3-DOF), rad."""
    gyro_radps: np.ndarray
    """(..., 3) angular velocity in the FLU body plus the constant gyro bias, rad/s."""
    accel_mps2: np.ndarray
    """(..., 3) specific force in the FLU body, gravity included (+g on z), m/s^2."""
    mag_tesla: np.ndarray
    """(..., 3) the configured geomagnetic field in the FLU body, T."""


@dataclass(frozen=True)
class Um7Errors:
    """Random errors of n samples, drawn by :class:`Um7Noise`; every array (n, 3)."""

    attitude_rad: np.ndarray
    """Orientation estimate error (roll, pitch, yaw), rad."""
    gyro_radps: np.ndarray
    """Angular velocity error in the FLU body (bias random walk plus white noise), rad/s."""
    accel_mps2: np.ndarray
    """Acceleration error in the FLU body, m/s^2."""
    mag_tesla: np.ndarray
    """Magnetic field error in the FLU body, T."""


def expected_gyro(config: Um7Config, yaw_rate_radps: np.ndarray) -> np.ndarray:
    """(..., 3) noise-free gyro reading, rad/s: the body rate (0, 0, yaw rate) plus the constant bias."""
    yaw_rate = np.asarray(yaw_rate_radps, dtype=float)
    gyro = np.zeros(yaw_rate.shape + (3,))
    gyro[..., 2] = yaw_rate
    gyro += np.asarray(config.gyro_bias_radps)
    return gyro


def expected_imu(config: Um7Config, yaw_rad: np.ndarray, yaw_rate_radps: np.ndarray, accel_x_mps2: np.ndarray,
                 accel_y_mps2: np.ndarray) -> ExpectedImu:
    """The noise-free UM7 outputs from the true yaw (rad), yaw rate (rad/s) and body acceleration over
    ground (m/s^2, no gravity), arrays of any one shape (samples, boats, ...)."""
    yaw = np.asarray(yaw_rad, dtype=float)
    b_east, b_north, b_up = config.magnetic_field_enu_tesla
    cos_yaw, sin_yaw = np.cos(yaw), np.sin(yaw)
    return ExpectedImu(
        yaw_rad=yaw,
        gyro_radps=expected_gyro(config, yaw_rate_radps),
        accel_mps2=np.stack([np.asarray(accel_x_mps2, dtype=float), np.asarray(accel_y_mps2, dtype=float),
                             np.full(yaw.shape, STANDARD_GRAVITY_MPS2)], axis=-1),
        mag_tesla=np.stack([cos_yaw * b_east + sin_yaw * b_north, -sin_yaw * b_east + cos_yaw * b_north,
                            np.full(yaw.shape, b_up)], axis=-1),
    )


class Um7Noise:
    """The UM7's random errors with their state (orientation Gauss-Markov error, gyro bias random walk, RNG),
    one sample at a time (:meth:`step`) or a record at once (:meth:`run`); a sample lasts ``1 / rate_hz`` s.

    Per sample it draws, in this order: orientation error, bias walk increment, gyro, accelerometer and
    magnetometer white noise. The bias walk starts at 0 (the bias at its constant value) on the first sample.
    """

    DRAWS: tuple[tuple[DrawKind, int], ...] = (("normal", 3),) * 5
    """Per sample, in draw order: orientation, bias walk, gyro, accelerometer, magnetometer (3 normals each)."""

    def __init__(self, config: Um7Config, rng: np.random.Generator,
                 streams: Sequence[np.random.Generator] | None = None) -> None:
        self.config = config
        self.dt_s = 1.0 / config.rate_hz
        """Sample period, s."""
        attitude_rng, self._walk_rng, self._gyro_rng, self._accel_rng, self._mag_rng = (
            streams if streams is not None else (rng,) * 5)
        stdev = np.array([config.roll_pitch_stdev_rad, config.roll_pitch_stdev_rad, config.yaw_stdev_rad])
        self.attitude = GaussMarkov(attitude_rng, 3, stdev, self.dt_s, config.orientation_correlation_time_s)
        self.bias_walk_radps: np.ndarray | None = None
        """Gyro bias drift at the last sample (x, y, z), rad/s; None before the first sample."""

    @classmethod
    def for_record(cls, config: Um7Config, rng: np.random.Generator, n: int) -> Um7Noise:
        """The process for a record of ``n`` samples read in chunks: its ``run`` calls (n samples in all) give
        exactly the errors of ``Um7Noise(config, rng).run(n)``, and ``rng`` is left where that leaves it."""
        return cls(config, rng, positioned_generators(rng, [(kind, n * width) for kind, width in cls.DRAWS]))

    def run(self, n: int) -> Um7Errors:
        """Errors of the next ``n`` samples (each kind drawn as one block: the batch draw order)."""
        cfg = self.config
        attitude = self.attitude.run(n)
        walk = self._walk_rng.standard_normal((n, 3)) * (cfg.gyro_bias_walk_radps_per_sqrt_s * math.sqrt(self.dt_s))
        if n:
            walk[0] = 0.0 if self.bias_walk_radps is None else walk[0] + self.bias_walk_radps
            bias = np.cumsum(walk, axis=0)
            self.bias_walk_radps = bias[-1]
        else:
            bias = walk
        return Um7Errors(
            attitude_rad=attitude,
            gyro_radps=bias + self._gyro_rng.standard_normal((n, 3)) * cfg.gyro_stdev_radps,
            accel_mps2=self._accel_rng.standard_normal((n, 3)) * cfg.accel_stdev_mps2,
            mag_tesla=self._mag_rng.standard_normal((n, 3)) * cfg.mag_stdev_tesla,
        )

    def step(self) -> Um7Errors:
        """Errors of the next sample (arrays with n = 1)."""
        return self.run(1)


def imu_samples(config: Um7Config, stamp_s: np.ndarray, expected: ExpectedImu, errors: Um7Errors | None
                ) -> ImuMeasurements:
    """The published samples: ``expected`` (n samples, at ``stamp_s``) plus ``errors`` (None: noise-free)."""
    n = stamp_s.size
    gyro, accel, mag = expected.gyro_radps, expected.accel_mps2, expected.mag_tesla
    attitude_error = np.zeros((n, 3))
    if errors is not None:
        attitude_error = errors.attitude_rad
        gyro = gyro + errors.gyro_radps
        accel = accel + errors.accel_mps2
        mag = mag + errors.mag_tesla
    roll, pitch = attitude_error[:, 0], attitude_error[:, 1]
    yaw = expected.yaw_rad + attitude_error[:, 2]
    return ImuMeasurements(
        stamp_s=stamp_s,
        quaternion_xyzw=quaternion_xyzw(roll, pitch, yaw),
        yaw_rad=yaw,
        gyro_radps=gyro,
        accel_mps2=accel,
        mag_tesla=mag,
        rpy_rad=np.column_stack([-pitch, roll, wrap_pi(-ned_yaw_from_enu(yaw))]),
        temperature_celsius=np.full(n, config.temperature_celsius),
        orientation_covariance_rad2=np.array(
            [config.roll_pitch_stdev_rad, config.roll_pitch_stdev_rad, config.yaw_stdev_rad]) ** 2,
        gyro_covariance_radps2=np.full(3, config.gyro_stdev_radps**2),
        accel_covariance_mps2_2=np.full(3, config.accel_stdev_mps2**2),
        mag_covariance_tesla2=np.full(3, config.mag_stdev_tesla**2),
    )


class Um7Model:
    """Turns a :class:`TruthSeries` into :class:`ImuMeasurements`; all randomness comes from ``rng``.

    ``noise=False`` switches off every random effect (white noise, bias random walk, orientation error) and
    keeps the deterministic ones (rate, constant gyro bias): the measurements are then the truth, exactly.
    """

    def __init__(self, config: Um7Config, rng: np.random.Generator, *, noise: bool = True) -> None:
        self.config = config
        self.rng = rng
        self.noise = noise

    def measure(self, truth: TruthSeries) -> ImuMeasurements:
        """Samples at the decimated truth times: the :func:`expected_imu` plus a :class:`Um7Noise` run over
        the record."""
        return next(self.measure_chunks(truth, max(1, len(truth))))

    def measure_chunks(self, truth: TruthSeries, chunk_ticks: int) -> Iterator[ImuMeasurements]:
        """:meth:`measure` a block of ``chunk_ticks`` truth ticks at a time: the samples stamped inside each
        block (one item per block, possibly empty), the same values bit for bit, memory bounded by the block.
        The noise takes its place in ``rng``'s stream at this call, before any block is read."""
        cfg = self.config
        t_s = np.asarray(truth.t_s, dtype=float)
        step = decimation_step(t_s, cfg.rate_hz, "um7.rate_hz")
        noise = Um7Noise.for_record(cfg, self.rng, -(-t_s.size // step)) if self.noise else None

        def block(start: int) -> ImuMeasurements:
            ticks = slice(-(-start // step) * step, min(start + chunk_ticks, t_s.size), step)
            expected = expected_imu(cfg, np.asarray(truth.yaw_rad, dtype=float)[ticks],
                                    np.asarray(truth.yaw_rate_radps, dtype=float)[ticks],
                                    np.asarray(truth.accel_x_mps2, dtype=float)[ticks],
                                    np.asarray(truth.accel_y_mps2, dtype=float)[ticks])
            errors = noise.run(t_s[ticks].size) if noise is not None else None
            return imu_samples(cfg, t_s[ticks], expected, errors)

        return (block(start) for start in range(0, max(t_s.size, 1), chunk_ticks))
