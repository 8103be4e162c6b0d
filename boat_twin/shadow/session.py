"""The live twin of one boat: the synchronised twin, its online adaptation and the rolling diagnosis, fed one
sample at a time. The one core that the ``shadow`` node, ``boat-twin follow`` and the tests drive."""

from __future__ import annotations

import math
import multiprocessing
from collections import deque
from collections.abc import Callable
from concurrent.futures import Future, ProcessPoolExecutor
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from boat_twin.config import TwinConfig, save_config
from boat_twin.diagnose.defaults import WINDOW_S as REPLAY_WINDOW_S
from boat_twin.errors import InputError
from boat_twin.ident.manoeuvring import prediction_error, prepare
from boat_twin.io.roles import MEASURED_INPUT_ROLES
from boat_twin.io.trial import VALUE_LIMITS
from boat_twin.shadow.adapt import SurgeAdapter, SurgeModel
from boat_twin.shadow.rolling import (
    IDLE_PERIOD_S,
    MISFIT_RATIO,
    PERIOD_S,
    WINDOW_S,
    DiagnosisJob,
    Outcome,
    RecentStreams,
    RollingDiagnosis,
    RollingResult,
)
from boat_twin.shadow.sync import Innovation, ShadowTwin, SyncSettings
from boat_twin.shadow.turning import MIN_TRAINING_S, TurningAdapter, TurningModel, coefficients
from boat_twin.twin.replay import cut_windows, predict
from boat_twin.vessel.environment import Environment
from boat_twin.vessel.params import VesselParams

RATIO_WINDOW_S = 60.0
"""The speed-innovation ratio is the RMS over this last stretch of stream time, s."""
RATIO_CHANNELS = ("speed_mps", "yaw_rate_radps")
"""Innovation channels whose ratio to their stated spread the twin watches (speed over ground, yaw rate)."""
ENVIRONMENT_CAUSES = ("water_current", "wind")
"""Causes the twin takes into its predictions when named (the sea around the boat, not the boat)."""


class WindowSquares:
    """One channel's innovations over a sliding window, as (time s, squared innovation, its stated variance), with
    the two sums the innovation ratio divides kept running: O(1) per sample however many the window holds (summed
    again on every sample, a 60 s window cost ``follow`` 6 % of an hour's CPU). The sums are recomputed exactly once
    as many samples have left the window as it holds, so rounding never accumulates beyond one window's worth."""

    def __init__(self) -> None:
        self._items: deque[tuple[float, float, float]] = deque()
        self.square_sum = 0.0
        """Σ squared innovations in the window."""
        self.variance_sum = 0.0
        """Σ their stated variances."""
        self._left = 0

    def __len__(self) -> int:
        return len(self._items)

    def append(self, item: tuple[float, float, float]) -> None:
        """Add (time s, squared innovation, its variance) at the window's end."""
        self._items.append(item)
        self.square_sum += item[1]
        self.variance_sum += item[2]

    def drop_before(self, t_s: float) -> None:
        """Drop the samples older than ``t_s`` (s) from the window's start."""
        while self._items and self._items[0][0] < t_s:
            _, square, variance = self._items.popleft()
            self.square_sum -= square
            self.variance_sum -= variance
            self._left += 1
        if self._left >= len(self._items):
            self.square_sum = sum(s[1] for s in self._items)
            self.variance_sum = sum(s[2] for s in self._items)
            self._left = 0

    def clear(self) -> None:
        """Empty the window."""
        self._items.clear()
        self.square_sum = self.variance_sum = 0.0
        self._left = 0


@dataclass(frozen=True)
class ShadowSettings:
    """Everything a live twin is set up with besides its model (SI)."""

    sync: SyncSettings = field(default_factory=SyncSettings)
    adapt: bool = True
    """Adapt the model online (surge and turning, each as its own switch says)."""
    horizon_s: float = 600.0
    """Moving horizon of the adaptation, s."""
    holdout_s: float = 130.0
    """Its held-out tail, s: at least 6 replay windows of 20 s (the diagnosis' replay)."""
    adapt_period_s: float = 30.0
    """Time between adaptation attempts, s."""
    adapt_turning: bool = True
    """Re-identify the turning coefficients online when the boat steers (needs ``adapt``)."""
    turning_period_s: float = 60.0
    """Time between turning-adaptation attempts, s (doubling while fits confirm the coefficients)."""
    diagnose: bool = True
    """Run the rolling diagnosis."""
    diagnose_in_background: bool = False
    """Run it in a worker process (a live node: the samples keep coming meanwhile, and a thread would fight the
    executor for the GIL); False: in line, so a replay is deterministic."""
    diagnosis_window_s: float = WINDOW_S
    diagnosis_period_s: float = PERIOD_S
    diagnosis_idle_period_s: float = IDLE_PERIOD_S
    misfit_ratio: float = MISFIT_RATIO


class Shadow:
    """Feeds a :class:`ShadowTwin`; adapts its model and diagnoses it on the accepted samples.

    ``log`` receives every line worth logging (synchronisation, gaps, clock jumps, bad samples, model swaps,
    diagnoses). ``on_innovation`` (optional) sees every innovation as it is made.
    """

    def __init__(self, config: TwinConfig, settings: ShadowSettings | None = None,
                 log: Callable[[str], None] | None = None) -> None:
        self.base = config
        self.settings = settings or ShadowSettings()
        self.log = log or (lambda _line: None)
        self._worker: ProcessPoolExecutor | None = None
        self.on_innovation: Callable[[Innovation], None] | None = None
        """Sees every innovation as it is made (a plot's trace, a node's publisher)."""
        self._build()

    def _build(self) -> None:
        s, config = self.settings, self.base
        self.adapter = SurgeAdapter(config.vessel, horizon_s=s.horizon_s, holdout_s=s.holdout_s,
                                    period_s=s.adapt_period_s, latency_s=config.gnss.latency_s, log=self.log)
        self.turning = TurningAdapter(config.vessel, period_s=s.turning_period_s, log=self.log)
        turning_horizon_s = s.horizon_s if s.adapt and s.adapt_turning else 0.0
        self.recent = RecentStreams(max(s.diagnosis_window_s, s.holdout_s, turning_horizon_s) + 10.0)
        self.rolling = RollingDiagnosis(self.recent, window_s=s.diagnosis_window_s, period_s=s.diagnosis_period_s,
                                        idle_period_s=s.diagnosis_idle_period_s, misfit_ratio=s.misfit_ratio,
                                        log=self.log)
        self.twin = ShadowTwin(config, s.sync, self.log, self._accepted)
        self._squares = {c: WindowSquares() for c in RATIO_CHANNELS}
        self._restarts = 0
        self._last_impulse: tuple[int, float, float] | None = None
        self._held = False
        self._sway_doubted = False
        self._pending: tuple[DiagnosisJob, Future[Outcome]] | None = None

    # --- intake ------------------------------------------------------------------------------------------
    def add(self, kind: str, stamp_s: float, values: tuple[float, ...]) -> None:
        """One sample as it arrives (see :meth:`ShadowTwin.add`); a measured wind (``wind``: east, north m/s) goes
        to the rolling diagnosis' streams alone (:func:`measured_input`)."""
        if kind in MEASURED_INPUT_ROLES:
            if measured_input(kind, stamp_s, values):
                self.recent.add(kind, stamp_s, values)
            return
        self.twin.add(kind, stamp_s, values)
        if self.twin.counts["restarts"] != self._restarts:  # the stream restarted: its buffers go too
            self._restarts = self.twin.counts["restarts"]
            self.adapter.reset()
            self._last_impulse = None
            self.turning.reset()
            self.recent.clear()
            self.rolling.restart()
            for squares in self._squares.values():
                squares.clear()

    def flush(self) -> None:
        """Process what is still queued (end of a recording)."""
        self.twin.flush()

    def close(self) -> None:
        """Stop the background diagnosis worker process (a node shutting down)."""
        if self._worker is not None:
            self._worker.shutdown(wait=False, cancel_futures=True)

    def reset(self) -> None:
        """Start afresh from the configured model (the ``reset`` service)."""
        self._build()
        self.log("reset to the configured model")

    def _accepted(self, kind: str, t_s: float, values: tuple[float, ...]) -> None:
        """Every sample the twin accepted, in stamp order."""
        self._collect_innovations()
        self.recent.add(kind, t_s, values)
        if kind != "gnss_vel" or not self.twin.synchronised:
            return
        if self.settings.adapt:
            env = self.twin.config.environment
            yaw, sway, rate = self.twin.motion_at(t_s - self.twin.config.gnss.latency_s)  # when it was measured
            east, north = values[0] - env.current_east_mps, values[1] - env.current_north_mps
            # the surge itself, along the hull: the speed through the water |(u, v)| also holds the sway, which
            # swings with every turn, and on constant-thrust zigzags the fit took its missing speed loss for mass
            # (fits 1,352-1,382 kg, intervals missing the configured 1,300 kg; along the hull 1,259-1,335 kg)
            surge = east * math.cos(yaw) + north * math.sin(yaw)
            # the sway-yaw coupling m₂₂·v·r of the twin's state at that time; its scale is fitted, under a prior as
            # wide as the turning model's uncertainty of it (TurningAdapter.coupling_sd). The measured
            # sway (the GNSS velocity across the heading) was tried: it carries the heading's error (~0.1 m/s a fix
            # at 10 m/s) and the masses came out +0.4…+3.3 % high (docs/live-twin.md). That sway is only as good as
            # the twin's turning: while the turning is known wrong the sample is set aside (the force still read,
            # the next interval's mean starts here)
            force = self._interval_thrust_N(t_s)
            if not self.sway_doubted():
                self.adapter.add(t_s, force, surge, self.twin.m22_kg * sway * rate)
            if self.adapter.due(t_s) and not self.model_held() and self.adapter.update(
                    self._held_out_score(t_s), self.turning.coupling_sd(self.vessel())):
                self.twin.set_config(replace(self.twin.config, vessel=self.vessel()))
        if self.settings.adapt and self.settings.adapt_turning:
            first_s = self.recent.first_s + self.settings.holdout_s + MIN_TRAINING_S
            if self.turning.due(t_s, first_s) and not self.model_held() and self._update_turning(t_s):
                self.twin.set_config(replace(self.twin.config, vessel=self.vessel()))
        self._poll_diagnosis()
        if self.settings.diagnose and self._pending is None and self.rolling.due(t_s, self.misfit_ratio()):
            self._diagnose(t_s)

    def model_held(self) -> bool:
        """Whether the adaptation holds the model now: while the live diagnosis holds ``unexplained`` (a cause
        the catalogue lacks, seen on consecutive runs while the twin misfits) or its latest run left structure
        while the twin misfit (the first of those runs), no surge or turning model is adopted or reverted. A fit
        on data holding such a cause takes it into the coefficients it has: on the out-of-catalogue probe
        (outboards losing up to 30 % of their thrust when steered) the surge fit's resistance ×1.074 predicted the
        held-out data 11 % better and was adopted — the fault published and saved as a drag increase, the very
        relabelling the diagnosis refuses; a current switched on mid-trial, whose first window held the switch,
        had 1,328 kg ×1.004 adopted after that window, and the next two windows, against that model, were not
        explained (the current named 3.9 min after the switch instead of 2.3). Logged when the hold starts and
        ends."""
        latest = self.rolling.latest
        held = bool(latest is not None and (latest.unexplained or (latest.structure_left and latest.misfit)))
        if held != self._held:
            self._held = held
            self.log("model adaptation held: the live diagnosis holds `unexplained` or left structure while the "
                     "twin misfits (a cause the model lacks would be fitted into its coefficients)" if held else
                     "model adaptation resumed: the live diagnosis no longer holds `unexplained`")
        return held

    def sway_doubted(self) -> bool:
        """Whether the twin's own sway, which the surge force's coupling m₂₂·v·r takes, is known wrong now: its
        yaw rate misfits (innovation ratio above ``misfit_ratio``) and the turning is what is wrong — no turning
        fit made yet, or the latest rejects the twin's turning coefficients while the surge model's scale it
        fitted with them (:data:`~boat_twin.ident.manoeuvring.SURGE_FACTORS`) holds 1. The surge adapter is not
        fed then. A turning fit that finds the surge model off says the surge is (also) wrong, and the surge
        adapts first: the turning of a twin whose resistance is 27 % high is derived wrong from it, misfits, and
        its fit, replayed with that surge model, did not predict the held-out tail better — the surge never
        adapted (a speed ratio 10-12 for 15 minutes, ``bench_live_adapt.py`` A, twin boat 3). Logged when it
        starts and ends."""
        doubted = False
        if self.settings.adapt_turning and self.innovation_ratio("yaw_rate_radps") > self.settings.misfit_ratio:
            fit = self.turning.candidate
            if fit is None:
                doubted = self.turning.fits == 0
            else:
                doubted = (fit.rejects(coefficients(self.twin.config.vessel))
                           and all(low <= 1.0 <= high for _, low, high in fit.surge_factors.values()))
        if doubted != self._sway_doubted:
            self._sway_doubted = doubted
            self.log("surge samples set aside: the twin's yaw rate misfits and its turning is not confirmed (its "
                     "sway, in the surge force's coupling, is wrong)" if doubted else
                     "surge samples taken again: the twin's turning is confirmed or its yaw rate fits")
        return doubted

    def _held_out_score(self, t_s: float) -> Callable[[SurgeModel], float]:
        """How well a surge model predicts the last ``holdout_s``: the mean squared GNSS velocity error of the
        whole twin with that model, replayed open loop in windows from the measurements (NaN if the held-out
        stretch cannot be cut into enough windows). The velocity vector, not the speed: the twin's turning is
        derived from its mass and resistance, so a surge model is judged on all it changes; at 10-14 m/s the
        true model scores 0.15-0.26 m/s RMS, a fit whose curve ran free below its speeds 1.3-3.9
        (:func:`~boat_twin.shadow.adapt.over_configured`)."""
        try:
            windows = cut_windows(self.recent.trial(t_s - self.settings.holdout_s, t_s), REPLAY_WINDOW_S)
        except InputError:
            return lambda _model: math.nan
        config = self.twin.config
        turning = self.turning.current

        def score(model: SurgeModel) -> float:
            prediction = predict(windows, turning.config(replace(config, vessel=model.vessel(self.adapter.base))))
            errors = [windows.measured[s] - prediction.signals[s] for s in ("vel_east_mps", "vel_north_mps")]
            return float(np.nanmean(np.square(errors)))

        return score

    def vessel(self) -> VesselParams:
        """The configured boat with the adopted surge model and turning coefficients."""
        return self.turning.current.config(replace(self.base, vessel=self.adapter.vessel())).vessel

    def _update_turning(self, t_s: float) -> bool:
        """Try the turning adaptation on the horizon without its held-out tail (True: the coefficients changed):
        the fit starts from the twin's current surge model (its shape held, its scale fitted), the held-out score
        replays the last ``holdout_s``."""
        s = self.settings
        try:
            training = self.recent.trial(t_s - s.horizon_s, t_s - s.holdout_s)
            held_out = prepare(self.recent.trial(t_s - s.holdout_s, t_s))
        except InputError:
            return False
        plain = replace(self.twin.config, vessel=self.adapter.vessel())

        def score(model: TurningModel) -> float:
            return prediction_error(held_out, model.config(plain))

        return self.turning.update(training, plain, score)

    def _interval_thrust_N(self, t_s: float) -> float:
        """The mean thrust along the hull over the twin's time since the previous velocity sample, N
        (:meth:`ShadowTwin.surge_thrust_N` integrated over every propagation step: the force as the surge fit
        integrates it over the interval; NaN after a (re)synchronisation or while the thrust is not known)."""
        twin = self.twin
        epoch, impulse = twin.impulse_epoch, twin.surge_impulse_Ns
        last, self._last_impulse = self._last_impulse, (epoch, t_s, impulse)
        if last is None or last[0] != epoch or not t_s > last[1]:
            return math.nan
        return (impulse - last[2]) / (t_s - last[1])

    def _diagnose(self, t_s: float) -> None:
        job = self.rolling.start(t_s, replace(self.base, vessel=self.vessel()),
                                 self.misfit_ratio() > self.settings.misfit_ratio)
        if self.settings.diagnose_in_background:
            if self._worker is None:
                self._worker = ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("spawn"))
            self._pending = (job, self._worker.submit(job.compute))
        else:
            self._take(self.rolling.finish(job, job.compute()))

    def poll(self) -> None:
        """Take a background diagnosis that has finished (also done on every velocity sample; a node calls this
        on a timer, for when the samples stop)."""
        self._poll_diagnosis()

    def _poll_diagnosis(self) -> None:
        if self._pending is not None and self._pending[1].done():
            job, future = self._pending
            self._pending = None
            try:
                outcome = future.result()
            except Exception as err:  # noqa: BLE001 - a worker that died (killed, out of memory) is one log line
                outcome = f"the diagnosis worker failed: {type(err).__name__}: {err}"
            self._take(self.rolling.finish(job, outcome))

    def _take(self, result: RollingResult) -> None:
        """The twin predicts with the current or wind a diagnosis named (or without, once none is named)."""
        if result.error:
            return
        environment = self.base.environment
        for cause in result.causes:
            if cause.name in ENVIRONMENT_CAUSES:
                environment = _with_cause(environment, cause.name, cause.parameters)
        if environment != self.twin.config.environment:
            self.twin.set_config(replace(self.twin.config, environment=environment))

    def _collect_innovations(self) -> None:
        innovations = self.twin.innovations
        while innovations:
            item = innovations.popleft()
            if self.on_innovation is not None:
                self.on_innovation(item)
            if item.channel in self._squares:
                self._squares[item.channel].append((item.t_s, item.value**2, item.stdev**2))
        for squares in self._squares.values():
            squares.drop_before(self.twin.t_s - RATIO_WINDOW_S)

    # --- what the front ends publish -----------------------------------------------------------------------
    def innovation_ratio(self, channel: str) -> float:
        """RMS of ``channel``'s innovations (one of :data:`RATIO_CHANNELS`) over the last :data:`RATIO_WINDOW_S`
        over their stated spread (the sensor's noise with the twin's own uncertainty); NaN without innovations."""
        squares = self._squares[channel]
        if not squares:
            return math.nan
        return math.sqrt(max(squares.square_sum, 0.0) / squares.variance_sum)

    def speed_ratio(self) -> float:
        """:meth:`innovation_ratio` of the speed over ground."""
        return self.innovation_ratio("speed_mps")

    def misfit_ratio(self) -> float:
        """The larger innovation ratio of speed and yaw rate (NaN-free: NaN only when neither has one)."""
        ratios = [r for r in (self.innovation_ratio(c) for c in RATIO_CHANNELS) if math.isfinite(r)]
        return max(ratios) if ratios else math.nan

    def causes(self) -> list[str]:
        """Names of the causes the latest rolling diagnosis holds."""
        latest = self.rolling.latest
        return [c.name for c in latest.causes] if latest is not None else []

    def status(self) -> dict[str, Any]:
        """The twin now, JSON-ready: the ``follow`` timeline's entry and the node's diagnostics."""
        latest = self.rolling.latest
        return {
            "t_s": self.twin.t_s,
            "synchronised": self.twin.synchronised,
            "speed_innovation_ratio": _finite(self.speed_ratio()),
            "yaw_rate_innovation_ratio": _finite(self.innovation_ratio("yaw_rate_radps")),
            "mass_kg": float(self.adapter.current.mass_kg),
            "resistance_factor": float(self.adapter.current.resistance_factor),
            "causes": self.causes(),
            "unexplained": bool(latest.unexplained) if latest is not None else False,
        }

    def model(self) -> dict[str, Any]:
        """The adapted model, JSON-ready: the surge model with intervals, the latest fit, the environment the
        twin predicts with, the latest diagnosis and the sample counters."""
        candidate = self.adapter.candidate
        return {
            "surge": self.adapter.current.to_dict(),
            "latest_fit": candidate.to_dict() if candidate is not None else None,
            "swaps": self.adapter.swaps,
            "turning": self.turning.to_dict(self.twin.config.vessel),
            "environment": {k: float(v) for k, v in vars(self.twin.config.environment).items()},
            "diagnosis": self.rolling.latest.to_dict() if self.rolling.latest is not None else None,
            "diagnosis_runs": self.rolling.runs,
            "samples": dict(self.twin.counts),
        }

    def twin_config(self) -> TwinConfig:
        """The twin as it predicts now (adapted vessel, environment with the named current or wind)."""
        return self.twin.config

    def save(self, path: Path) -> None:
        """Write the current twin as a twin.yaml (atomically), a comment line saying where it came from."""
        save_config(self.twin_config(), path, f"boat_twin live twin at t = {self.twin.t_s:.1f} s: "
                    f"{self.adapter.swaps} model swap(s)")


def measured_input(kind: str, stamp_s: float, values: tuple[float, ...]) -> bool:
    """Whether a measured input's sample is usable: a finite stamp and values within the recording limits
    (:data:`~boat_twin.io.trial.VALUE_LIMITS`)."""
    return math.isfinite(stamp_s) and len(values) == len(VALUE_LIMITS[kind]) and all(
        low <= value <= high for value, (_, low, high, _) in zip(values, VALUE_LIMITS[kind], strict=True))


def _with_cause(environment: Environment, name: str, parameters: dict[str, float]) -> Environment:
    """``environment`` with a named water current (added) or wind (set), the catalogue's parameters in m/s."""
    east, north = parameters["east_mps"], parameters["north_mps"]
    if name == "wind":  # the catalogue's wind is the air over ground itself
        return replace(environment, wind_east_mps=east, wind_north_mps=north)
    return replace(environment, current_east_mps=environment.current_east_mps + east,
                   current_north_mps=environment.current_north_mps + north)


def _finite(value: float) -> float | None:
    return value if math.isfinite(value) else None
