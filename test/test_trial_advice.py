"""Which trial to record next (boat_twin.ident.trial_advice), and the runaway rule of the manoeuvring fit, on data
from the independent integrator of test/independent.py (another boat, not the twin's kernel)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import independent
import numpy as np
import pytest

from boat_twin.cli import main
from boat_twin.config import TwinConfig
from boat_twin.ident.manoeuvring import RUNAWAY_FACTOR, fit_manoeuvring
from boat_twin.ident.manoeuvring_trials import draw_boat, zigzag_set
from boat_twin.ident.trial_advice import advise_next_trial, candidate_scenario, half_widths
from boat_twin.io.trial import Trial
from boat_twin.vessel.params import VesselParams, derive_coefficients
from boat_twin.vessel.simulate import simulate

SPEED_MPS = 6.0


def _other_boat() -> tuple[VesselParams, dict[str, float]]:
    """A directionally stable boat whose turning coefficients are 10-25 % off the twin's, x_c −1.3 m, outboards
    that swing at once (the integrator has no actuator; no steering offset: it applies none)."""
    params = VesselParams(steering_rate_radps=0.0)
    derived = derive_coefficients(params)
    scale = {"m22_kg": 1.15, "m33_kgm2": 0.85, "sway_damping_Nspm2": 1.15, "yaw_damping_Nms": 1.1,
             "sway_quadratic_Ns2pm2": 1.25, "yaw_quadratic_Nms2": 0.9}
    truth = {k: getattr(derived, k) * f for k, f in scale.items()}
    truth.update(lateral_centre_x_m=-1.3, steering_offset_rad=0.0)
    manoeuvring = {k: truth[k] for k in scale}
    return VesselParams(steering_rate_radps=0.0, manoeuvring=manoeuvring, lateral_centre_x_m=-1.3,
                        steering_offset_rad=0.0), truth


def _held(t_s: np.ndarray, values: np.ndarray):
    """A command series as a function of time (each value held until the next)."""
    def at(t: float) -> float:
        return float(values[max(int(np.searchsorted(t_s, t + 1e-9, side="right")) - 1, 0)])
    return at


def _run(boat: VesselParams, thrust_N, steering_rad, seed: int, speed_mps: float = SPEED_MPS) -> Trial:
    return independent.boat_trial(boat, thrust_N, steering_rad, 130.0, np.random.default_rng(seed),
                                  initial_surge_mps=speed_mps, accel_stdev_mps2=0.04)


def _square_zigzag(angle_deg: float, half_period_s: float):
    """Open-loop zigzag helm: straight for 10 s, then ±``angle_deg`` alternating every ``half_period_s``."""
    angle = math.radians(angle_deg)
    return lambda t: 0.0 if t < 10.0 else (angle if int((t - 10.0) / half_period_s) % 2 == 0 else -angle)


@pytest.fixture(scope="module")
def two_zigzags() -> tuple[VesselParams, dict[str, float], list[Trial]]:
    boat, truth = _other_boat()
    thrust = 0.5 * float(boat.resistance.force_N(SPEED_MPS))
    trials = [_run(boat, lambda t: thrust, _square_zigzag(20.0, 7.0), 1),
              _run(boat, lambda t: thrust, _square_zigzag(10.0, 5.0), 2)]
    return boat, truth, trials


def test_the_advised_trial_narrows_what_two_zigzags_leave_wide_as_predicted(two_zigzags) -> None:
    boat, truth, trials = two_zigzags
    base = TwinConfig(vessel=VesselParams(steering_rate_radps=0.0))
    fit = fit_manoeuvring(trials, base)
    assert not fit.misfit, fit.residual_to_noise
    advice = advise_next_trial(fit, base, trials)
    # two zigzags at one speed: x_c's interval is wider than its goal (0.1 m on this 6 m boat)
    assert "lateral_centre_x_m" in advice.unmet, advice.half_width
    best = advice.candidates[0]
    assert best.met >= max(c.met for c in advice.candidates)
    assert best.half_width["lateral_centre_x_m"] < 0.7 * advice.half_width["lateral_centre_x_m"], best
    # The advised manoeuvre as a pre-programmed helm: its commands, from the fitted boat's simulation, replayed
    # open loop on the independent boat.
    scenario = candidate_scenario(fit.config, best.manoeuvre, best.speed_mps)
    record = simulate(fit.config.vessel, scenario, fit.config.environment)
    thrust = _held(record.t_s, record.commands[:, 0, 0])
    steering = _held(record.t_s, record.commands[:, 0, 2])
    extra = _run(boat, thrust, steering, 3, speed_mps=best.speed_mps)
    refit = fit_manoeuvring([*trials, extra], base)
    achieved = half_widths(refit, refit.stderr, refit.degrees_of_freedom)
    for key in ("lateral_centre_x_m", "yaw_damping_Nms"):
        assert 0.5 < best.half_width[key] / achieved[key] < 2.0, (key, best.half_width[key], achieved[key])
    assert achieved["lateral_centre_x_m"] < 0.7 * advice.half_width["lateral_centre_x_m"]
    x_c = refit.ci95["lateral_centre_x_m"]
    assert x_c[0] <= truth["lateral_centre_x_m"] <= x_c[1], x_c
    # This draw of the zigzags' noise (seeds 1, 2) leaves a_r +2.1 to +2.6 % and m33 −0.7 to −0.9 %, just outside
    # their ±1.8-2 % intervals once the third trial narrows them (its seeds 3-5; the other six hold the truth).
    # Not a bias of the fit on this boat: over four other draws of all three trials (zigzag seeds 100-107, third
    # trial 300-303, a scratch loop) every interval held, a_r within +0.5 to +1.4 %; noise-free, the replay with
    # the true coefficients follows this integrator's turning circles to 0.03× the gyro's noise.
    covered = sum(lo <= truth[k] <= hi for k, (lo, hi) in refit.ci95.items())
    assert covered >= len(refit.ci95) - 2, (refit.ci95, truth)
    assert abs(refit.values["yaw_damping_Nms"] / truth["yaw_damping_Nms"] - 1.0) < 0.03


HIDDEN = """vessel:
  lateral_centre_x_m: -0.8
  steering_offset_rad: 0.01
  manoeuvring: {m22_kg: 3000.0, m33_kgm2: 5000.0, sway_damping_Nspm2: 850.0, yaw_damping_Nms: 1000.0,
                sway_quadratic_Ns2pm2: 1800.0, yaw_quadratic_Nms2: 9000.0}
"""


def test_identify_manoeuvring_names_the_next_trial(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """The contract (docs/manoeuvring.md's example boat, two zigzags at one speed): the JSON's ``next_trial`` block
    and the text's ``next trial:`` line name the same best candidate."""
    hidden = tmp_path / "hidden.yaml"
    hidden.write_text(HIDDEN)
    bags = [tmp_path / name for name in ("zz20", "zz10")]
    for seed, (name, bag) in enumerate(zip(("zigzag-20-20", "zigzag-10-10"), bags, strict=True), start=1):
        assert main(["simulate", name, "--config", str(hidden), "--seed", str(seed), "--out", str(bag)]) == 0
    capsys.readouterr()
    assert main(["identify", *map(str, bags), "--manoeuvring", "--json"]) == 0
    block = json.loads(capsys.readouterr().out)["manoeuvring"]["next_trial"]
    assert set(block) == {"goals", "half_width", "unmet", "trusted", "candidates"} and block["trusted"]
    assert block["goals"]["lateral_centre_x_m"] == pytest.approx(0.1)  # L/60 of the 6 m boat
    best = block["candidates"][0]
    assert best["manoeuvre"] in ("zigzag-20-20", "zigzag-10-10", "turning-circle") and best["speed_mps"] > 0.0
    assert len(block["candidates"]) == 9 and best["goals_met"] == max(c["goals_met"] for c in block["candidates"])
    assert main(["identify", *map(str, bags), "--manoeuvring"]) == 0
    line = next(s for s in capsys.readouterr().out.splitlines() if s.startswith("next trial:"))
    if block["unmet"]:
        assert f"{best['manoeuvre']} at {best['speed_mps']:.1f} m/s" in line and block["unmet"][0] in line
    else:
        assert "every coefficient within its goal" in line


def test_a_coefficient_that_runs_off_is_not_identified_and_its_interval_is_unbounded() -> None:
    # Two 90 s zigzags at one speed in 10 s windows: the cross-flow sway drag (drift |v|·v) runs off to ~1e-24 of
    # its start (measured; its sensitivity vanishes with it, and the jackknife gave a zero-width interval).
    base = TwinConfig()
    true, truth = draw_boat(base, np.random.default_rng(502))
    trials = zigzag_set(true, 7020, both_sides=False, speeds_mps=(6.0,), duration_s=90.0)
    fit = fit_manoeuvring(trials, base, window_s=10.0)
    start = derive_coefficients(base.vessel)
    ran_off = [k for k in ("sway_quadratic_Ns2pm2", "yaw_quadratic_Nms2", "m22_kg", "m33_kgm2")
               if not 1.0 / RUNAWAY_FACTOR < fit.values[k] / getattr(start, k) < RUNAWAY_FACTOR]
    assert ran_off == ["sway_quadratic_Ns2pm2"], fit.values
    assert fit.ci95["sway_quadratic_Ns2pm2"] == (0.0, math.inf)
    assert "do not bound it" in fit.not_identified["sway_quadratic_Ns2pm2"]
    for key, (lo, hi) in fit.ci95.items():  # every other interval has a width
        assert key == "sway_quadratic_Ns2pm2" or hi > lo, (key, lo, hi)
    assert truth["sway_quadratic_Ns2pm2"] > 0.0
