"""The diagnosis catalogue run live: on the recent window of the stream, on a schedule, against the twin's
current (adapted) model; it names causes, their sizes and whether something stays unexplained.

A full diagnosis of a 2-minute window costs ~2-3 s of one core (:mod:`boat_twin.diagnose.search` fits every
catalogue effect with held-out folds; a live node runs it in a worker process), so it runs every ``period_s``
while the twin's speed innovations stay above ``misfit_ratio`` × their noise (something is wrong: find out what,
soon) or the last run had too little data, and every ``idle_period_s`` otherwise (a check that nothing crept
in). The window holds the last ``window_s`` of samples; the causes held are those of the latest run.

``unexplained`` needs more evidence live than one window gives: the catalogue's residual-structure test on a
130 s window flags most windows of a clean trial (velocity residuals 3-8× a noise floor measured on so few
samples: 11 of 12 runs of a clean hour). So a run's flag counts only while the twin's own innovations misfit
(speed or yaw rate above ``misfit_ratio`` × their stated spread over the last minute, the ratio the schedule
uses), and the live diagnosis says ``unexplained`` once :data:`UNEXPLAINED_RUNS` consecutive runs counted.

A run whose flag counts names nothing: the causes its catalogue would name are ``withheld`` (kept in the record
and logged, never held, never put into the twin). The window's own verdict is that structure remains after them,
and the twin's innovations say the misfit is real: a cause named there explains part of something outside the
catalogue, a partial relabel a user would act on. The rule is the offline diagnosis' own
(:func:`~boat_twin.diagnose.search.withheld`), the run passing the twin's misfit as its evidence that the misfit
is real (offline the evidence is a cause's own signals left above twice their noise; a 130 s window's noise floor
is too uncertain for that here). An actuator fault the catalogue lacks (the outboards losing up
to 30 % of their thrust when steered) had one window of ten name a thrust asymmetry of 0.15 that way (it removed
74 % of the velocity and yaw-rate misfit's excess, the rule's floor being 70 %, and left them 4.6× their noise);
a water current, once fully in the window, leaves no structure and is named as before (docs/live-twin.md).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.diagnose.pipeline import TrialDiagnosis, diagnose_trial
from boat_twin.errors import InputError
from boat_twin.io.roles import COMMAND_ROLES, MEASURED_INPUT_ROLES, SENSOR_ROLES
from boat_twin.io.trial import Stream, Trial, build_trial

WINDOW_S = 130.0
"""Recent data each run diagnoses, s: the diagnosis' minimum of 6 replay windows of 20 s, and a margin for a
sample missing at a window's start."""
PERIOD_S = 50.0
"""Time between runs while the twin misfits, s: a cause that starts is fully inside a window within
WINDOW_S + PERIOD_S = 3 minutes."""
IDLE_PERIOD_S = 300.0
"""Time between runs while the twin fits, s."""
MISFIT_RATIO = 1.5
"""Speed or yaw-rate innovations above this many times their stated spread make the schedule the busy one, and are
the twin's own evidence that something is wrong."""
UNEXPLAINED_RUNS = 2
"""Consecutive runs whose window leaves structure while the twin misfits, before the live diagnosis says
``unexplained``."""


@dataclass(frozen=True)
class Cause:
    """One cause the latest run named."""

    name: str
    parameters: dict[str, float]
    """Fitted parameters, SI, named with their units."""
    ci95: dict[str, list[float]]
    size: float
    """The effect's magnitude in ``size_unit``."""
    size_unit: str

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready."""
        return {"name": self.name, "parameters": self.parameters, "ci95": self.ci95, "size": self.size,
                "size_unit": self.size_unit}


@dataclass
class RollingResult:
    """The latest run: when, over which span, what it named."""

    t_s: float
    span_s: tuple[float, float]
    causes: list[Cause] = field(default_factory=list)
    withheld: list[Cause] = field(default_factory=list)
    """Causes the catalogue named in a window that left structure while the twin misfit: not held (module
    docstring)."""
    unexplained: bool = False
    """Structure left in :data:`UNEXPLAINED_RUNS` consecutive runs while the twin misfit (module docstring)."""
    structure_left: bool = False
    """This run's window alone left structure (the catalogue's own ``unexplained``)."""
    misfit: bool = False
    """The twin's innovations misfit when the run started."""
    error: str = ""
    """Why the run could not diagnose (too little data), else ''."""

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready."""
        return {"t_s": self.t_s, "span_s": list(self.span_s), "unexplained": self.unexplained,
                "structure_left": self.structure_left, "misfit": self.misfit, "error": self.error,
                "causes": [c.to_dict() for c in self.causes], "withheld": [c.to_dict() for c in self.withheld]}


class RecentStreams:
    """The accepted samples of the last ``keep_s`` seconds per stream (and, per command, the last value before
    them), as a :class:`~boat_twin.io.trial.Trial` on demand; a measured input (an anemometer's ``wind``) among
    them, which the diagnosis then takes as known (:func:`~boat_twin.diagnose.pipeline.diagnose_trial`)."""

    def __init__(self, keep_s: float) -> None:
        self.keep_s = keep_s
        self.clear()

    def clear(self) -> None:
        """Forget every sample."""
        self._rows: dict[str, deque[tuple[float, tuple[float, ...]]]] = {
            kind: deque() for kind in COMMAND_ROLES + SENSOR_ROLES + MEASURED_INPUT_ROLES}
        self.first_s = math.nan

    def add(self, kind: str, t_s: float, values: tuple[float, ...]) -> None:
        """One accepted sample (stamp order)."""
        rows = self._rows[kind]
        rows.append((t_s, values))
        keep_one = kind in COMMAND_ROLES
        while len(rows) > (2 if keep_one else 1) and rows[1 if keep_one else 0][0] < t_s - self.keep_s:
            rows.popleft()
        if math.isnan(self.first_s):
            self.first_s = t_s

    def trial(self, start_s: float, end_s: float) -> Trial:
        """The samples from ``start_s`` to ``end_s`` as a Trial (a command held from before starts with it);
        InputError when they cannot make one."""
        streams = {}
        for kind, rows in self._rows.items():
            picked = [r for r in rows if r[0] <= end_s and (r[0] >= start_s or kind in COMMAND_ROLES)]
            if kind in COMMAND_ROLES:  # only the last command before the start, moved to it
                before = [r for r in picked if r[0] < start_s][-1:]
                picked = [(start_s, r[1]) for r in before] + [r for r in picked if r[0] >= start_s]
            if picked:
                streams[kind] = Stream(np.array([r[0] for r in picked]),
                                       np.array([r[1] for r in picked], dtype=float))
        return build_trial(streams, f"live window {start_s:.0f}-{end_s:.0f} s", {k: f"live {k}" for k in streams})


class RollingDiagnosis:
    """Diagnoses the recent window of a :class:`RecentStreams` when due."""

    def __init__(self, streams: RecentStreams, *, window_s: float = WINDOW_S, period_s: float = PERIOD_S,
                 idle_period_s: float = IDLE_PERIOD_S, misfit_ratio: float = MISFIT_RATIO,
                 log: Callable[[str], None] | None = None) -> None:
        self.streams = streams
        self.window_s, self.period_s, self.idle_period_s = window_s, period_s, idle_period_s
        self.misfit_ratio = misfit_ratio
        self.log = log or (lambda _line: None)
        self.latest: RollingResult | None = None
        self.runs = 0
        self.restart()

    def restart(self) -> None:
        """A restarted stream: the next run waits for a full window."""
        self._last_run_s = -math.inf
        self._streak = 0

    def due(self, t_s: float, speed_ratio: float) -> bool:
        """True when a run is due at ``t_s`` given the twin's current speed-innovation ratio."""
        first = self.streams.first_s
        if math.isnan(first) or t_s - first < self.window_s:
            return False
        failed = self.latest is not None and bool(self.latest.error)  # too little data last time: try again soon
        busy = failed or (math.isfinite(speed_ratio) and speed_ratio > self.misfit_ratio)
        return t_s - self._last_run_s >= (self.period_s if busy else self.idle_period_s)

    def run(self, t_s: float, base: TwinConfig, misfit: bool = False) -> RollingResult:
        """Diagnose the buffered window against ``base`` (the twin's current model, environment as configured)
        now; :meth:`start` + :meth:`finish` split it for a worker thread."""
        job = self.start(t_s, base, misfit)
        return self.finish(job, job.compute())

    def start(self, t_s: float, base: TwinConfig, misfit: bool = False) -> DiagnosisJob:
        """Take the window's samples now (the caller's thread) for a diagnosis that may run elsewhere; ``misfit``:
        the twin's innovations misfit now."""
        self._last_run_s = t_s
        self.runs += 1
        start = t_s - self.window_s
        try:
            return DiagnosisJob(t_s, start, self.streams.trial(start, t_s), base, misfit=misfit)
        except InputError as err:
            return DiagnosisJob(t_s, start, None, base, str(err), misfit)

    def finish(self, job: DiagnosisJob, outcome: Outcome) -> RollingResult:
        """Record a job's outcome (causes and the unexplained flag, or why there is none) as the latest result;
        logged."""
        result = RollingResult(job.t_s, (job.start_s, job.t_s), misfit=job.misfit)
        if isinstance(outcome, str):
            result.error = outcome
            self.log(f"rolling diagnosis at {job.t_s:.0f} s: {outcome}")
        else:
            result.causes, result.withheld, result.structure_left = outcome
            counts = result.structure_left and job.misfit
            self._streak = self._streak + 1 if counts else 0
            result.unexplained = self._streak >= UNEXPLAINED_RUNS
            named = ", ".join(f"{c.name} ({c.size:.3g} {c.size_unit})" for c in result.causes) or "no cause"
            if result.withheld:
                named += " (withheld, the window leaving structure while the twin misfits: " + ", ".join(
                    f"{c.name} {c.size:.3g} {c.size_unit}" for c in result.withheld) + ")"
            note = ("; something stays unexplained" if result.unexplained
                    else "; structure left while the twin misfits" if self._streak
                    else "; structure left in the window, the twin's innovations at their noise"
                    if result.structure_left else "")
            self.log(f"rolling diagnosis of {job.start_s:.0f}-{job.t_s:.0f} s: {named}{note}")
        self.latest = result
        return result


Outcome = tuple[list[Cause], list[Cause], bool] | str
"""A run's causes, the causes it withheld and its unexplained flag, or why it could not diagnose."""


@dataclass
class DiagnosisJob:
    """One run's input, taken from the buffers: computable in another process (it shares nothing live, and it
    and its outcome pickle)."""

    t_s: float
    start_s: float
    trial: Trial | None
    base: TwinConfig
    error: str = ""
    misfit: bool = False
    """The twin's innovations misfit when the job was taken."""

    def compute(self) -> Outcome:
        """The named causes, those withheld and the unexplained flag, or why there are none. The twin's misfit
        is the evidence the diagnosis withholds causes by (:func:`~boat_twin.diagnose.search.withheld`)."""
        if self.trial is None:
            return self.error
        try:
            diagnosis = diagnose_trial(self.trial, self.base, misfit=self.misfit)
        except InputError as err:
            return str(err)
        return causes_of(diagnosis), causes_of(diagnosis, withheld=True), bool(diagnosis.result["unexplained"])


def causes_of(diagnosis: TrialDiagnosis, withheld: bool = False) -> list[Cause]:
    """The causes a diagnosis names (or, ``withheld``, those it withholds) with their sizes."""
    out = []
    entries = diagnosis.result["withheld"] if withheld else diagnosis.result["verdict"]
    for candidate in diagnosis.withheld if withheld else diagnosis.presented:
        effect = candidate.effect
        entry = next(v for v in entries if v["effect"] == effect.name)
        out.append(Cause(effect.name, dict(entry["parameters"]), dict(entry["ci95"]), float(candidate.size),
                         effect.spec.size_unit))
    return out
