"""A recorded trial replayed through the live twin as if it arrived live, faster than real time: what
``boat-twin follow TRIAL`` runs. The samples of the trial's grid go to :class:`~boat_twin.shadow.session.Shadow`
in time order (commands when they change and at least every second, as a helm publishes them; sensors where
the trial has them, the heading wrapped as an IMU gives it: gaps stay gaps), and the twin's state is read every
simulated minute."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.diagnose.pipeline import command_warnings
from boat_twin.io.samples import trial_samples
from boat_twin.io.trial import Trial
from boat_twin.rows import Rows
from boat_twin.shadow.session import RATIO_CHANNELS, Shadow, ShadowSettings
from boat_twin.shadow.sync import Innovation

TIMELINE_PERIOD_S = 60.0
"""One timeline entry per this much trial time, s."""


class FollowObserver(Protocol):
    """Watches a followed trial from outside the core (the Foxglove view, ``boat_twin.view``)."""

    def attach(self, shadow: Shadow) -> None:
        """The Shadow before its first sample."""

    def log_line(self, line: str) -> None:
        """Each line the Shadow logs."""

    def sample(self, kind: str, t_s: float, values: tuple[float, ...]) -> None:
        """After the Shadow took each sample."""

    def finish(self) -> None:
        """After the last sample was processed."""


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
    innovations: dict[str, np.ndarray] = field(default_factory=dict)
    """Channel (:data:`~boat_twin.shadow.session.RATIO_CHANNELS`: speed m/s, yaw rate rad/s) → (n, 3) t_s,
    innovation, its stated spread (the plots draw them)."""
    track: np.ndarray = field(default_factory=lambda: np.zeros((0, 5)))
    """(n, 5) t_s, measured east m, north m, and the twin's prediction of them, per GNSS fix (local ENU about the
    twin's first fix)."""
    warnings: list[str] = field(default_factory=list)
    """What the follow did not take from the trial as given: commands not to trust, what reading lost (signals
    missing, spans without samples, dropped samples: :meth:`~boat_twin.io.trial.TrialMetadata.warnings`), a
    model held at the end."""

    def to_dict(self) -> dict[str, Any]:
        """The contract: ``timeline``, ``final``, ``warnings``, plus ``log`` and ``diagnoses``."""
        return {"timeline": self.timeline, "final": self.final, "warnings": self.warnings,
                "diagnoses": self.diagnoses, "log": self.log}


def final_model_text(final: dict[str, Any]) -> str:
    """The surge model the follow ended with (``FollowResult.final``), with its 95 % intervals, in words."""
    surge = final["model"]["surge"]
    held = bool(surge.get("mass_held"))
    return (f"final model: mass {_interval_text(surge['mass_kg'], surge['mass_ci95_kg'], held, 0, ' kg')}, "
            f"resistance ×{_interval_text(surge['resistance_factor'], surge['resistance_factor_ci95'], False, 3)}")


def _interval_text(value: float, ci: list[float], held: bool, digits: int, unit: str = "") -> str:
    """``value unit [low, high]``; in words where the interval is NaN (a value not fitted, or held)."""
    if all(x is not None and math.isfinite(x) for x in ci):
        return f"{value:.{digits}f}{unit} [{ci[0]:.{digits}f}, {ci[1]:.{digits}f}]"
    why = "held: the data did not fix it, the value before is kept" if held else "configured, not fitted yet"
    return f"{value:.{digits}f}{unit} ({why}; no interval)"


def follow_trial(trial: Trial, config: TwinConfig, settings: ShadowSettings | None = None,
                 progress: Callable[[str], None] | None = None, observer: FollowObserver | None = None
                 ) -> FollowResult:
    """Feed ``trial`` to a live twin of ``config`` (see the module docstring); ``observer`` sees it happen."""
    log: list[str] = []

    def log_line(line: str) -> None:
        log.append(line)
        if observer is not None:
            observer.log_line(line)

    shadow = Shadow(config, settings, log_line)
    traces = {channel: Rows(3) for channel in RATIO_CHANNELS}
    east: dict[float, tuple[float, float]] = {}
    track = Rows(5)

    def trace(item: Innovation) -> None:
        if item.channel in traces:
            traces[item.channel].add((item.t_s, item.value, item.stdev))
        elif item.channel == "east_m":
            east.clear()
            east[item.t_s] = (item.measured, item.predicted)
        elif item.channel == "north_m" and item.t_s in east:
            (e_measured, e_predicted) = east[item.t_s]
            track.add((item.t_s, e_measured, item.measured, e_predicted, item.predicted))

    shadow.on_innovation = trace
    if observer is not None:
        observer.attach(shadow)
    timeline: list[dict[str, Any]] = []
    models: list[dict[str, Any]] = []
    diagnoses: list[dict[str, Any]] = []
    seen_runs = 0
    next_entry = TIMELINE_PERIOD_S
    end_s = float(trial.t_s[-1]) if trial.t_s.size else 0.0
    for kind, t, values in trial_samples(trial):
        shadow.add(kind, t, values)
        if observer is not None:
            observer.sample(kind, t, values)
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
    if observer is not None:
        observer.finish()
    final = {**_entry(shadow), "model": shadow.model(), "twin": _twin_summary(shadow)}
    if not timeline:
        timeline.append(_entry(shadow))
    innovations = {channel: rows.array() for channel, rows in traces.items()}
    return FollowResult(timeline, final, log, shadow.twin_config(), innovations["speed_mps"], models, diagnoses,
                        innovations, track.array(), follow_warnings(trial, config, shadow))


def follow_warnings(trial: Trial, config: TwinConfig, shadow: Shadow) -> list[str]:
    """:attr:`FollowResult.warnings` of ``trial`` followed by ``shadow`` from ``config``."""
    source = trial.metadata.source
    found = [f"{source}: {w}" for w in command_warnings(trial, config.vessel)] + trial.metadata.warnings()
    if shadow.model_held():
        found.append("the model was held at the end: the live diagnosis held `unexplained` or left structure "
                     "while the twin misfit, so no fit was adopted then (a cause the model lacks)")
    surge = shadow.adapter.current
    if surge.mass_held:
        found.append(f"the mass was held at {surge.mass_kg:.0f} kg at the end: the data since the last adopted fit "
                     "did not fix it (the resistance was fitted with it held; no interval on the mass)")
    if not shadow.twin.synchronised:
        found.append("the twin was not synchronised at the end: no fix, velocity and IMU heading together")
    return found


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
