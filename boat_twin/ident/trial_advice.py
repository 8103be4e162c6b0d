"""Which manoeuvre to record next: each candidate trial's effect on the turning coefficients' intervals, predicted
from the fit (optimal experiment design, linearized).

Two zigzags at one speed leave some coefficients wide: x_c·a_v·|u|·v and a_r·|u|·r move the yaw alike where the
drift v follows the yaw rate r, as it does at one speed (issue 38: x_c 0.12-0.16 m off with ±0.25 m intervals).
Each candidate — a 20°/20° or 10°/10° zigzag or a turning circle at the trials' speed or another one — is simulated
noise-free with the *fitted* boat, cut into the fit's windows and weighted by the noise the fit measured; the
Gauss-Newton information of its residuals at the solution, I_c = J_cᵀJ_c (:func:`~boat_twin.ident.manoeuvring.
window_information`), is added to the fit's I, and each coefficient's standard error is scaled by how much that
shrinks it: se'_k = se_k·√([(I + I_c)⁻¹]_kk / [I⁻¹]_kk) (se_k the window jackknife's, so its robustness to each
window's error is kept), its 95 % half-width with the t quantile of the degrees of freedom the windows would then
give (:func:`~boat_twin.ident.manoeuvring.interval_degrees_of_freedom`). The goals are
the issue's targets (:data:`PRECISION_GOALS`; x_c's scaled with the boat's length). The prediction is only as good
as the fit it starts from: a misfit or a coefficient far off makes it a guess, which the advice says.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.special import stdtrit

from boat_twin.config import TwinConfig
from boat_twin.ident.manoeuvring import (
    PARAMETERS,
    WINDOW_S,
    ManoeuvringFit,
    interval_degrees_of_freedom,
    prepare,
    window_information,
)
from boat_twin.io.trial import Trial
from boat_twin.twin.sea_trial import measured_trial
from boat_twin.vessel.params import top_speed_mps
from boat_twin.vessel.scenarios import Scenario, Zigzag, turning_circle
from boat_twin.vessel.simulate import OUTPUT_RATE_HZ, simulate

PRECISION_GOALS = {"m22_kg": 0.05, "m33_kgm2": 0.05, "sway_damping_Nspm2": 0.05, "yaw_damping_Nms": 0.05,
                   "sway_quadratic_Ns2pm2": 0.15, "yaw_quadratic_Nms2": 0.15,
                   "steering_offset_rad": math.radians(0.1)}
"""95 % half-width each coefficient should reach: relative for the positive ones (5 % for the inertias and lift
dampings, 15 % for the cross-flow drags), absolute for the steering offset (0.1°, rad); issue 38's targets."""
LATERAL_CENTRE_GOAL_PER_LENGTH = 1.0 / 60.0
"""x_c's goal as a fraction of the boat's length: 0.1 m on the 6 m boat (issue 38), m/m."""
SPEED_FACTORS = (0.6, 1.0, 1.4)
"""Candidate approach speeds over the trials' own (:func:`approach_speed_mps`), clipped to the boat's envelope."""
MIN_SPEED_MPS = 1.0
"""Slowest candidate approach speed, m/s: below it the lift terms (∝ |u|) hardly act."""
TOP_SPEED_SHARE = 0.9
"""Fastest candidate approach speed as a share of the boat's top speed (the zigzag needs thrust in hand)."""
CANDIDATE_S = 130.0
"""Length of each candidate trial, s: the CLI's zigzag (10 s approach, six 20 s windows)."""
MANOEUVRES = ("zigzag-20-20", "zigzag-10-10", "turning-circle")
"""Candidate manoeuvres (the names ``boat-twin simulate`` takes)."""


def goals(base: TwinConfig) -> dict[str, float]:
    """Coefficient key → the 95 % half-width it should reach (relative; x_c in m, the offset in rad)."""
    return {**PRECISION_GOALS, "lateral_centre_x_m": LATERAL_CENTRE_GOAL_PER_LENGTH * base.vessel.length_m}


def half_widths(fit: ManoeuvringFit, stderr: dict[str, float], dof: dict[str, float]) -> dict[str, float]:
    """Key → 95 % half-width of each goal coefficient with standard errors ``stderr`` (fitted coordinates) and
    t degrees of freedom ``dof``: relative (×/÷ factor − 1) for the positive ones, absolute for the signed; inf
    where the fit leaves it unbounded."""
    out = {}
    for p in PARAMETERS:  # every coefficient has a goal; the factors (surge, layout, windage) have none
        if p.key not in fit.fitted:
            continue
        quantile = float(stdtrit(dof[p.key], 0.975))
        if not math.isfinite(fit.ci95[p.key][1]):
            out[p.key] = math.inf
        elif p.logarithmic:
            out[p.key] = math.expm1(min(quantile * stderr[p.key], 700.0))
        else:
            out[p.key] = quantile * p.scale * stderr[p.key]
    return out


@dataclass(frozen=True)
class Candidate:
    """A manoeuvre to record and what it would leave of each goal coefficient's interval."""

    manoeuvre: str
    """A ``boat-twin simulate`` scenario name."""
    speed_mps: float
    """Approach speed, m/s."""
    half_width: dict[str, float]
    """Predicted 95 % half-width with this trial added (as :func:`half_widths`)."""
    met: int
    """Goal coefficients within their goal then."""

    def describe(self) -> str:
        """The manoeuvre and its approach speed, as the advice names it."""
        return f"{self.manoeuvre} at {self.speed_mps:.1f} m/s"


@dataclass(frozen=True)
class TrialAdvice:
    """The fit's goal coefficients against their goals and the candidate trials, best first."""

    goals: dict[str, float]
    half_width: dict[str, float]
    """95 % half-width of each goal coefficient now."""
    candidates: list[Candidate]
    trusted: bool
    """False when the fit is a misfit: its predictions rest on a model that lacks a cause."""

    @property
    def unmet(self) -> list[str]:
        """The goal coefficients wider than their goal now."""
        return [k for k, h in self.half_width.items() if not h <= self.goals[k]]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready (SI; half-widths as in :func:`half_widths`)."""
        return {"goals": dict(self.goals), "half_width": dict(self.half_width), "unmet": self.unmet,
                "trusted": self.trusted,
                "candidates": [{"manoeuvre": c.manoeuvre, "speed_mps": c.speed_mps, "half_width": c.half_width,
                                "goals_met": c.met} for c in self.candidates]}

    def summary(self) -> str:
        """One line: what is wide and which trial would narrow it most."""
        if not self.unmet:
            return "every coefficient within its goal (95 % half-widths: 5 % inertia and damping, x_c L/60)"
        best = self.candidates[0]
        shown = ", ".join(f"{k} {_shown(k, self.half_width[k])} → {_shown(k, best.half_width[k])}"
                          for k in self.unmet)
        still = [k for k in self.unmet if not best.half_width[k] <= self.goals[k]]
        return (f"these trials leave {', '.join(self.unmet)} wider than the goal; the trial that narrows them most: "
                f"{best.describe()} ({shown}, predicted"
                + (f"; still wide: {', '.join(still)}" if still else "") + ")"
                + ("" if self.trusted else " — a guess: the fit is a misfit"))


def _shown(key: str, half: float) -> str:
    """A half-width as the text output shows it: ±% for positive coefficients, ±m for x_c, ±° for the offset."""
    if not math.isfinite(half):
        return "unbounded"
    if key == "lateral_centre_x_m":
        return f"±{half:.2f} m"
    if key == "steering_offset_rad":
        return f"±{math.degrees(half):.2f}°"
    return f"±{100.0 * half:.1f} %"


def approach_speed_mps(trials: Sequence[Trial]) -> float:
    """The trials' approach speed, m/s: the median GNSS speed over ground before each trial's steering first
    moves (a zigzag slows as it turns), over a whole trial that steers from its start."""
    speeds = []
    for t in trials:
        speed = np.hypot(t.vel_east_mps, t.vel_north_mps)
        moved = np.flatnonzero(np.abs(t.angle_left_rad - t.angle_left_rad[0]) > 1e-6)
        before = speed[: int(moved[0])] if moved.size else speed
        speeds.append(before if np.isfinite(before).any() else speed)
    return float(np.nanmedian(np.concatenate(speeds)))


def candidate_scenario(config: TwinConfig, manoeuvre: str, speed_mps: float,
                       decision_rate_hz: float = OUTPUT_RATE_HZ) -> Scenario:
    """The :data:`MANOEUVRES` entry ``manoeuvre`` from ``speed_mps``, :data:`CANDIDATE_S` long; a zigzag's helm
    decides at ``decision_rate_hz`` (the log rate: its commands are exactly the logged ones; 0: at every
    integration step, as a helm on the water)."""
    if manoeuvre == "turning-circle":
        return turning_circle(config.vessel, speed_mps, turn_s=CANDIDATE_S - 10.0)
    angle = math.radians(float(manoeuvre.split("-")[1]))
    return Zigzag(config.vessel, angle, angle, speed_mps=speed_mps, duration_s=CANDIDATE_S, name=manoeuvre,
                  decision_rate_hz=decision_rate_hz)


def candidate_speeds_mps(config: TwinConfig, speed_mps: float) -> list[float]:
    """Approach speeds of the candidates for a boat whose trials ran at ``speed_mps``, m/s (0.1 m/s steps)."""
    top = TOP_SPEED_SHARE * top_speed_mps(config.vessel)
    return sorted({round(min(max(f * speed_mps, MIN_SPEED_MPS), top), 1) for f in SPEED_FACTORS})


def advise_next_trial(fit: ManoeuvringFit, base: TwinConfig, trials: Sequence[Trial],
                      window_s: float = WINDOW_S) -> TrialAdvice:
    """The candidate trials ranked by what they would leave of the goal coefficients' intervals (most goals met,
    then the smallest sum of squared half-width over goal); ``base`` the fit's prior, ``trials`` its trials."""
    target = {k: v for k, v in goals(base).items() if k in fit.fitted}
    now = half_widths(fit, fit.stderr, fit.degrees_of_freedom)
    information = fit.window_squares.sum(axis=0)
    inverse = np.linalg.pinv(information)
    config = fit.config
    candidates = []
    for speed, name in itertools.product(candidate_speeds_mps(config, approach_speed_mps(trials)), MANOEUVRES):
        record = simulate(config.vessel, candidate_scenario(config, name, speed), config.environment)
        trial = measured_trial(record, 0, config, np.random.default_rng(0), noise=False)
        data = prepare(trial, window_s, noise=fit.noise)
        squares = np.concatenate([fit.window_squares, window_information(fit, base, [data])])
        added = np.linalg.pinv(squares.sum(axis=0))
        ratio = np.sqrt(np.maximum(np.diag(added), 0.0) / np.where(np.diag(inverse) > 0.0, np.diag(inverse), np.inf))
        stderr = {key: fit.stderr[key] * float(r) for key, r in zip(fit.fitted, ratio, strict=True)}
        dof = dict(zip(fit.fitted, interval_degrees_of_freedom(squares).tolist(), strict=True))
        half = half_widths(fit, stderr, dof)
        half = {k: (math.inf if not math.isfinite(now[k]) else h) for k, h in half.items()}
        candidates.append(Candidate(name, speed, half, sum(half[k] <= g for k, g in target.items())))
    candidates.sort(key=lambda c: (-c.met, sum(min(c.half_width[k] / g, 1e6) ** 2 for k, g in target.items())))
    return TrialAdvice(target, now, candidates, trusted=not fit.misfit)
