"""RLS, the steady-state detector and the online identifier against batch on closed-form trials (Fc = k·v)."""

import math

import numpy as np
import pytest

from boat_twin.errors import InputError
from boat_twin.ident.dynamic import DynamicWindow, identify_dynamic
from boat_twin.ident.online import (
    OnlineThrustSpeedIdentifier,
    RecursiveLeastSquares,
    SteadyCriteria,
    analyse_segment,
    detect_steady_segments,
)
from boat_twin.ident.steady import fit_power_series

MASS_KG = 1365.0
DAMPING_NSPM = 120.0  # Fc = k·v, N/(m/s): time constant m/k ≈ 11 s


def linear_trial(levels, hold_s: float, noise: float, seed: int = 0, rate_hz: float = 10.0):
    """Exact samples of m·dv/dt = F − k·v under held thrust levels, speed plus Gaussian noise."""
    rng = np.random.default_rng(seed)
    t, f, v = [], [], []
    u0, t0 = 0.0, 0.0
    for level in levels:
        tt = np.arange(round(hold_s * rate_hz)) / rate_hz
        target = level / DAMPING_NSPM
        t.append(t0 + tt)
        f.append(np.full(tt.size, float(level)))
        v.append(target + (u0 - target) * np.exp(-DAMPING_NSPM * tt / MASS_KG))
        u0 = target + (u0 - target) * math.exp(-DAMPING_NSPM * hold_s / MASS_KG)
        t0 += hold_s
    v = np.concatenate(v)
    return np.concatenate(t), np.concatenate(f), v + rng.normal(0.0, noise, v.size)


def test_rls_equals_least_squares_and_weighted_least_squares() -> None:
    rng = np.random.default_rng(0)
    x = rng.normal(size=(200, 4))
    y = x @ np.array([1.0, -2.0, 0.5, 3.0]) + rng.normal(0.0, 0.1, 200)
    for lam in (1.0, 0.98):
        rls = RecursiveLeastSquares(4, forgetting=lam, initial_covariance=1e8)
        for xi, yi in zip(x, y, strict=True):
            rls.update(xi, yi)
        w = np.sqrt(lam ** np.arange(199, -1, -1))
        ref, *_ = np.linalg.lstsq(x * w[:, None], y * w, rcond=None)
        np.testing.assert_allclose(rls.theta, ref, rtol=1e-6)
    rls = RecursiveLeastSquares(4, initial_covariance=1e8)
    for xi, yi in zip(x, y, strict=True):
        rls.update(xi, yi)
    ref, res, *_ = np.linalg.lstsq(x, y, rcond=None)
    assert rls.noise_variance == pytest.approx(res[0] / 196, rel=1e-4)
    np.testing.assert_allclose(rls.covariance, res[0] / 196 * np.linalg.inv(x.T @ x), rtol=1e-3)
    with pytest.raises(InputError, match="forgetting factor"):
        RecursiveLeastSquares(2, forgetting=1.5)


def test_rls_covariance_does_not_wind_up_without_excitation() -> None:
    rls = RecursiveLeastSquares(2, forgetting=0.9, initial_covariance=1e3)
    for _ in range(5000):
        rls.update(np.array([1.0, 0.0]), 2.0)
    assert np.trace(rls.p_matrix) <= 2e3 * (1 + 1e-12) and rls.theta[0] == pytest.approx(2.0)


def _segment(speed: np.ndarray, rate_hz: float = 10.0):
    t = np.arange(speed.size) / rate_hz
    return analyse_segment(t, speed, np.full(t.size, 500.0), SteadyCriteria())


def test_detector_verdicts() -> None:
    rng = np.random.default_rng(5)
    noise = rng.normal(0.0, 0.05, 900)
    settled = _segment(4.0 + noise)
    assert settled.accepted and settled.duration_s == pytest.approx(89.9)
    assert settled.speed_mps == pytest.approx(4.0, abs=4 * 0.05 / math.sqrt(900))
    t = np.arange(900) / 10.0
    creeping = _segment(3.0 + 1.5 * (1 - np.exp(-t / 200.0)) + noise)  # τ = 200 s: far from settled
    assert not creeping.accepted and creeping.reason.startswith("speed never settled")
    wavy = _segment(4.0 + 0.5 * np.sin(2 * np.pi * t / 8.0) + noise)
    assert not wavy.accepted and wavy.reason.startswith("speed unsteady: spread")
    short = _segment(4.0 + noise[:150])
    assert not short.accepted and "shorter than the 20 s test window" in short.reason
    gap_t = np.r_[t[:600], t[600:] + 100.0]  # a 100 s gap: only the 30 s after it may be used
    after_gap = analyse_segment(gap_t, 4.0 + noise, np.full(900, 500.0), SteadyCriteria())
    assert after_gap.accepted and after_gap.duration_s <= 30.0


def test_detector_splits_on_thrust_changes_and_rejects_unsettled_levels() -> None:
    t, f, v = linear_trial([240.0, 480.0, 720.0, 600.0], [80.0, 80.0, 25.0, 80.0][0], 0.05)
    segs = detect_steady_segments(t, f, v)
    assert [round(s.thrust_N) for s in segs] == [240, 480, 720, 600]
    for seg in segs:
        assert seg.accepted
        assert seg.speed_mps == pytest.approx(seg.thrust_N / DAMPING_NSPM, rel=0.01)
    t, f, v = linear_trial([240.0, 480.0], 25.0, 0.05)  # 25 s holds: 2.2 time constants
    assert [s.accepted for s in detect_steady_segments(t, f, v)] == [False, False]


@pytest.fixture(scope="module")
def trial():
    return linear_trial([200.0, 500.0, 800.0, 350.0, 650.0, 100.0, 900.0, 450.0], 90.0, 0.05, seed=2)


def test_online_equals_batch_without_forgetting(trial) -> None:
    t, f, v = trial
    window = DynamicWindow()
    online = OnlineThrustSpeedIdentifier(2, 1, memory_s=1e15, through_origin=False, window=window)
    for sample in zip(t.tolist(), f.tolist(), v.tolist(), strict=True):
        online.update(*sample)
    online.finish()
    points = [s for s in detect_steady_segments(t, f, v) if s.accepted]
    assert [s.speed_mps for s in online.steady_points] == [s.speed_mps for s in points]
    batch = fit_power_series([s.speed_mps for s in points], [s.thrust_N for s in points], 2)
    coef, stderr = online.resistance()
    np.testing.assert_allclose(coef, batch.coefficients, rtol=1e-6, atol=1e-4)
    np.testing.assert_allclose(stderr, batch.stderr, rtol=1e-2)
    dyn = identify_dynamic(t, f, v, 1, window)
    snap = online.snapshot()["dynamic"]
    assert snap["n_windows"] == dyn.n_windows
    assert snap["mass_kg"] == pytest.approx(dyn.mass_kg, rel=1e-7)
    np.testing.assert_allclose(snap["coefficients"], dyn.coefficients, rtol=1e-6, atol=1e-6)
    assert snap["mass_stderr_kg"] == pytest.approx(dyn.mass_stderr_kg, rel=1e-3)


def test_dynamic_identification_recovers_mass_and_damping(trial) -> None:
    t, f, _ = trial
    clean = linear_trial([200.0, 500.0, 800.0, 350.0, 650.0, 100.0, 900.0, 450.0], 90.0, 0.0, seed=2)[2]
    dyn = identify_dynamic(t, f, clean, 1)
    assert dyn.mass_kg == pytest.approx(MASS_KG, rel=1e-3)
    np.testing.assert_allclose(dyn.coefficients, [0.0, DAMPING_NSPM], atol=0.05 * DAMPING_NSPM)
    noisy = identify_dynamic(*trial, order=1)
    assert noisy.mass_ci95_kg[0] < MASS_KG < noisy.mass_ci95_kg[1]
    assert noisy.two_way_fraction > 0.8  # steps up and down cover the speed range both ways


def test_online_ignores_bad_samples_and_waits_for_data() -> None:
    online = OnlineThrustSpeedIdentifier(3)
    assert online.update(0.0, 100.0, 1.0) is None
    online.update(0.1, math.nan, 1.0)
    online.update(0.1, 100.0, 1.0)
    online.update(0.1, 100.0, 1.0)  # not later than the previous sample
    online.update(0.05, 100.0, 1.0)
    snap = online.snapshot()
    assert snap["n_samples"] == 2 and snap["n_ignored_samples"] == 3
    assert snap["coefficients"] is None and snap["dynamic"] is None
    with pytest.raises(InputError, match="orders must be integers from 1 to 12"):
        OnlineThrustSpeedIdentifier(0)


def test_seconds_one_ulp_apart_give_the_same_windows_and_the_same_model() -> None:
    """A live node's stamps in seconds since the epoch, from sec + nanosec·1e-9 or from ns·1e-9, differ by an ulp
    (0.24 µs at 1.8e9 s) on some samples; windows and segments must not move with it."""
    t, f, v = linear_trial((300.0, 700.0, 1150.0, 500.0), 90.0, 0.02, seed=4)
    stamps_ns = 1_795_000_000_000_000_000 + np.rint(t * 1e9).astype(np.int64)
    as_ns = stamps_ns * 1e-9
    as_sec = (stamps_ns // 1_000_000_000) + (stamps_ns % 1_000_000_000) * 1e-9
    assert np.any(as_ns != as_sec)  # the two conversions really differ somewhere
    fits = []
    up = np.random.default_rng(1).random(t.size) < 0.5
    jittered = np.where(up, np.nextafter(as_ns, np.inf), np.nextafter(as_ns, -np.inf))  # ±1 ulp at random
    for seconds in (as_ns, as_sec, jittered):
        ident = OnlineThrustSpeedIdentifier(2)
        for row in zip(seconds.tolist(), f.tolist(), v.tolist(), strict=True):
            ident.update(*row)
        ident.finish()
        fits.append((len(ident.steady_points), ident.resistance()[0], ident.dynamic()["mass_kg"]))
    for count, coef, mass in fits[1:]:
        assert count == fits[0][0]
        np.testing.assert_allclose(coef, fits[0][1], rtol=1e-6)
        assert mass == pytest.approx(fits[0][2], rel=1e-6)


def test_a_negative_mass_is_refused_as_physically_impossible(monkeypatch) -> None:
    """A transient fit that lands on a negative mass (seen on a recording whose GNSS stamps ran backwards) is
    refused with the reason; the model (the output-error fit) does not take its mass from there."""
    from dataclasses import replace

    import boat_twin.ident.pipeline as pipeline

    t, f, v = linear_trial((300.0, 700.0, 1150.0, 500.0), 90.0, 0.01, seed=2)
    real = pipeline.identify_dynamic
    monkeypatch.setattr(pipeline, "identify_dynamic", lambda *a: replace(real(*a), mass_kg=-860.0))
    result = pipeline.identify_arrays(t, f, v, order=1)
    assert "-860 kg: physically impossible" in result["dynamic"]["error"]
    assert result["model"]["effective_mass_kg"] == result["output_error"]["selected"]["mass_kg"] > 0.0
    assert len(result["steady_points"]) == 4
