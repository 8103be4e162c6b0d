"""GNSS receiver model: what a ROS GNSS driver (nmea_navsat_driver, ublox) publishes from the true motion.

Position: the antenna (``gnss_link``, ``antenna_height_m`` straight above ``base_link``) in local ENU plus
noise, mapped to WGS-84 latitude/longitude/ellipsoidal height about a geodetic origin with pymap3d. Velocity:
ENU over ground plus noise (Doppler velocity, independent of the position noise). A fix stamped t describes
the boat at t - ``latency_s`` (delivered late; drivers stamp on reception). Lost fixes are dropped.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import pymap3d

from boat_twin.sensors import config_from_mapping, decimation_step, gauss_markov, number
from boat_twin.vessel.truth import TruthSeries

CEP_TO_SIGMA = 1.0 / math.sqrt(2.0 * math.log(2.0))
"""Per-axis stdev of a circular normal error per metre of its CEP (50 % radius): CEP = 1.1774 sigma."""

UBLOX_M8_CEP_M = 2.5
"""u-blox M8 (NEO-M8N) datasheet, GPS & GLONASS: horizontal position accuracy 2.5 m CEP (open sky)."""


@dataclass(frozen=True)
class GnssConfig:
    """A consumer GPS/GLONASS receiver (u-blox M8 class) on the boat; SI units, validated on construction."""

    rate_hz: float = 10.0
    """Fix rate, Hz; must divide the truth output rate. 10 Hz: the paper's logging rate (M8: <= 10 Hz)."""
    horizontal_stdev_m: float = UBLOX_M8_CEP_M * CEP_TO_SIGMA
    """Position noise stdev per horizontal axis (east, north), m: 2.5 m CEP (u-blox M8 datasheet) = 2.12 m."""
    vertical_stdev_m: float = 4.0
    """Height noise stdev, m. No datasheet figure: about twice the horizontal (VDOP ~ 2 HDOP), assumed."""
    position_correlation_time_s: float = 0.0
    """Correlation time of the position error, s (first-order Gauss-Markov); 0 = white, independent fixes."""
    velocity_stdev_mps: float = 0.05
    """Velocity noise stdev per ENU axis, m/s: u-blox M8 datasheet 0.05 m/s (50 % figure: conservative)."""
    latency_s: float = 0.1
    """Delivery delay, s: the fix stamped t carries the state at t - latency_s. 0.1 s (one epoch), assumed."""
    dropout_probability: float = 0.0
    """Probability that a fix is lost, independently per sample (0 <= p < 1); open sky over water: 0."""
    antenna_height_m: float = 1.5
    """Antenna height above the base_link origin (waterline), m, assumed; no horizontal offset."""
    origin_lat_deg: float = 43.07
    """Geodetic latitude of the local ENU origin (WGS-84), deg: Vladivostok, where the paper's boat ran."""
    origin_lon_deg: float = 131.90
    """Geodetic longitude of the local ENU origin (WGS-84), deg east: Vladivostok."""
    origin_alt_m: float = 0.0
    """Ellipsoidal height of the ENU origin (WGS-84), m. 0: on the ellipsoid, not at sea level (the geoid)."""

    def __post_init__(self) -> None:
        checks: dict[str, dict[str, Any]] = {
            "rate_hz": {"above": 0.0},
            "horizontal_stdev_m": {"minimum": 0.0},
            "vertical_stdev_m": {"minimum": 0.0},
            "position_correlation_time_s": {"minimum": 0.0},
            "velocity_stdev_mps": {"minimum": 0.0},
            "latency_s": {"minimum": 0.0},
            "dropout_probability": {"minimum": 0.0, "below": 1.0},
            "antenna_height_m": {"minimum": 0.0},
            "origin_lat_deg": {"minimum": -90.0, "maximum": 90.0},
            "origin_lon_deg": {"minimum": -180.0, "maximum": 180.0},
            "origin_alt_m": {},
        }
        for name, limits in checks.items():
            object.__setattr__(self, name, number(f"gnss.{name}", getattr(self, name), **limits))

    @classmethod
    def from_dict(cls, data: Any) -> GnssConfig:
        """From a YAML mapping (section ``gnss``); unknown or bad fields raise InputError naming them."""
        return config_from_mapping(cls, data, "gnss")


@dataclass(frozen=True)
class GnssMeasurements:
    """Fixes as a GNSS driver publishes them; arrays of shape (n,) unless noted, time-ordered."""

    stamp_s: np.ndarray
    """Header stamp (reception time), s since the start of the trial."""
    lat_deg: np.ndarray
    """WGS-84 latitude of the antenna, deg."""
    lon_deg: np.ndarray
    """WGS-84 longitude of the antenna, deg east."""
    alt_m: np.ndarray
    """Height of the antenna above the WGS-84 ellipsoid, m."""
    vel_east_mps: np.ndarray
    """Velocity over ground, east, m/s."""
    vel_north_mps: np.ndarray
    """Velocity over ground, north, m/s."""
    vel_up_mps: np.ndarray
    """Velocity over ground, up, m/s."""
    position_covariance_m2: np.ndarray
    """Diagonal of the ENU position covariance (east, north, up), m^2, shape (n, 3)."""

    def __len__(self) -> int:
        return int(self.stamp_s.size)


class GnssModel:
    """Turns a :class:`TruthSeries` into :class:`GnssMeasurements`; all randomness comes from ``rng``.

    ``noise=False`` switches off every random effect (noise and dropouts) and keeps the deterministic ones
    (rate, latency, antenna height): the measurements are then the delayed truth, exactly.
    """

    def __init__(self, config: GnssConfig, rng: np.random.Generator, *, noise: bool = True) -> None:
        self.config = config
        self.rng = rng
        self.noise = noise

    def measure(self, truth: TruthSeries) -> GnssMeasurements:
        """Fixes at the decimated truth times whose delayed state lies inside the truth series."""
        cfg = self.config
        t_s = np.asarray(truth.t_s, dtype=float)
        step = decimation_step(t_s, cfg.rate_hz, "gnss.rate_hz")
        stamp_s = t_s[::step]
        if t_s.size:
            stamp_s = stamp_s[stamp_s - cfg.latency_s >= t_s[0] - 1e-9]
        state_t_s = stamp_s - cfg.latency_s
        n = stamp_s.size

        def at_state_time(values: np.ndarray) -> np.ndarray:
            if n == 0:
                return np.zeros(0)
            return np.interp(state_t_s, t_s, values)  # exact at the truth samples themselves

        east_m = at_state_time(truth.east_m)
        north_m = at_state_time(truth.north_m)
        up_m = np.full(n, cfg.antenna_height_m)
        vel = np.column_stack(
            [at_state_time(truth.vel_east_mps), at_state_time(truth.vel_north_mps), np.zeros(n)]
        )
        keep = np.ones(n, dtype=bool)
        if self.noise:
            dt_s = 1.0 / cfg.rate_hz
            pos_err = gauss_markov(
                self.rng, n, 3,
                np.array([cfg.horizontal_stdev_m, cfg.horizontal_stdev_m, cfg.vertical_stdev_m]),
                dt_s, cfg.position_correlation_time_s,
            )
            east_m = east_m + pos_err[:, 0]
            north_m = north_m + pos_err[:, 1]
            up_m = up_m + pos_err[:, 2]
            vel = vel + self.rng.standard_normal((n, 3)) * cfg.velocity_stdev_mps
            keep = self.rng.random(n) >= cfg.dropout_probability
        lat_deg, lon_deg, alt_m = pymap3d.enu2geodetic(
            east_m[keep], north_m[keep], up_m[keep], cfg.origin_lat_deg, cfg.origin_lon_deg, cfg.origin_alt_m
        )
        variance = np.array([cfg.horizontal_stdev_m, cfg.horizontal_stdev_m, cfg.vertical_stdev_m]) ** 2
        n_kept = int(keep.sum())
        return GnssMeasurements(
            stamp_s=stamp_s[keep],
            lat_deg=np.asarray(lat_deg, dtype=float).reshape(n_kept),
            lon_deg=np.asarray(lon_deg, dtype=float).reshape(n_kept),
            alt_m=np.asarray(alt_m, dtype=float).reshape(n_kept),
            vel_east_mps=vel[keep, 0],
            vel_north_mps=vel[keep, 1],
            vel_up_mps=vel[keep, 2],
            position_covariance_m2=np.tile(variance, (n_kept, 1)),
        )
