"""A recorded trial replayed through the live twin as if it arrived live, faster than real time: what
``boat-twin follow TRIAL`` runs. The samples of the trial's grid go to :class:`~boat_twin.shadow.session.Shadow`
in time order (commands when they change and at least every second, as a helm publishes them; sensors where
the trial has them, the heading wrapped as an IMU gives it: gaps stay gaps), and the twin's state is read every
simulated minute."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.io.samples import trial_samples
from boat_twin.io.trial import Trial
from boat_twin.shadow.session import Shadow, ShadowSettings

TIMELINE_PERIOD_S = 60.0
"""One timeline entry per this much trial time, s."""


@dataclass
class FollowResult:
    """What following a trial produced: the ``--json`` contract and the traces the plots draw."""

    timeline: list[dict[str, Any]]
    final: dict[str, Any]
    log: list[str]
    twin: TwinConfig
    """The twin as it predicts at the end (adapted vessel, environment with a named current or wind)."""
    speed_innovations: np.ndarray
    """(n, 3) t_s, speed innovation m/s, its stated spread m/s."""
    models: list[dict[str, Any]] = field(default_factory=list)
    """Per timeline entry: t_s, the current surge model and its latest fit (with intervals), the turning
    coefficients (:meth:`~boat_twin.shadow.turning.TurningAdapter.to_dict`)."""
    diagnoses: list[dict[str, Any]] = field(default_factory=list)
    """Every rolling diagnosis run (RollingResult.to_dict)."""

    def to_dict(self) -> dict[str, Any]:
        """The contract: ``timeline``, ``final``, plus ``log`` and ``diagnoses``."""
        return {"timeline": self.timeline, "final": self.final, "diagnoses": self.diagnoses, "log": self.log}


def follow_trial(trial: Trial, config: TwinConfig, settings: ShadowSettings | None = None,
                 progress: Callable[[str], None] | None = None) -> FollowResult:
    """Feed ``trial`` to a live twin of ``config`` (see the module docstring)."""
    log: list[str] = []
    shadow = Shadow(config, settings, log.append)
    speed: list[tuple[float, float, float]] = []
    shadow.on_innovation = lambda n: speed.append((n.t_s, n.value, n.stdev)) if n.channel == "speed_mps" else None
    timeline: list[dict[str, Any]] = []
    models: list[dict[str, Any]] = []
    diagnoses: list[dict[str, Any]] = []
    seen_runs = 0
    next_entry = TIMELINE_PERIOD_S
    end_s = float(trial.t_s[-1]) if trial.t_s.size else 0.0
    for kind, t, values in trial_samples(trial):
        shadow.add(kind, t, values)
        if shadow.rolling.runs != seen_runs and shadow.rolling.latest is not None:
            seen_runs = shadow.rolling.runs
            diagnoses.append(shadow.rolling.latest.to_dict())
        if t >= next_entry:
            timeline.append(_entry(shadow))
            models.append({"t_s": t, "surge": shadow.adapter.current.to_dict(),
                           "latest_fit": shadow.adapter.candidate.to_dict() if shadow.adapter.candidate else None,
                           "turning": shadow.turning.to_dict(shadow.twin.config.vessel)})
            next_entry += TIMELINE_PERIOD_S
            if progress is not None:
                progress(f"follow: {t:.0f} of {end_s:.0f} s")
    shadow.flush()
    final = {**_entry(shadow), "model": shadow.model(), "twin": _twin_summary(shadow)}
    if not timeline:
        timeline.append(_entry(shadow))
    return FollowResult(timeline, final, log, shadow.twin_config(), np.array(speed).reshape(-1, 3), models, diagnoses)


def _entry(shadow: Shadow) -> dict[str, Any]:
    status = shadow.status()
    return {"t_s": status["t_s"], "speed_innovation_ratio": status["speed_innovation_ratio"],
            "yaw_rate_innovation_ratio": status["yaw_rate_innovation_ratio"], "mass_kg": status["mass_kg"],
            "resistance_factor": status["resistance_factor"],
            "causes": status["causes"], "unexplained": status["unexplained"]}


def _twin_summary(shadow: Shadow) -> dict[str, Any]:
    config = shadow.twin_config()
    return {"mass_kg": config.vessel.mass_kg,
            "current_mps": [config.environment.current_east_mps, config.environment.current_north_mps]}
