"""The 42 zigzag features of Pashentsev (2025) (boat_twin/ident/zigzag_features.py)."""

from __future__ import annotations

import math
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from boat_twin.config import TwinConfig
from boat_twin.errors import InputError
from boat_twin.ident.manoeuvring_trials import recorded
from boat_twin.ident.zigzag_features import (
    EVENTS,
    FEATURE_NAMES,
    ZigzagRecord,
    ensemble_features,
    measured_ensemble_features,
    trial_features,
    zigzag_features,
)
from boat_twin.twin.sea_trial import run_sea_trial
from boat_twin.vessel.manoeuvres import zigzag_figures
from boat_twin.vessel.params import derive_coefficients
from boat_twin.vessel.scenarios import Zigzag
from boat_twin.vessel.simulate import OUTPUT_RATE_HZ, simulate

AMPLITUDE = math.radians(30.0)
PERIOD_S = 24.0
SWITCH = math.radians(20.0)
HEADING0 = 3.0  # rad: the heading wraps through ±π during the zigzag
OMEGA = 2.0 * math.pi / PERIOD_S


def hand_made(duration_s: float = 60.0) -> tuple[ZigzagRecord, float]:
    """A heading oscillating as 30°·sin(ωτ) from the execute (τ = 0), a helm reversing ±20° at the first sample
    past ±20°, straight-line positions and a linear speed; sampled at 10 Hz off the events' instants."""
    t = 0.037 + np.arange(0.0, duration_s, 0.1)
    t_exec = float(t[np.searchsorted(t, 10.0)])
    tau = np.clip(t - t_exec, 0.0, None)
    deviation = AMPLITUDE * np.sin(OMEGA * tau)  # steering sense: to starboard
    steering = np.zeros_like(t)
    side = 1.0
    for i in np.flatnonzero(t >= t_exec):
        steering[i] = side * SWITCH
        if side * deviation[i] >= SWITCH:
            side = -side  # the helm reverses from the next sample on
    heading = np.angle(np.exp(1j * (HEADING0 - deviation)))  # ENU yaw, wrapped
    yaw_rate = -AMPLITUDE * OMEGA * np.cos(OMEGA * tau) * (t >= t_exec)
    record = ZigzagRecord(t, 100.0 + 5.0 * t, -50.0 + 2.0 * t, heading, 6.0 - 0.01 * t, yaw_rate, steering,
                          source="hand-made")
    return record, t_exec


def test_hand_made_record_gives_the_known_events() -> None:
    record, t_exec = hand_made()
    features = zigzag_features(record)
    assert features.shape == (6, 7) and len(FEATURE_NAMES) == 42
    rise = math.asin(SWITCH / AMPLITUDE) / OMEGA  # τ where the deviation first reaches 20°
    half = PERIOD_S / 2.0
    expected_t = [rise, PERIOD_S / 4, half + rise, 3 * PERIOD_S / 4, PERIOD_S + rise, 5 * PERIOD_S / 4]
    expected_dev = [SWITCH, AMPLITUDE, -SWITCH, -AMPLITUDE, SWITCH, AMPLITUDE]
    expected_steer = [SWITCH, -SWITCH, -SWITCH, SWITCH, SWITCH, -SWITCH]
    np.testing.assert_allclose(features[:, 0], expected_t, atol=5e-3)
    np.testing.assert_allclose(features[:, 4], expected_dev, atol=1e-4)
    np.testing.assert_allclose(features[:, 5], expected_steer, atol=0)
    # Position from the execute, along (x) and to port of (y) the initial heading; speed and yaw rate at the time.
    t_abs = t_exec + np.array(expected_t)
    shift = np.stack([5.0 * (t_abs - t_exec), 2.0 * (t_abs - t_exec)], axis=1)
    ahead = np.array([math.cos(HEADING0), math.sin(HEADING0)])
    port = np.array([-math.sin(HEADING0), math.cos(HEADING0)])
    np.testing.assert_allclose(features[:, 1], shift @ ahead, atol=0.03)
    np.testing.assert_allclose(features[:, 2], shift @ port, atol=0.03)
    np.testing.assert_allclose(features[:, 3], 6.0 - 0.01 * t_abs, atol=1e-4)
    expected_rate = -AMPLITUDE * OMEGA * np.cos(OMEGA * np.array(expected_t))
    np.testing.assert_allclose(features[:, 6], expected_rate, atol=2e-4)
    assert np.all(np.abs(features[1::2, 6]) < 2e-4)  # the heading stands still at its extremes


def test_port_first_zigzag_mirrors_the_features() -> None:
    record, _ = hand_made()
    mirror = ZigzagRecord(record.t_s, record.east_m, record.north_m, 2 * HEADING0 - record.heading_rad,
                          record.speed_mps, -record.yaw_rate_radps, -record.steering_rad)
    a, b = zigzag_features(record), zigzag_features(mirror)  # the same (straight) track, mirrored heading
    np.testing.assert_allclose(b[:, :4], a[:, :4], atol=1e-9)
    np.testing.assert_allclose(b[:, 4:], -a[:, 4:], atol=1e-9)


def test_a_record_too_short_or_without_steering_is_refused_by_name() -> None:
    record, _ = hand_made(duration_s=38.0)  # the third extreme comes at τ = 30 s, 40 s into the record
    with pytest.raises(InputError, match="hand-made: the record ends before zigzag extreme 3 of 3"):
        zigzag_features(record)
    still = ZigzagRecord(*(getattr(record, f) for f in ("t_s", "east_m", "north_m", "heading_rad", "speed_mps",
                                                        "yaw_rate_radps")), np.zeros_like(record.t_s))
    with pytest.raises(InputError, match="no steering command"):
        zigzag_features(still)


def test_simulated_and_measured_zigzag_features_agree_with_the_imo_figures() -> None:
    config = TwinConfig()
    angle = math.radians(20.0)
    zigzag = Zigzag(config.vessel, angle, angle, speed_mps=6.0, duration_s=60.0, decision_rate_hz=OUTPUT_RATE_HZ)
    record = simulate(config.vessel, zigzag, n_boats=2)
    truth = ensemble_features(record)
    np.testing.assert_array_equal(truth[0], truth[1])
    events = truth[0].reshape(6, 7)
    t = record.truth(0)
    figures = zigzag_figures(t.t_s, t.east_m, t.north_m, t.yaw_rad, np.hypot(t.surge_mps, t.sway_mps),
                             zigzag.approach_s, angle, angle, config.vessel.length_m)
    assert math.degrees(events[1, 4] - angle) == pytest.approx(figures.first_overshoot_deg, abs=1e-6)
    assert events[0, 0] == pytest.approx(figures.initial_turning_time_s, abs=1e-6)
    with tempfile.TemporaryDirectory() as tmp:
        measured = trial_features(recorded(run_sea_trial(config, zigzag, 3), "zigzag", Path(tmp)))
    # The training-set path (sensors on an ensemble's truth, no bag) gives the bag's features for the same noise.
    sensed = measured_ensemble_features(record, config, np.array([3, 4]))
    np.testing.assert_allclose(sensed[0], measured.ravel(), rtol=0, atol=1e-6)
    assert np.abs(sensed[1] - sensed[0]).max() > 0.1  # each boat its own noise
    # Default sensor noise: event times within 0.05 s, deviations within 0.2°, positions within GNSS noise.
    np.testing.assert_allclose(measured[:, 0], events[:, 0], atol=0.05)
    np.testing.assert_allclose(measured[:, 4], events[:, 4], atol=math.radians(0.2))
    np.testing.assert_allclose(measured[:, 1:3], events[:, 1:3], atol=8.0)
    np.testing.assert_allclose(measured[:, 6], events[:, 6], atol=0.01)


def test_actual_rudder_leaves_no_feature_constant_where_the_command_left_nine() -> None:
    """Pashentsev (2025) records the rudder's position (the steering actuator), not the order. Over an ensemble
    of boats with their coefficients and steering offsets varied (the training sets'), every one of the 42
    features varies with the actual angle; with the commanded angle the rudder at every event and the deviation
    at the equalities are the constants ±20° (9 features). At an equality the deviation equals the actual rudder
    angle; where the offset brings the rudder's target inside ±20° (before the helm reverses at ±20°), the rudder
    stands settled there at the command plus the offset."""
    config = TwinConfig()
    rng = np.random.default_rng(5)
    base = config.vessel
    coeff = derive_coefficients(base)
    boats, offsets = [], rng.normal(0.0, math.radians(0.5), 16)
    for offset in offsets:
        scale = 1.0 + 0.1 * rng.standard_normal(3)
        manoeuvring = {"m22_kg": coeff.m22_kg * scale[0], "m33_kgm2": coeff.m33_kgm2 * scale[1],
                       "yaw_damping_Nms": coeff.yaw_damping_Nms * scale[2]}
        boats.append(replace(base, manoeuvring=manoeuvring, steering_offset_rad=float(offset)))
    angle = math.radians(20.0)
    zigzag = Zigzag(base, angle, angle, speed_mps=6.0, duration_s=75.0, decision_rate_hz=OUTPUT_RATE_HZ)
    record = simulate(base, zigzag, boats=boats)
    actual, commanded = ensemble_features(record), ensemble_features(record, actual_rudder=False)
    assert np.all(np.isfinite(actual)) and np.all(np.isfinite(commanded))

    def constant(x: np.ndarray) -> list[str]:
        return [FEATURE_NAMES[j] for j in np.flatnonzero(np.ptp(x, axis=0) <= 1e-9 * np.abs(x).max(axis=0))]

    assert constant(actual) == []
    assert sorted(constant(commanded)) == sorted(
        [f"{e}.rudder_rad" for e in EVENTS] + [f"equality_{k}.heading_deviation_rad" for k in (1, 2, 3)])
    events = actual.reshape(-1, 6, 7)
    for k, sign in zip((0, 2, 4), (1.0, -1.0, 1.0), strict=True):
        np.testing.assert_allclose(events[:, k, 4], events[:, k, 5], atol=1e-9)
        inside = sign * offsets < 0.0
        assert inside.sum() >= 4
        np.testing.assert_allclose(events[inside, k, 5], sign * angle + offsets[inside], atol=1e-9)
