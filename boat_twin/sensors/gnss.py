"""GNSS receiver model: what a ROS GNSS driver (nmea_navsat_driver, ublox) publishes from the true motion.

Position: the antenna (``gnss_link``, ``antenna_height_m`` straight above ``base_link``) in local ENU plus
noise, mapped to WGS-84 latitude/longitude/ellipsoidal height about a geodetic origin with pymap3d. Velocity:
ENU over ground plus noise (Doppler velocity, independent of the position noise). A fix stamped t describes
the boat at t - ``latency_s`` (delivered late; drivers stamp on reception). Lost fixes are dropped.

Pieces: :func:`expected_fix` (noise-free antenna position and velocity, latency applied; vectorised over samples
and boats or windows), :class:`GnssNoise` (position Gauss-Markov state, velocity noise, dropouts; ``step()`` per
fix or ``run(n)``), :func:`fixes` (expected + errors -> :class:`GnssMeasurements`). :class:`GnssModel` composes
them over a batch record.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, fields
from typing import Any

import numpy as np
import pymap3d

from boat_twin.sensors import DrawKind, GaussMarkov, decimation_step, positioned_generators
from boat_twin.validation import config_from_mapping, number
from boat_twin.vessel.truth import TruthSeries

CEP_TO_SIGMA = 1.0 / math.sqrt(2.0 * math.log(2.0))
"""Per-axis stdev of a circular normal error per metre of its CEP (50 % radius): CEP = 1.1774 sigma."""

UBLOX_M8_CEP_M = 2.5
"""u-blox M8 (NEO-M8N) datasheet, GPS & GLONASS: horizontal position accuracy 2.5 m CEP (open sky)."""


MAX_POSITION_STDEV_M = 1000.0
"""Largest position noise stdev, m: a receiver worse than a kilometre has no fix (M8: 2.5 m CEP)."""
MAX_LATENCY_S = 10.0
"""Largest delivery delay, s: receivers deliver a fix within about one epoch (0.1-1 s); 10 s leaves a margin."""


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
            "horizontal_stdev_m": {"minimum": 0.0, "maximum": MAX_POSITION_STDEV_M},
            "vertical_stdev_m": {"minimum": 0.0, "maximum": MAX_POSITION_STDEV_M},
            "position_correlation_time_s": {"minimum": 0.0},
            "velocity_stdev_mps": {"minimum": 0.0, "maximum": 10.0},  # m/s: M8 0.05; beyond 10, no velocity
            "latency_s": {"minimum": 0.0, "maximum": MAX_LATENCY_S},
            "dropout_probability": {"minimum": 0.0, "below": 1.0},
            "antenna_height_m": {"minimum": 0.0, "maximum": 100.0},  # m: a mast, not a tower
            "origin_lat_deg": {"minimum": -90.0, "maximum": 90.0},
            "origin_lon_deg": {"minimum": -180.0, "maximum": 180.0},
            "origin_alt_m": {"minimum": -1000.0, "maximum": 10000.0},  # m: Dead Sea -430 to mountain lakes
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


@dataclass(frozen=True)
class ExpectedFix:
    """What the receiver reads without noise: the antenna's local ENU position and velocity over ground at
    each sample time, from the state ``latency_s`` earlier; arrays of shape (n, ...) like the inputs."""

    east_m: np.ndarray
    """Antenna east of the geodetic origin, m."""
    north_m: np.ndarray
    """Antenna north of the geodetic origin, m."""
    up_m: np.ndarray
    """Antenna height above the origin (``antenna_height_m``: the boat is 3-DOF), m."""
    vel_east_mps: np.ndarray
    """Velocity over ground, east, m/s."""
    vel_north_mps: np.ndarray
    """Velocity over ground, north, m/s."""
    vel_up_mps: np.ndarray
    """Velocity over ground, up (0: 3-DOF), m/s."""
    has_state: np.ndarray
    """(n,) bool: the delayed state lies inside the record (earlier samples hold the first state)."""

    def at(self, index: np.ndarray | slice) -> ExpectedFix:
        """The samples ``index`` (along the first axis)."""
        return ExpectedFix(**{f.name: getattr(self, f.name)[index] for f in fields(self)})


@dataclass(frozen=True)
class GnssErrors:
    """Random errors of n fixes, drawn by :class:`GnssNoise`."""

    position_m: np.ndarray
    """(n, 3) ENU position error (east, north, up), m."""
    velocity_mps: np.ndarray
    """(n, 3) ENU velocity error, m/s."""
    received: np.ndarray
    """(n,) bool: False where the fix is lost."""


def delayed(t_s: np.ndarray, values: np.ndarray, delay_s: float) -> np.ndarray:
    """``values`` (n, ...) sampled at increasing times ``t_s`` (n,), s, read at ``t_s - delay_s``: linear
    between samples, held at the first sample before it (:func:`numpy.interp` per column, exact at samples)."""
    values = np.asarray(values, dtype=float)
    if t_s.size == 0:
        return values.copy()
    columns = values.reshape(t_s.size, -1)
    return _interp_columns(t_s - delay_s, t_s, columns).reshape(values.shape)


def _interp_columns(x: np.ndarray, xp: np.ndarray, fp: np.ndarray) -> np.ndarray:
    """``np.interp(x, xp, fp[:, j])`` for every column j of ``fp`` (len(xp), k) at once, bit for bit: the same
    interval, the same slope·(x − xp[i]) + fp[i] (from the right end where that is NaN), each sample exact, held
    beyond the ends. One pass over the (n, k) array instead of k calls (a replay's windows: k in the hundreds)."""
    n = xp.size
    i = np.clip(np.searchsorted(xp, x, side="right") - 1, 0, max(n - 2, 0))[:, None]
    nxt = np.minimum(i + 1, n - 1)
    left, right = fp[i[:, 0]], fp[nxt[:, 0]]
    with np.errstate(invalid="ignore", divide="ignore"):
        slope = (right - left) / (xp[nxt] - xp[i])
        out = slope * (x[:, None] - xp[i]) + left
        lost = np.isnan(out)
        if lost.any():
            out = np.where(lost, slope * (x[:, None] - xp[nxt]) + right, out)
            out = np.where(np.isnan(out) & (left == right), left, out)
    out = np.where(x[:, None] == xp[i], left, out)
    out = np.where((x < xp[0])[:, None], fp[:1], out)
    return np.where((x >= xp[-1])[:, None], fp[-1:], out)


def expected_fix(config: GnssConfig, t_s: np.ndarray, east_m: np.ndarray, north_m: np.ndarray,
                 vel_east_mps: np.ndarray, vel_north_mps: np.ndarray) -> ExpectedFix:
    """The noise-free fix at every time of ``t_s`` (n,), s, from the true motion: ``base_link`` position
    (local ENU, m) and velocity over ground (m/s), each of shape (n, ...) (e.g. (n, boats) or (n, windows)).

    Latency: the fix at t carries the state at t - ``latency_s`` (:func:`delayed`). Antenna: ``antenna_height_m``
    straight above ``base_link``, so the horizontal position and velocity are those of the boat.
    """
    t_s = np.asarray(t_s, dtype=float)
    latency_s = config.latency_s
    east = delayed(t_s, east_m, latency_s)
    has_state = t_s - latency_s >= (t_s[0] if t_s.size else 0.0) - 1e-9
    return ExpectedFix(
        east_m=east,
        north_m=delayed(t_s, north_m, latency_s),
        up_m=np.full(east.shape, config.antenna_height_m),
        vel_east_mps=delayed(t_s, vel_east_mps, latency_s),
        vel_north_mps=delayed(t_s, vel_north_mps, latency_s),
        vel_up_mps=np.zeros(east.shape),
        has_state=has_state,
    )


class GnssNoise:
    """The receiver's random errors with their state (Gauss-Markov position error, RNG), one fix at a time
    (:meth:`step`) or a record at once (:meth:`run`); a fix lasts ``1 / rate_hz`` s.

    Per fix it draws, in this order: position error (Gauss-Markov, stdev horizontal/horizontal/vertical),
    velocity error (white, ``velocity_stdev_mps``), loss (probability ``dropout_probability``).
    :meth:`for_record` gives a process whose ``run`` calls over a record draw what one ``run(n)`` would.
    """

    DRAWS: tuple[tuple[DrawKind, int], ...] = (("normal", 3), ("normal", 3), ("uniform", 1))
    """Per fix, in draw order: position (3 normals), velocity (3 normals), loss (1 uniform)."""

    def __init__(self, config: GnssConfig, rng: np.random.Generator,
                 streams: Sequence[np.random.Generator] | None = None) -> None:
        self.config = config
        position_rng, self._velocity_rng, self._loss_rng = streams if streams is not None else (rng, rng, rng)
        stdev = np.array([config.horizontal_stdev_m, config.horizontal_stdev_m, config.vertical_stdev_m])
        self.position = GaussMarkov(position_rng, 3, stdev, 1.0 / config.rate_hz, config.position_correlation_time_s)

    @classmethod
    def for_record(cls, config: GnssConfig, rng: np.random.Generator, n: int) -> GnssNoise:
        """The process for a record of ``n`` fixes read in chunks: its ``run`` calls (n fixes in all) give
        exactly the errors of ``GnssNoise(config, rng).run(n)``, and ``rng`` is left where that leaves it."""
        return cls(config, rng, positioned_generators(rng, [(kind, n * width) for kind, width in cls.DRAWS]))

    def run(self, n: int) -> GnssErrors:
        """Errors of the next ``n`` fixes (each kind drawn as one block: the batch draw order)."""
        position = self.position.run(n)
        velocity = self._velocity_rng.standard_normal((n, 3)) * self.config.velocity_stdev_mps
        received = self._loss_rng.random(n) >= self.config.dropout_probability
        return GnssErrors(position_m=position, velocity_mps=velocity, received=received)

    def step(self) -> GnssErrors:
        """Errors of the next fix (arrays with n = 1)."""
        return self.run(1)


def fixes(config: GnssConfig, stamp_s: np.ndarray, expected: ExpectedFix, errors: GnssErrors | None
          ) -> GnssMeasurements:
    """The published fixes: ``expected`` (shape (n,), at ``stamp_s``) plus ``errors`` (None: noise-free),
    lost fixes dropped, mapped to WGS-84 about the config's origin."""
    n = stamp_s.size
    east_m, north_m, up_m = expected.east_m, expected.north_m, expected.up_m
    vel = np.column_stack([expected.vel_east_mps, expected.vel_north_mps, expected.vel_up_mps])
    keep = np.ones(n, dtype=bool)
    if errors is not None:
        east_m = east_m + errors.position_m[:, 0]
        north_m = north_m + errors.position_m[:, 1]
        up_m = up_m + errors.position_m[:, 2]
        vel = vel + errors.velocity_mps
        keep = errors.received
    lat_deg, lon_deg, alt_m = pymap3d.enu2geodetic(
        east_m[keep], north_m[keep], up_m[keep], config.origin_lat_deg, config.origin_lon_deg, config.origin_alt_m
    )
    variance = np.array([config.horizontal_stdev_m, config.horizontal_stdev_m, config.vertical_stdev_m]) ** 2
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
        """Fixes at the decimated truth times whose delayed state lies inside the truth series: the
        :func:`expected_fix` plus a :class:`GnssNoise` run over the record."""
        return next(self.measure_chunks(truth, max(1, len(truth))))

    def measure_chunks(self, truth: TruthSeries, chunk_ticks: int) -> Iterator[GnssMeasurements]:
        """:meth:`measure` a block of ``chunk_ticks`` truth ticks at a time: the fixes stamped inside each block
        (one item per block, possibly empty), the same values bit for bit, memory bounded by the block.
        The noise takes its place in ``rng``'s stream at this call, before any block is read."""
        cfg = self.config
        t_s = np.asarray(truth.t_s, dtype=float)
        step = decimation_step(t_s, cfg.rate_hz, "gnss.rate_hz")
        has_state = t_s - cfg.latency_s >= (t_s[0] if t_s.size else 0.0) - 1e-9
        index = np.arange(0, t_s.size, step)
        index = index[has_state[index]]
        noise = GnssNoise.for_record(cfg, self.rng, index.size) if self.noise else None
        dt_s = float(t_s[1] - t_s[0]) if t_s.size > 1 else 1.0
        lead = math.ceil(cfg.latency_s / dt_s) + 1  # ticks before a block that its delayed states need

        def block(start: int) -> GnssMeasurements:
            stop = min(start + chunk_ticks, t_s.size)
            fix = index[(index >= start) & (index < stop)]
            ticks = slice(max(0, start - lead), stop)
            expected = expected_fix(cfg, t_s[ticks], truth.east_m[ticks], truth.north_m[ticks],
                                    truth.vel_east_mps[ticks], truth.vel_north_mps[ticks])
            errors = noise.run(fix.size) if noise is not None else None
            return fixes(cfg, t_s[fix], expected.at(fix - ticks.start), errors)

        return (block(start) for start in range(0, max(t_s.size, 1), chunk_ticks))
