"""The live twin's turning adaptation (boat_twin.shadow.turning): a boat that turns otherwise than the twin and
zigzags is followed, the twin adopts turning coefficients whose intervals hold the truth and its yaw-rate
innovations fall; a boat equal to the twin adopts nothing; a straight run costs no fit; a wrongly adopted model is
reverted. On the twin's own trials and on the independent integrator's (test/independent.py)."""

from __future__ import annotations

import math
from dataclasses import fields, replace

import numpy as np
import pymap3d
import pytest
from independent import boat_trial

from boat_twin.config import TwinConfig
from boat_twin.diagnose.hidden import scenario
from boat_twin.ident.manoeuvring import prediction_error, prepare
from boat_twin.io.trial import Trial
from boat_twin.shadow.follow import follow_trial
from boat_twin.shadow.session import Shadow, ShadowSettings
from boat_twin.shadow.turning import LIVE_KEYS, TurningAdapter, TurningModel, coefficients, steering_excitation
from boat_twin.twin.sea_trial import measured_trial, run_sea_trial
from boat_twin.vessel.params import VesselParams
from boat_twin.vessel.resistance import CorrectedResistance

NO_DIAGNOSIS = ShadowSettings(diagnose=False)


def _turning_otherwise(vessel: VesselParams, **factors: float) -> VesselParams:
    """``vessel`` with some turning coefficients (keys of LIVE_KEYS) scaled by ``factors``."""
    derived = coefficients(vessel)
    return replace(vessel, manoeuvring={k: derived[k] * f for k, f in factors.items()})


def _twin_trial(config: TwinConfig, kind: str, duration_s: float, seed: int) -> Trial:
    run = run_sea_trial(config, scenario(kind, TwinConfig().vessel, np.random.default_rng(seed), duration_s), seed)
    return measured_trial(run.record, 0, config, np.random.default_rng(seed + 100))


def _independent_zigzag(vessel: VesselParams, duration_s: float, seed: int) -> Trial:
    """The independent integrator's boat zigzagging: steering ±15° reversed every 8 s (open loop), each engine's
    thrust stepping between 300 and 800 N every 40 s (so that the live surge fit finds the mass, which the turning
    fit holds); positions as GNSS fixes."""
    data = boat_trial(vessel, lambda t: 300.0 + 500.0 * ((t // 40.0) % 2),
                      lambda t: math.radians(15.0) * (1.0 if (t // 8.0) % 2 else -1.0),
                      duration_s, np.random.default_rng(seed), initial_surge_mps=4.0)
    lat, lon, _ = pymap3d.enu2geodetic(data.east_m, data.north_m, 0.0, 43.0, 131.0, 0.0)
    return replace(data, lat_deg=lat, lon_deg=lon)


def _part(trial: Trial, start: int, stop: int) -> Trial:
    """Samples ``start`` to ``stop`` of ``trial``."""
    n = trial.t_s.size
    arrays = {f.name: getattr(trial, f.name) for f in fields(trial)}
    return replace(trial, **{k: v[start:stop] for k, v in arrays.items()
                             if isinstance(v, np.ndarray) and v.shape[:1] == (n,)})


def _yaw_ratios(timeline: list[dict]) -> list[float]:
    return [e["yaw_rate_innovation_ratio"] for e in timeline if e["yaw_rate_innovation_ratio"] is not None]


def _check_adopted(result, truth: VesselParams, trial: Trial, base: TwinConfig) -> None:  # noqa: ANN001
    turning = result.final["model"]["turning"]
    assert turning["fitted"] and any(line.startswith("adopted turning coefficients") for line in result.log)
    true = coefficients(truth)
    held = [k for k in LIVE_KEYS if turning["ci95"][k][0] <= true[k] <= turning["ci95"][k][1]]
    assert len(held) >= len(LIVE_KEYS) - 1, (turning["ci95"], true)
    for k in LIVE_KEYS:  # the ones determined within ±5 % are within 5 % of the truth
        if turning["ci95"][k][1] / turning["coefficients"][k] < 1.05:
            assert turning["coefficients"][k] == pytest.approx(true[k], rel=0.05), k
    # the yaw-rate innovations: the twin's filter keeps them near the gyro's noise (its gain is high), so the
    # model's error shows as a ratio above the true model's, which the adapted twin comes down to
    ratios = _yaw_ratios(result.timeline)
    right = _yaw_ratios(follow_trial(trial, replace(base, vessel=truth), ShadowSettings(adapt=False,
                                                                                        diagnose=False)).timeline)
    assert ratios[0] > 1.15 * right[0] and ratios[-1] < 1.05 * right[-1], (ratios, right)


def test_the_twin_adopts_the_turning_of_a_boat_that_turns_otherwise() -> None:
    """Yaw damping +25 %, yaw inertia −20 %: the twin's trial of random thrust and steering (8 minutes; on its
    constant-thrust zigzags the live surge fit's mass came out up to 12 % high before the fit read the surge along
    the heading, docs/live-twin.md, and the turning fit, which holds it, absorbed that)."""
    base = TwinConfig()
    truth = replace(base, vessel=_turning_otherwise(base.vessel, yaw_damping_Nms=1.25, m33_kgm2=0.8))
    trial = _twin_trial(truth, "random", 480.0, 3)
    result = follow_trial(trial, base, NO_DIAGNOSIS)
    _check_adopted(result, truth.vessel, trial, base)
    assert result.final["model"]["turning"]["swaps"] == 1


def test_the_twin_adopts_the_turning_of_an_independent_integrators_boat() -> None:
    """Yaw damping −25 %, sway damping +20 %, integrated apart from the twin (the integrator's outboards swing
    instantly: the given model says so)."""
    base = TwinConfig(vessel=VesselParams(steering_rate_radps=0.0))
    truth = _turning_otherwise(base.vessel, yaw_damping_Nms=0.75, sway_damping_Nspm2=1.2)
    trial = _independent_zigzag(truth, 480.0, 21)
    result = follow_trial(trial, base, NO_DIAGNOSIS)
    _check_adopted(result, truth, trial, base)


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["random", "zigzag"])
def test_a_boat_equal_to_the_twin_adopts_no_turning_coefficients(kind: str) -> None:
    """The configured boat for 15 minutes, two seeds: turning fits are made, none is adopted (no flapping)."""
    for seed in (5, 6):
        result = follow_trial(_twin_trial(TwinConfig(), kind, 900.0, seed), TwinConfig(), NO_DIAGNOSIS)
        turning = result.final["model"]["turning"]
        assert turning["fits"] >= 3 and turning["swaps"] == 0, [line for line in result.log if "turning" in line]


def test_a_straight_run_costs_no_turning_fit() -> None:
    config = TwinConfig()
    straight = boat_trial(config.vessel, lambda t: 600.0, lambda t: 0.0, 200.0, np.random.default_rng(2))
    ratio, reversals = steering_excitation(straight)
    assert ratio < 3.0 and reversals == 0
    zigzag = _twin_trial(config, "zigzag", 120.0, 4)
    ratio, reversals = steering_excitation(zigzag)
    assert ratio > 30.0 and reversals >= 4
    adapter = TurningAdapter(config.vessel)
    assert not adapter.update(straight, config, lambda _model: 1.0)
    assert adapter.fits == 0 and adapter.wait_s == 2.0 * adapter.period_s  # backs off


def test_a_wrongly_adopted_turning_model_is_reverted_when_the_data_show_the_previous_better() -> None:
    """The twin holds coefficients 25 % off (adopted earlier) while the boat turns as configured: the newest
    fit does not reject the configured ones and they predict the held-out tail better, so they come back."""
    config = TwinConfig()
    trial = _twin_trial(config, "zigzag", 400.0, 8)
    training, held_out = _part(trial, 0, 2700), prepare(_part(trial, 2700, trial.t_s.size))
    log: list[str] = []
    adapter = TurningAdapter(config.vessel, log=log.append)
    wrong = coefficients(_turning_otherwise(config.vessel, yaw_damping_Nms=1.25))
    adapter.current, adapter.previous = TurningModel(values=wrong), [TurningModel()]
    assert adapter.update(training, config, lambda model: prediction_error(held_out, model.config(config)))
    assert adapter.current == TurningModel() and not adapter.previous
    assert any(line.startswith("reverted turning coefficients to the configured boat's") for line in log), log


def test_the_turning_intervals_hold_the_truth_when_the_twins_surge_model_is_off() -> None:
    """The twin's surge model is off by more than its own intervals say (issue 25: a live surge fit's resistance
    curve ~1 % off, its interval ±0.2 %), here mass −3 % and resistance +2 %, on an independent integrator's boat
    yawing otherwise: held as exact (before issue 25's fix), that surge model moved m33 +3.1 % [+0.9, +5.3] %,
    a_r −6.8 %, m22 −2.6 %; the turning fit now scales the held surge model with the coefficients, finds the truth
    within its intervals (every error within 1 %) and the scale it needed."""
    base = TwinConfig(vessel=VesselParams(steering_rate_radps=0.0))
    truth = _turning_otherwise(base.vessel, yaw_damping_Nms=0.85, m33_kgm2=1.1)
    trial = _independent_zigzag(truth, 330.0, 22)
    training, held_out = _part(trial, 0, 2000), prepare(_part(trial, 2000, trial.t_s.size))
    plain = replace(base, vessel=replace(base.vessel, mass_kg=0.97 * base.vessel.mass_kg,
                                         resistance=CorrectedResistance.scaled(base.vessel.resistance, 1.02)))
    adapter = TurningAdapter(base.vessel)
    adapter.update(training, plain, lambda model: prediction_error(held_out, model.config(plain)))
    candidate, true = adapter.candidate, coefficients(truth)
    assert candidate is not None
    missed = {k: candidate.values[k] / true[k] for k in LIVE_KEYS
              if not candidate.ci95[k][0] <= true[k] <= candidate.ci95[k][1]}
    assert not missed, missed
    mass, low_mass, high_mass = candidate.surge_factors["surge_mass_factor"]
    factor, low, high = candidate.surge_factors["resistance_factor"]
    assert low_mass <= 1.0 / 0.97 <= high_mass and low <= 1.0 / 1.02 <= high, candidate.surge_factors
    reported = adapter.to_dict(plain.vessel)["latest_fit"]["surge_factors"]
    assert reported["resistance_factor"] == {"value": pytest.approx(factor), "ci95": [pytest.approx(low),
                                                                                      pytest.approx(high)]}



def test_the_surge_is_not_fitted_on_the_twins_sway_while_its_turning_is_known_wrong() -> None:
    """The boat's surge is the twin's, its yaw damping 25 % lower and its yaw inertia 16 % higher (study T's twin
    boat 3): until the turning adapts, the twin's sway, which the surge force's coupling m₂₂·v·r takes, is far off
    the boat's, and the surge fit took the difference for mass (1,455 kg [1,371, 1,539] adopted for 1,300 in the
    first 250 s). While the yaw rate misfits and no turning fit confirms the coefficients, those samples are set
    aside: no surge model is adopted, and it says so."""
    config = TwinConfig()
    truth = _turning_otherwise(config.vessel, yaw_damping_Nms=0.753, m33_kgm2=1.161)
    trial = _part(_twin_trial(replace(config, vessel=truth), "random", 900.0, 83), 0, 2500)
    result = follow_trial(trial, config, NO_DIAGNOSIS)
    assert not any(line.startswith("adopted surge model") for line in result.log), result.log
    assert any(line.startswith("surge samples set aside") for line in result.log)
    assert result.final["model"]["surge"]["mass_kg"] == config.vessel.mass_kg


def test_surge_samples_are_set_aside_only_while_the_turning_is_what_is_wrong() -> None:
    """The rule on its own: with the yaw rate misfitting, the surge samples are set aside before any turning fit
    and while the latest rejects the twin's coefficients with the surge model's scale holding 1; not when that
    fit finds the surge model off (the surge must adapt first: the turning is derived from it), nor when it
    confirms the coefficients, nor while the yaw rate fits its noise."""
    config = TwinConfig()
    shadow = Shadow(config, NO_DIAGNOSIS)
    shadow._squares["yaw_rate_radps"].append((0.0, 4.0, 1.0))  # the yaw-rate innovation ratio 2 (misfit: 1.5)
    assert shadow.sway_doubted()
    current = coefficients(config.vessel)
    wrong = {k: v * (0.75 if k == "yaw_damping_Nms" else 1.0) for k, v in current.items()}
    covariance = tuple(tuple(1e-4 if i == j else 0.0 for j in range(len(LIVE_KEYS))) for i in range(len(LIVE_KEYS)))
    surge_right = {"surge_mass_factor": (1.0, 0.99, 1.01), "resistance_factor": (1.002, 0.998, 1.006)}
    shadow.turning.fits = 1
    shadow.turning.candidate = TurningModel(values=wrong, covariance=covariance, windows=20, surge_factors=surge_right)
    assert shadow.sway_doubted()
    shadow.turning.candidate = TurningModel(values=wrong, covariance=covariance, windows=20, surge_factors={
        **surge_right, "resistance_factor": (0.73, 0.72, 0.74)})
    assert not shadow.sway_doubted()
    shadow.turning.candidate = TurningModel(values=current, covariance=covariance, windows=20,
                                            surge_factors=surge_right)
    assert not shadow.sway_doubted()
    shadow.turning.candidate = TurningModel(values=wrong, covariance=covariance, windows=20, surge_factors=surge_right)
    shadow._squares["yaw_rate_radps"].append((0.0, 0.0, 2.0))  # ratio 4 / 3 under 1.5
    assert not shadow.sway_doubted()


def test_the_surge_fits_coupling_prior_is_the_turning_models_uncertainty_of_m22_over_a_v() -> None:
    """The twin's sway in a turn scales with 1/a_v, its coupling m₂₂·v·r with m₂₂/a_v: the prior on the coupling's
    scale is that ratio's relative deviation from the latest turning fit (its variance plus the twin's distance
    from it) and the sway state's measured 5 %; without a fit, the configured a_v's drift-angle range (3-6° as a
    95 % interval: 0.177) and the state's."""
    config = TwinConfig()
    adapter = TurningAdapter(config.vessel)
    assert adapter.coupling_sd(config.vessel) == pytest.approx(math.hypot(math.log(2.0) / 3.92, 0.05))
    values = coefficients(config.vessel)
    cov = np.diag([0.02, 0.01, 0.03, 0.01, 0.05]) ** 2
    cov[0, 2] = cov[2, 0] = 0.5 * 0.02 * 0.03  # m22 and a_v correlated
    adapter.candidate = TurningModel(values=values, covariance=tuple(map(tuple, cov)), windows=20)
    ratio_variance = 0.02**2 + 0.03**2 - 0.02 * 0.03 + 0.05**2  # and the sway state's 5 %
    assert adapter.coupling_sd(config.vessel) == pytest.approx(math.sqrt(ratio_variance))
    off = _turning_otherwise(config.vessel, sway_damping_Nspm2=1.1)  # the twin 10 % from the fit in a_v
    assert adapter.coupling_sd(off) == pytest.approx(math.sqrt(ratio_variance + math.log(1.1) ** 2))
