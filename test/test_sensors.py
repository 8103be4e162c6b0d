"""GNSS and UM7 sensor models: exact without noise, stated statistics with noise, validated configs."""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np
import pymap3d
import pytest

from boat_twin.config import TwinConfig
from boat_twin.errors import InputError
from boat_twin.io.messages import TOPICS, TS, Message
from boat_twin.sensors import GaussMarkov, gauss_markov
from boat_twin.sensors.gnss import GnssConfig, GnssModel, GnssNoise
from boat_twin.sensors.um7 import WMM2020_VLADIVOSTOK_ENU_TESLA, Um7Config, Um7Model, Um7Noise
from boat_twin.twin.live import LiveTwin
from boat_twin.twin.sea_trial import compact_trial_messages, run_compact_trial, run_sea_trial, trial_messages
from boat_twin.units import STANDARD_GRAVITY_MPS2
from boat_twin.vessel.scenarios import make_scenario
from boat_twin.vessel.truth import TruthSeries

DT_S = 0.1


def turning_truth(n: int, speed_mps: float = 5.0, yaw_rate_radps: float = 0.05) -> TruthSeries:
    """A boat on a circle at 10 Hz, speeding up slightly: every field non-trivial and mutually consistent."""
    t_s = np.arange(n) * DT_S
    yaw = 0.3 + yaw_rate_radps * t_s
    speed = speed_mps + 0.01 * t_s
    radius = speed / yaw_rate_radps
    return TruthSeries(
        t_s=t_s, east_m=radius * np.sin(yaw), north_m=-radius * np.cos(yaw), yaw_rad=yaw,
        vel_east_mps=speed * np.cos(yaw), vel_north_mps=speed * np.sin(yaw), surge_mps=speed,
        sway_mps=np.zeros(n), yaw_rate_radps=np.full(n, yaw_rate_radps), accel_x_mps2=np.full(n, 0.01),
        accel_y_mps2=speed * yaw_rate_radps,
    )


def resting_truth(n: int, yaw_rad: float = 0.0) -> TruthSeries:
    zeros = np.zeros(n)
    return TruthSeries(np.arange(n) * DT_S, zeros, zeros, np.full(n, yaw_rad), zeros, zeros, zeros, zeros,
                       zeros, zeros, zeros)


def local_enu(cfg: GnssConfig, fixes) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return pymap3d.geodetic2enu(fixes.lat_deg, fixes.lon_deg, fixes.alt_m, cfg.origin_lat_deg,
                                cfg.origin_lon_deg, cfg.origin_alt_m)


def assert_stdev(samples: np.ndarray, stdev: float, mean: float = 0.0) -> None:
    """Sample mean and stdev within 3 standard errors of the estimators (normal samples)."""
    n = samples.size
    assert abs(samples.mean() - mean) < 3.0 * stdev / math.sqrt(n)
    assert abs(samples.std(ddof=1) - stdev) < 3.0 * stdev / math.sqrt(2.0 * (n - 1))


# ---------------------------------------------------------------- GNSS


def test_gnss_without_noise_is_truth_and_round_trips_through_geodetic() -> None:
    truth = turning_truth(3000)
    cfg = GnssConfig(latency_s=0.0)
    fixes = GnssModel(cfg, np.random.default_rng(0), noise=False).measure(truth)
    np.testing.assert_array_equal(fixes.stamp_s, truth.t_s)
    east, north, up = local_enu(cfg, fixes)
    np.testing.assert_allclose(east, truth.east_m, atol=1e-3)
    np.testing.assert_allclose(north, truth.north_m, atol=1e-3)
    np.testing.assert_allclose(up, cfg.antenna_height_m, atol=1e-3)
    np.testing.assert_array_equal(fixes.vel_east_mps, truth.vel_east_mps)
    np.testing.assert_array_equal(fixes.vel_north_mps, truth.vel_north_mps)
    np.testing.assert_array_equal(fixes.vel_up_mps, 0.0)
    assert abs(fixes.lat_deg[0] - 43.07) < 0.01 and abs(fixes.lon_deg[0] - 131.90) < 0.02  # Vladivostok


def test_gnss_latency_delivers_the_past_state() -> None:
    truth = turning_truth(500)
    fixes = GnssModel(GnssConfig(latency_s=0.3), np.random.default_rng(0), noise=False).measure(truth)
    np.testing.assert_allclose(fixes.stamp_s, truth.t_s[3:], atol=1e-12)  # no state before the start
    np.testing.assert_allclose(fixes.vel_east_mps, truth.vel_east_mps[:-3], atol=1e-12)
    half = GnssModel(GnssConfig(latency_s=0.05), np.random.default_rng(0), noise=False).measure(truth)
    midpoint = 0.5 * (truth.vel_north_mps[:-1] + truth.vel_north_mps[1:])  # linear between two samples
    np.testing.assert_allclose(half.vel_north_mps, midpoint, atol=1e-12)


def test_gnss_rate_decimates_and_rejects_rates_that_do_not_divide() -> None:
    truth = turning_truth(1000)
    fixes = GnssModel(GnssConfig(rate_hz=2.0, latency_s=0.0), np.random.default_rng(0)).measure(truth)
    np.testing.assert_allclose(fixes.stamp_s, truth.t_s[::5])
    for rate_hz in (3.0, 20.0):
        with pytest.raises(InputError, match="gnss.rate_hz"):
            GnssModel(GnssConfig(rate_hz=rate_hz), np.random.default_rng(0)).measure(truth)


def test_gnss_noise_statistics_and_covariance() -> None:
    truth = turning_truth(20000)
    cfg = GnssConfig(latency_s=0.0)
    fixes = GnssModel(cfg, np.random.default_rng(1)).measure(truth)
    east, north, up = local_enu(cfg, fixes)
    assert_stdev(east - truth.east_m, cfg.horizontal_stdev_m)
    assert_stdev(north - truth.north_m, cfg.horizontal_stdev_m)
    assert_stdev(up, cfg.vertical_stdev_m, mean=cfg.antenna_height_m)
    assert_stdev(fixes.vel_east_mps - truth.vel_east_mps, cfg.velocity_stdev_mps)
    assert_stdev(fixes.vel_up_mps, cfg.velocity_stdev_mps)
    assert cfg.horizontal_stdev_m == pytest.approx(2.5 / 1.1774, rel=1e-4)  # 2.5 m CEP
    expected = [cfg.horizontal_stdev_m**2, cfg.horizontal_stdev_m**2, cfg.vertical_stdev_m**2]
    np.testing.assert_allclose(fixes.position_covariance_m2, np.tile(expected, (len(fixes), 1)))


def test_gnss_dropouts_remove_the_stated_fraction() -> None:
    truth = turning_truth(20000)
    p = 0.2
    cfg = GnssConfig(dropout_probability=p, latency_s=0.0)
    fixes = GnssModel(cfg, np.random.default_rng(2)).measure(truth)
    lost = 1.0 - len(fixes) / len(truth)
    assert abs(lost - p) < 3.0 * math.sqrt(p * (1.0 - p) / len(truth))
    assert np.all(np.diff(fixes.stamp_s) > 0.0)
    assert np.isin(np.round(fixes.stamp_s / DT_S), np.arange(len(truth))).all()


def test_gauss_markov_continues_from_its_state() -> None:
    """Run in pieces (down to single steps), the process is the one run at once: the state carries over."""
    stdev = np.array([1.0, 3.0])
    whole = GaussMarkov(np.random.default_rng(8), 2, stdev, DT_S, 2.0).run(50)
    process = GaussMarkov(np.random.default_rng(8), 2, stdev, DT_S, 2.0)
    pieces = np.concatenate([process.run(k) for k in (1, 1, 17, 0, 30, 1)])
    np.testing.assert_allclose(pieces, whole, rtol=1e-12, atol=0.0)


def test_gauss_markov_is_stationary_with_the_stated_correlation() -> None:
    tau_s, stdev = 1.0, 2.0
    noise = gauss_markov(np.random.default_rng(3), 200, 4000, stdev, DT_S, tau_s)
    per_time_stdev = noise.std(axis=1)
    assert np.all(np.abs(per_time_stdev - stdev) < 4.0 * stdev / math.sqrt(2.0 * noise.shape[1]))
    lag1 = np.mean(noise[1:] * noise[:-1]) / np.mean(noise**2)
    assert lag1 == pytest.approx(math.exp(-DT_S / tau_s), abs=0.01)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("rate_hz", 0.0), ("rate_hz", -10.0), ("horizontal_stdev_m", -1.0), ("vertical_stdev_m", math.nan),
        ("velocity_stdev_mps", -0.1), ("latency_s", -0.1), ("latency_s", math.inf),
        ("dropout_probability", 1.0), ("dropout_probability", -0.1), ("antenna_height_m", -1.0),
        ("origin_lat_deg", 91.0),
        ("origin_lon_deg", math.nan), ("position_correlation_time_s", -1.0), ("origin_alt_m", "high"),
    ],
)
def test_gnss_config_rejects_bad_values_naming_the_field(field: str, value: object) -> None:
    with pytest.raises(InputError, match=f"^gnss.{field}: "):
        GnssConfig(**{field: value})


def test_gnss_config_from_dict() -> None:
    assert GnssConfig.from_dict({"rate_hz": 5, "latency_s": 0}).rate_hz == 5.0
    with pytest.raises(InputError, match="^gnss.rate: unknown field"):
        GnssConfig.from_dict({"rate": 5})
    with pytest.raises(InputError, match="^gnss: expected a mapping"):
        GnssConfig.from_dict([1, 2])


# ---------------------------------------------------------------- UM7


def test_um7_at_rest_reads_plus_g_on_z_and_the_local_field() -> None:
    yaw = math.radians(30.0)
    imu = Um7Model(Um7Config(), np.random.default_rng(0), noise=False).measure(resting_truth(10, yaw))
    np.testing.assert_array_equal(imu.accel_mps2, np.tile([0.0, 0.0, STANDARD_GRAVITY_MPS2], (10, 1)))
    np.testing.assert_array_equal(imu.gyro_radps, 0.0)
    b_east, b_north, b_up = WMM2020_VLADIVOSTOK_ENU_TESLA
    cos_yaw, sin_yaw = math.cos(yaw), math.sin(yaw)
    body = [cos_yaw * b_east + sin_yaw * b_north, -sin_yaw * b_east + cos_yaw * b_north, b_up]
    np.testing.assert_allclose(imu.mag_tesla, np.tile(body, (10, 1)), rtol=0, atol=1e-15)
    yaw_quaternion = [0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)]
    np.testing.assert_allclose(imu.quaternion_xyzw, np.tile(yaw_quaternion, (10, 1)))
    # imu/rpy as the driver lays it out (ENU mode): (NED pitch, NED roll, -NED yaw), radians
    np.testing.assert_allclose(imu.rpy_rad, np.tile([0.0, 0.0, yaw - math.pi / 2], (10, 1)), atol=1e-15)
    declination = math.degrees(math.atan2(b_east, b_north))
    inclination = math.degrees(math.atan2(-b_up, math.hypot(b_east, b_north)))
    assert declination == pytest.approx(-10.57, abs=0.01) and inclination == pytest.approx(59.69, abs=0.01)


def test_um7_without_noise_is_truth_plus_the_constant_bias() -> None:
    truth = turning_truth(2000, yaw_rate_radps=0.2)
    bias = (0.01, -0.02, 0.003)
    imu = Um7Model(Um7Config(gyro_bias_radps=bias), np.random.default_rng(0), noise=False).measure(truth)
    np.testing.assert_array_equal(imu.stamp_s, truth.t_s)
    np.testing.assert_allclose(imu.gyro_radps - bias, np.column_stack([0 * truth.t_s, 0 * truth.t_s,
                                                                         truth.yaw_rate_radps]), atol=1e-15)
    np.testing.assert_array_equal(imu.accel_mps2[:, 1], truth.accel_y_mps2)
    np.testing.assert_array_equal(imu.yaw_rad, truth.yaw_rad)
    x, y, z, w = imu.quaternion_xyzw.T
    yaw_from_q = np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    np.testing.assert_allclose(np.angle(np.exp(1j * (yaw_from_q - truth.yaw_rad))), 0.0, atol=1e-12)
    assert np.all(imu.rpy_rad[:, 2] >= -math.pi) and np.all(imu.rpy_rad[:, 2] < math.pi)


def test_um7_noise_statistics_bias_and_covariances() -> None:
    truth = turning_truth(20000)
    cfg = Um7Config(gyro_bias_radps=(0.01, -0.02, 0.003))
    imu = Um7Model(cfg, np.random.default_rng(4)).measure(truth)
    for axis, expected in enumerate([0.0, 0.0, 0.05]):
        assert_stdev(imu.gyro_radps[:, axis] - expected, cfg.gyro_stdev_radps, mean=cfg.gyro_bias_radps[axis])
    assert_stdev(imu.accel_mps2[:, 2], cfg.accel_stdev_mps2, mean=STANDARD_GRAVITY_MPS2)
    assert_stdev(imu.accel_mps2[:, 0] - truth.accel_x_mps2, cfg.accel_stdev_mps2)
    assert_stdev(imu.mag_tesla[:, 2], cfg.mag_stdev_tesla, mean=cfg.magnetic_field_enu_tesla[2])
    assert_stdev(imu.yaw_rad - truth.yaw_rad, cfg.yaw_stdev_rad)
    assert_stdev(imu.rpy_rad[:, 1], cfg.roll_pitch_stdev_rad)  # NED roll = roll
    np.testing.assert_allclose(np.linalg.norm(imu.quaternion_xyzw, axis=1), 1.0, atol=1e-12)
    assert np.all(imu.quaternion_xyzw[:, 3] >= 0.0)
    np.testing.assert_allclose(imu.orientation_covariance_rad2, np.radians([3.0, 3.0, 3.0]) ** 2)
    np.testing.assert_allclose(imu.gyro_covariance_radps2, np.radians(0.06) ** 2)
    np.testing.assert_allclose(imu.accel_covariance_mps2_2, (0.004 * STANDARD_GRAVITY_MPS2) ** 2)
    np.testing.assert_allclose(imu.mag_covariance_tesla2, cfg.mag_stdev_tesla**2)


def test_um7_gyro_bias_random_walk_has_the_stated_increments() -> None:
    walk = 0.001
    cfg = Um7Config(gyro_stdev_radps=0.0, gyro_bias_walk_radps_per_sqrt_s=walk)
    imu = Um7Model(cfg, np.random.default_rng(5)).measure(resting_truth(20000))
    assert imu.gyro_radps[0, 0] == 0.0
    assert_stdev(np.diff(imu.gyro_radps[:, 0]), walk * math.sqrt(DT_S))


def test_um7_rate_decimates() -> None:
    truth = resting_truth(100)
    imu = Um7Model(Um7Config(rate_hz=5.0), np.random.default_rng(0)).measure(truth)
    np.testing.assert_array_equal(imu.stamp_s, truth.t_s[::2])
    with pytest.raises(InputError, match="um7.rate_hz"):
        Um7Model(Um7Config(rate_hz=4.0), np.random.default_rng(0)).measure(truth)


def test_sensor_models_are_reproducible_from_the_seed() -> None:
    truth = turning_truth(200)
    a = Um7Model(Um7Config(), np.random.default_rng(7)).measure(truth)
    b = Um7Model(Um7Config(), np.random.default_rng(7)).measure(truth)
    np.testing.assert_array_equal(a.quaternion_xyzw, b.quaternion_xyzw)
    g1 = GnssModel(GnssConfig(dropout_probability=0.1), np.random.default_rng(7)).measure(truth)
    g2 = GnssModel(GnssConfig(dropout_probability=0.1), np.random.default_rng(7)).measure(truth)
    np.testing.assert_array_equal(g1.lat_deg, g2.lat_deg)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("rate_hz", 0.0), ("gyro_stdev_radps", -1e-3), ("accel_stdev_mps2", math.nan),
        ("yaw_stdev_rad", -0.1), ("roll_pitch_stdev_rad", math.inf), ("mag_stdev_tesla", -1e-7),
        ("gyro_bias_walk_radps_per_sqrt_s", -1.0),
        ("orientation_correlation_time_s", -2.0), ("temperature_celsius", math.nan),
        ("gyro_bias_radps", (0.0, 0.0)), ("gyro_bias_radps", "0 0 0"),
        ("magnetic_field_enu_tesla", (0.0, math.nan, 0.0)), ("gyro_stdev_radps", True),
    ],
)
def test_um7_config_rejects_bad_values_naming_the_field(field: str, value: object) -> None:
    with pytest.raises(InputError, match=f"^um7.{field}"):
        Um7Config(**{field: value})


def test_um7_config_from_dict() -> None:
    cfg = Um7Config.from_dict({"gyro_bias_radps": [0, 0, 0.01], "temperature_celsius": 30})
    assert cfg.gyro_bias_radps == (0.0, 0.0, 0.01) and cfg.temperature_celsius == 30.0
    with pytest.raises(InputError, match="^um7.gyro_noise: unknown field"):
        Um7Config.from_dict({"gyro_noise": 1.0})


# ---------------------------------------------------------------- live (tick by tick) vs batch noise


def variogram(errors: np.ndarray, lag: int) -> float:
    """Mean of (e[k + lag] - e[k])^2 over k and columns of ``errors`` (n, columns)."""
    return float(np.mean((errors[lag:] - errors[:-lag]) ** 2))


def test_live_noise_has_the_batch_statistics_correlated_noise_included() -> None:
    """A resting boat, 600 s: the GNSS Gauss-Markov position error (tau 30 s) and the gyro bias random walk
    keep their state across LiveTwin ticks, as in a batch record. Both are checked against theory at lags of
    0.1, 1 and 10 s: the normalised variogram of the position error is 2 (1 - a^lag), a = exp(-dt/tau); that of
    the gyro is 2 sigma_white^2 + walk^2 lag dt. Tolerances: > 4 standard deviations of the ratio over 40
    batch seeds (1 %, 2.6 %, 8.8 % at 0.1, 1, 10 s). A twin that restarts the processes every tick reads
    white position noise (ratio ~300 at 0.1 s) and a bounded gyro bias (ratio ~0.2 at 10 s)."""
    n = 6000
    gnss = GnssConfig(position_correlation_time_s=30.0)
    um7 = Um7Config(gyro_bias_walk_radps_per_sqrt_s=2e-3)
    live = LiveTwin(TwinConfig(gnss=gnss, um7=um7), seed=11)
    fixes, gyro = [], []
    for _ in range(n):
        for topic, _, msg in live.tick():
            if topic == "gnss/fix":
                fixes.append((msg.latitude, msg.longitude, msg.altitude))
            elif topic == "imu/data":
                gyro.append((msg.angular_velocity.x, msg.angular_velocity.y, msg.angular_velocity.z))
    np.testing.assert_array_equal(live.state, 0.0)  # at rest: the truth is the origin, not moving
    lat, lon, alt = np.array(fixes).T
    live_enu = np.column_stack(pymap3d.geodetic2enu(lat, lon, alt, gnss.origin_lat_deg, gnss.origin_lon_deg,
                                                    gnss.origin_alt_m))
    rng = np.random.default_rng(11)
    batch_fixes = GnssModel(gnss, rng).measure(resting_truth(n))
    batch_gyro = Um7Model(um7, rng).measure(resting_truth(n)).gyro_radps
    batch_enu = np.column_stack(local_enu(gnss, batch_fixes))
    stdev = np.array([gnss.horizontal_stdev_m, gnss.horizontal_stdev_m, gnss.vertical_stdev_m])
    a = math.exp(-DT_S / gnss.position_correlation_time_s)
    for lag, tolerance in ((1, 0.05), (10, 0.12), (100, 0.4)):
        gm = 2.0 * (1.0 - a**lag)
        walk = 2.0 * um7.gyro_stdev_radps**2 + um7.gyro_bias_walk_radps_per_sqrt_s**2 * lag * DT_S
        for enu, rates in ((live_enu, np.array(gyro)), (batch_enu, batch_gyro)):
            errors = (enu - [0.0, 0.0, gnss.antenna_height_m]) / stdev
            assert variogram(errors, lag) / gm == pytest.approx(1.0, abs=tolerance), lag
            assert variogram(rates, lag) / walk == pytest.approx(1.0, abs=tolerance), lag


@pytest.mark.parametrize("pieces", [(1, 999, 500, 4500), (6000,), (0, 3, 5997)])
def test_noise_for_a_record_read_in_chunks_draws_what_one_run_draws(pieces: tuple[int, ...]) -> None:
    """GnssNoise/Um7Noise.for_record: chunked runs equal one run bit for bit and leave the RNG where it does."""
    n = sum(pieces)
    gnss_cfg = GnssConfig(dropout_probability=0.1)
    um7_cfg = Um7Config()
    whole_rng = np.random.default_rng(21)
    whole = (GnssNoise(gnss_cfg, whole_rng).run(n), Um7Noise(um7_cfg, whole_rng).run(n))
    chunked_rng = np.random.default_rng(21)
    gnss_noise = GnssNoise.for_record(gnss_cfg, chunked_rng, n)
    um7_noise = Um7Noise.for_record(um7_cfg, chunked_rng, n)
    gnss_parts = [gnss_noise.run(k) for k in pieces]
    um7_parts = [um7_noise.run(k) for k in pieces]
    for field in ("position_m", "velocity_mps", "received"):
        assert np.array_equal(np.concatenate([getattr(p, field) for p in gnss_parts]), getattr(whole[0], field))
    for field in ("attitude_rad", "gyro_radps", "accel_mps2", "mag_tesla"):
        assert np.array_equal(np.concatenate([getattr(p, field) for p in um7_parts]), getattr(whole[1], field))
    assert chunked_rng.random() == whole_rng.random()


@pytest.mark.parametrize("chunk_s", [7.3, 0.3, 1000.0])
def test_compact_trial_messages_equal_the_whole_trials(chunk_s: float) -> None:
    """The streamed (chunked) sea trial writes the messages of the whole-record one, byte for byte: GNSS with
    dropouts, a latency that is not a whole number of ticks, a 5 Hz receiver."""
    cfg = TwinConfig(gnss=GnssConfig(dropout_probability=0.05, latency_s=0.23, rate_hz=5.0))
    scenario = make_scenario("random", cfg.vessel, np.random.default_rng(1), 120.0)

    def serialized(stream: Iterable[Message]) -> list[tuple[str, int, bytes]]:
        return [(topic, stamp, bytes(TS.serialize_cdr(msg, TOPICS[topic]))) for topic, stamp, msg in stream]

    whole = serialized(trial_messages(run_sea_trial(cfg, scenario, 3)))
    streamed = serialized(compact_trial_messages(run_compact_trial(cfg, scenario, 3), chunk_s=chunk_s))
    assert len(whole) > 5_000
    assert streamed == whole
