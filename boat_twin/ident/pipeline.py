"""The identification pipelines: a recorded trial, or a table of steady points, to the model m·dv/dt = F − Fc(v).

:func:`identify_trials` is what ``boat-twin identify TRIAL [TRIAL ...]`` runs; :func:`identify_pooled` runs
every identifier on the arrays of one or more recordings pooled (steady points, batch fits with order selection,
mass from transients, the online identifier replayed over the same samples) into a typed
:class:`~boat_twin.ident.results.Identification`; :func:`identify_recordings` and :func:`identify_arrays` (one
recording) return its ``--json`` contract (:mod:`boat_twin.ident.results` serialises, :mod:`boat_twin.ident.report`
writes the files); :func:`identify_table` reproduces the paper's table.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.data import dyda2021_table1_si
from boat_twin.errors import InputError
from boat_twin.ident.dynamic import DynamicResult, DynamicWindow, check_samples, identify_dynamic
from boat_twin.ident.online import OnlineThrustSpeedIdentifier, SteadyCriteria, detect_steady_segments
from boat_twin.ident.output_error import OutputErrorResult, SurgeFit, SurgeRecord, identify_surge, thrust_scale
from boat_twin.ident.paper import reproduce
from boat_twin.ident.resimulate import Resimulation, resimulate
from boat_twin.ident.results import (
    Identification,
    IdentifyResult,
    TrialIdentifyResult,
    TrialReplay,
    TrialsIdentification,
    identification_dict,
    model_dict,
    steady_point_dicts,
    trials_identification_dict,
    write_model_yaml,
)
from boat_twin.ident.settling import DerivedCriteria, derive_criteria
from boat_twin.ident.steady import FitResult, fit_power_series, select_order
from boat_twin.ident.trial_record import DELIVERED_THRUST, known_samples, trial_record
from boat_twin.ident.twin_config import identified_vessel, thrust_seen
from boat_twin.ident.wind_drag import wind_drag_result
from boat_twin.io.trial import Trial, long_holds, thrust_outliers
from boat_twin.twin.replay import measured_wind_mps
from boat_twin.units import KGF_N, KNOT_MPS
from boat_twin.vessel.params import (
    HELD_COMMAND_TIME_CONSTANTS,
    VesselParams,
    held_command_limit_s,
    surge_response_time_s,
    vessel_with_facts,
)

__all__ = ["IdentifyResult", "TrialIdentifyResult", "identify_arrays", "identify_pooled", "identify_recordings",
           "identify_table", "identify_trial", "identify_trials", "identify_and_resimulate", "model_dict", "pool",
           "replay_online", "trial_samples", "trial_warnings", "write_model_yaml"]
"""The pipelines, and the result types and writers of :mod:`boat_twin.ident.results` their callers import here."""

TWO_WAY_WARNING = 0.3
"""Below this share of the speed range crossed both ways, the report warns: the mass rests on Fc's form."""


def _nrms(a: np.ndarray, b: np.ndarray) -> float:
    """RMS of a − b relative to the RMS of b."""
    return float(np.sqrt(np.mean((a - b) ** 2)) / np.sqrt(np.mean(b**2)))


def trial_samples(trial: Trial) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Time (s), commanded surge thrust Σ T·cos δ (N) and GNSS speed over ground (m/s) of a trial's known samples
    (:func:`~boat_twin.ident.trial_record.known_samples`): the trial as commanded, without the configured boat's
    engines and actuators (``identify`` fits :func:`~boat_twin.ident.trial_record.trial_record`)."""
    thrust, speed = trial.surge_thrust_N, trial.speed_mps
    known = known_samples(trial, thrust, speed)
    return trial.t_s[known], thrust[known], speed[known]


def replay_online(
    t_s: np.ndarray,
    thrust_N: np.ndarray,
    speed_mps: np.ndarray,
    identifier: OnlineThrustSpeedIdentifier,
) -> OnlineThrustSpeedIdentifier:
    """Feed a trial's samples to ``identifier`` one by one in timestamp order, then close its last segment.

    The replay of ``boat-twin identify TRIAL``: the same :meth:`~OnlineThrustSpeedIdentifier.update` calls the
    identifier node makes live. Returns ``identifier``.
    """
    for sample in zip(np.asarray(t_s).tolist(), np.asarray(thrust_N).tolist(), np.asarray(speed_mps).tolist(),
                      strict=True):
        identifier.update(*sample)
    identifier.finish()
    return identifier


POOL_GAP_S = 1000.0
"""Pooled recordings are placed on one time axis this far apart, s: no steady segment or dynamic window spans two."""
OVER_THRUST = 0.15
"""A resistance more than this share above the thrust that held a steady speed (or above the largest thrust at a
speed the boat sustained) is not physical: the twin is refused, -."""


def pool(pieces: list[tuple[Any, Any, Any]]) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Checked (t s, thrust N, speed m/s) recordings, each shifted to start :data:`POOL_GAP_S` after the last one
    ends (the first keeps its times), so that they share one time axis without touching."""
    out: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    for i, (t_s, thrust_N, speed_mps) in enumerate(pieces):
        try:
            t, f, v = check_samples(t_s, thrust_N, speed_mps)
        except InputError as err:
            raise InputError(f"recording {i + 1}: {err}" if len(pieces) > 1 else str(err)) from None
        if out:
            t = t - t[0] + out[-1][0][-1] + POOL_GAP_S
        out.append((t, f, v))
    return out


MASS_DEPARTURE = 0.25
"""An identified mass further than this share from a boat file's ``mass_kg`` is remarked in the warnings, -."""
REST_NOISE_FACTOR = 3.0
"""A steady point slower than this many speed-noise σ is at rest (:func:`rest_floor`), -."""


def rest_floor(derived: DerivedCriteria) -> float:
    """Speed below which a steady point is the boat at rest, not a speed its thrust held, m/s:
    :data:`REST_NOISE_FACTOR` × the speed's white noise σ measured on the trial (``derived``): the speed over
    ground of a boat lying still is the magnitude of that noise (its mean 1.25 σ for two axes of noise σ, 99 % of
    it below 3.03 σ), whatever trickle of thrust an idling ESC logs."""
    return REST_NOISE_FACTOR * derived.speed_noise_mps


def physical_problems(fit: SurgeFit, points: list[dict[str, float]],
                      pieces: list[tuple[np.ndarray, np.ndarray, np.ndarray]], thrust_name: str = "thrust",
                      sources: list[str] | None = None, rest_mps: float = 0.0) -> list[str]:
    """Why the identified model is not physical (empty: it is): a mass that is not positive, a resistance above
    the (positive) thrust that held a steady speed, or above the largest thrust of the fitted ``pieces`` at a
    speed the boat sustained for 5 s, or a curve that decreases. ``thrust_name`` says what the pieces' thrust is
    and ``sources`` names each piece (the messages name what was checked). Steady points at rest (slower than
    ``rest_mps``: :func:`rest_floor`) are not checked."""
    problems = []
    if not (np.isfinite(fit.mass_kg) and fit.mass_kg > 0.0):
        problems.append(f"effective mass {fit.mass_kg:.4g} kg is not positive")
    for p in points:
        if p["thrust_N"] <= 0.0 or p["speed_mps"] < rest_mps:
            continue  # at rest (or astern): the speed over ground is the GNSS noise floor
        force = float(fit.resistance_N(np.array([p["speed_mps"]]))[0])
        if force > (1.0 + OVER_THRUST) * p["thrust_N"] + 3.0 * p.get("thrust_stderr_N", 0.0):
            problems.append(f"Fc({p['speed_mps']:.2f} m/s) = {force:.4g} N is above the {p['thrust_N']:.4g} N "
                            "that held that speed steadily")
    sustained = 0.0
    for t, _, v in pieces:
        width = max(int(round(5.0 / float(np.median(np.diff(t))))), 1) if t.size > 1 else 1
        if v.size >= width:
            sustained = max(sustained, float(np.max(np.convolve(np.abs(v), np.ones(width) / width, "valid"))))
    tops = [float(np.max(f)) for _, f, _ in pieces]
    top = int(np.argmax(tops))
    grid = np.linspace(0.0, sustained, 50)
    over = fit.resistance_N(grid) > (1.0 + OVER_THRUST) * max(tops[top], 0.0)
    if np.any(over):
        where = f" in {sources[top]}" if sources else ""
        problems.append(f"Fc({grid[np.argmax(over)]:.2f} m/s) exceeds the largest {thrust_name}: {tops[top]:.4g} N"
                        f"{where}, yet the boat sustained {sustained:.2f} m/s")
    if np.any(np.diff(fit.resistance_N(np.linspace(0.0, fit.top_speed_mps, 200))) < -1e-9):
        problems.append("Fc decreases with speed")
    return problems


def _steady_view(points: list[Any], rejected: list[Any], criteria: SteadyCriteria, order: int | None,
                 max_order: int, monotone: bool, through_origin: bool
                 ) -> tuple[tuple[FitResult, ...], int | None, str, list[str]]:
    """Steady power-series fits (a view of the data and the paper's method): fits, selected order, why, warnings.
    Too few steady points for an ``order`` asked for is an error; without one, the view is left out."""
    needed = (order or 1) + 2
    if len(points) < needed:
        why = "; ".join(f"{s.thrust_N:.0f} N at {s.start_s:.0f} s: {s.reason}" for _, s in rejected[:3])
        message = (f"{len(points)} steady point(s) found, order {order or 1} needs at least {needed} (N + 2): "
                   f"hold more thrust levels until the speed settles ({criteria.window_s:.3g} s without a trend)"
                   + (f"; rejected: {why}" if why else ""))
        if order is not None:
            raise InputError(message)
        return (), None, message, [f"no steady points' polynomial (a view only): {message}"]
    speed = np.array([s.speed_mps for _, s in points])
    thrust = np.array([s.thrust_N for _, s in points])
    if order is None:
        selection = select_order(speed, thrust, max_order, monotone, through_origin=through_origin)
        fits: tuple[FitResult, ...] = selection.fits
        chosen, reason = selection.selected_order, selection.reason
    else:
        fits = (fit_power_series(speed, thrust, order, monotone, through_origin),)
        chosen, reason = order, f"N = {order}: given"
    fit = next(fr for fr in fits if fr.order == chosen)
    warnings = []
    if not fit.monotone:
        bands = ", ".join(f"{lo:.2f}-{hi:.2f}" for lo, hi in fit.nonmonotone_bands)
        warnings.append(f"the steady points' polynomial (N = {chosen}) decreases at {bands} m/s (a view only: the "
                        "model is the output-error fit, non-decreasing by construction)")
    return fits, chosen, reason, warnings


def identify_arrays(
    t_s: Any,
    thrust_N: Any,
    speed_mps: Any,
    **options: Any,
) -> IdentifyResult:
    """Identify one recording from its arrays: time (s), total thrust (N), speed over ground (m/s).
    :func:`identify_recordings` with one recording; ``options`` are its keyword arguments."""
    return identify_recordings([(t_s, thrust_N, speed_mps)], **options)


def identify_recordings(recordings: list[tuple[Any, Any, Any]], **options: Any) -> IdentifyResult:
    """:func:`identify_pooled` as the ``--json`` contract (SI): ``output_error``, ``physical_problems``,
    ``steady_points``, ``rejected_segments``, ``steady_criteria``, ``fits``, ``selected_order`` (None without
    enough steady points), ``selection_reason``, ``dynamic``, ``online``, ``model`` (for :func:`write_model_yaml`)
    and ``warnings``; each steady point and rejected segment names its ``recording`` (0-based)."""
    return identification_dict(identify_pooled(recordings, **options))


def identify_pooled(
    recordings: list[tuple[Any, Any, Any]],
    *,
    order: int | None = None,
    max_order: int = 6,
    monotone: bool = False,
    through_origin: bool = True,
    criteria: SteadyCriteria | None = None,
    window_s: float | None = None,
    thrust_tolerance_N: float | None = None,
    noise_correlation_s: float = 0.0,
    speed_noise_mps: float | None = None,
    window: DynamicWindow | None = None,
    memory_s: float = 3600.0,
    fallback_mass_kg: float | None = None,
    couplings: list[np.ndarray | None] | None = None,
    thrust_name: str = "thrust",
    sources: list[str] | None = None,
) -> Identification:
    """Identify a boat from one or more recordings of (time s, total thrust N, speed m/s), pooled in one fit.

    The model is the output-error fit over every sample (:func:`~boat_twin.ident.output_error.identify_surge`:
    effective mass and a non-decreasing resistance with Fc(0) = 0, complexity by cross-validated multi-step
    prediction, always beside the baseline m·du/dt = T − a·u − b·u|u| fitted the same way). When the data do not
    identify the mass, ``fallback_mass_kg`` (effective mass, kg, e.g. from a boat file) is held instead and the
    curve refitted; without it the model has no mass. ``couplings`` (one per recording, its samples', N; None:
    none) is a further surge force whose scale the fit estimates (the sway-yaw coupling of
    :func:`~boat_twin.ident.trial_record.trial_record`); ``thrust_name`` (what the recordings' thrust is) and
    ``sources`` (a name per recording) are what a problem found names. Views of the same data: steady points
    (detector run on each recording; its criteria derived from the data by
    :func:`~boat_twin.ident.settling.derive_criteria`, ``window_s`` / ``thrust_tolerance_N`` overriding,
    ``noise_correlation_s`` > 0 and ``speed_noise_mps`` for a speed smoothed from positions; or ``criteria`` taken
    as given) with power-series fits of N = 1..``max_order`` (CV/BIC selection, or ``order``; Fc(0) = 0 unless
    ``through_origin`` is False), mass + Fc from transients, and the online identifier replayed over the same
    samples with its agreement with batch. Returns the typed :class:`~boat_twin.ident.results.Identification`
    (:func:`identify_recordings`: its ``--json`` contract), which holds the records the output-error fit read
    (``records``: one per recording, the plots' data). Pooled recordings share one time axis (:func:`pool`); each
    steady point and rejected segment names its recording (0-based).
    """
    pieces = pool(recordings)
    records = [SurgeRecord(*piece, coupling)
               for piece, coupling in zip(pieces, couplings or [None] * len(pieces), strict=True)]
    derived = derive_criteria(pieces, criteria, window_s=window_s, thrust_tolerance_N=thrust_tolerance_N,
                              noise_correlation_s=noise_correlation_s, speed_noise_mps=speed_noise_mps)
    if criteria is not None and window_s is None and thrust_tolerance_N is None:
        derived = replace(derived, criteria=criteria, given=("all",))
    criteria = derived.criteria
    t, f, v = (np.concatenate(column) for column in zip(*pieces, strict=True))
    if np.ptp(f) <= max(
        criteria.thrust_tolerance_N, criteria.thrust_tolerance_rel * float(np.max(np.abs(f)))
    ):
        raise InputError(
            f"thrust is constant ({np.mean(f):.1f} N) over the whole trial: Fc(v) and the mass are "
            "unidentifiable from one thrust level; record thrust steps"
        )
    segments = [(i, s) for i, piece in enumerate(pieces) for s in detect_steady_segments(*piece, criteria)]
    points = [(i, s) for i, s in segments if s.accepted]
    rejected = [(i, s) for i, s in segments if not s.accepted]
    fits, chosen, reason, warnings = _steady_view(points, rejected, criteria, order, max_order, monotone,
                                                   through_origin)
    oe = _output_error(records, fallback_mass_kg, warnings)
    dyn, dynamic_error = _dynamic(t, f, v, window, warnings)
    model: dict[str, Any] = {"resistance": oe.selected.resistance_model().to_dict()}
    if oe.mass_identified or oe.selected.mass_fixed:
        model["effective_mass_kg"] = oe.selected.mass_kg
    online = OnlineThrustSpeedIdentifier(
        chosen or 1,
        dyn.order if dyn else (chosen or 1),
        memory_s=memory_s,
        through_origin=through_origin,
        criteria=criteria,
        window=window,
    )
    for piece in pieces:
        replay_online(*piece, online)
    rest = rest_floor(derived)
    problems = physical_problems(oe.selected, steady_point_dicts(points), pieces, thrust_name, sources, rest)
    at_rest = [p for p in physical_problems(oe.selected, steady_point_dicts(points), pieces, thrust_name, sources)
               if p not in problems]
    if at_rest:
        warnings.append(f"not checked, at rest (speed below {rest:.3g} m/s = {REST_NOISE_FACTOR:g}× the speed "
                        "noise: there the speed over ground is the noise's magnitude): " + "; ".join(at_rest))
    return Identification(oe, problems, points, rejected, derived, fits, chosen, reason, dyn, dynamic_error,
                          _online_view(online, fits, chosen, dyn), model, warnings, records)


def _output_error(records: list[SurgeRecord], fallback_mass_kg: float | None, warnings: list[str]
                  ) -> OutputErrorResult:
    """The output-error model over every sample of ``records``; the fallback mass held when the data do not
    identify one (without one, a warning: no mass in the model). With a fallback mass, the thrust's scale with
    the mass held at it (:func:`~boat_twin.ident.output_error.thrust_scale`, from the fit of the mass)."""
    oe = identify_surge(records)
    scale = None if fallback_mass_kg is None else thrust_scale(oe, fallback_mass_kg)
    if not oe.mass_identified and fallback_mass_kg is not None:
        warnings.append(f"{oe.mass_note}; the boat file's mass (with its added mass) {fallback_mass_kg:.0f} kg is "
                        "held in the model (not identified: no interval on it)")
        oe = identify_surge(records, mass_kg=fallback_mass_kg)
    oe = replace(oe, thrust_scale=scale)
    if not oe.mass_identified and fallback_mass_kg is None:
        warnings.append(f"{oe.mass_note}; no mass in the model (give a boat file with mass_kg)")
    return oe


def _dynamic(t: np.ndarray, f: np.ndarray, v: np.ndarray, window: DynamicWindow | None, warnings: list[str]
             ) -> tuple[DynamicResult | None, str]:
    """Mass + Fc from the transients (a view), or None and why not."""
    try:
        dyn = identify_dynamic(t, f, v, None, window)
        if not dyn.mass_kg > 0.0:
            raise InputError(f"the mass from the transients is {dyn.mass_kg:.0f} kg: physically impossible (time "
                             "stamps out of order, or commands not aligned with the speed?); no mass identified")
    except InputError as err:
        return None, str(err)
    if dyn.two_way_fraction < TWO_WAY_WARNING:
        warnings.append(
            f"only {dyn.two_way_fraction:.0%} of the speed range was crossed both accelerating and "
            "decelerating: the mass rests on the form of Fc; add thrust steps down as well"
        )
    return dyn, ""


def _online_view(online: OnlineThrustSpeedIdentifier, fits: tuple[FitResult, ...], chosen: int | None,
                 dyn: DynamicResult | None) -> dict[str, Any]:
    """The replayed online identifier's snapshot with its agreement with the batch fits."""
    snap = online.snapshot()
    agreement: dict[str, Any] = {}
    if snap["coefficients"] is not None and fits:
        fit = next(fr for fr in fits if fr.order == chosen)
        grid = np.linspace(fit.domain[0], fit.domain[1], 200)
        agreement["curve_nrms"] = _nrms(np.polynomial.polynomial.polyval(grid, snap["coefficients"]),
                                        fit.predict(grid))
    if dyn is not None and snap["dynamic"] is not None:
        agreement["mass_rel"] = snap["dynamic"]["mass_kg"] / dyn.mass_kg - 1.0
    snap["agreement_with_batch"] = agreement
    return snap


def identify_trial(trial: Trial, **options: Any) -> tuple[TrialIdentifyResult, Resimulation | None]:
    """One recorded trial: :func:`identify_trials` with it alone; returns the result and its re-simulation."""
    result, found = identify_trials([trial], **options)
    return result, found.trials[0].resimulation


def identify_trials(trials: list[Trial], **options: Any) -> tuple[TrialIdentifyResult, TrialsIdentification]:
    """:func:`identify_and_resimulate` and its ``--json`` contract: ``trial`` and ``resimulation`` (the latter
    ``{"error": why}`` when the loop cannot be closed) describe the first trial; ``trials`` lists every trial
    with its own re-simulation; ``twin`` holds the vessel (``vessel``, ``sources``) or ``{"error": why}``.
    Returns the contract and the typed result it serialises (the records fitted, the re-simulations, the
    vessel: what the reports draw)."""
    found = identify_and_resimulate(trials, **options)
    return trials_identification_dict(found), found


ASSUMED_BOAT = ("no boat facts given (--boat): the twin's length, beam, engines and bollard thrust are the default "
                "boat's, carried to the identified mass, and the thrust checks use its bollard thrust")
"""The warning of an identification without boat facts: what was assumed rather than given."""


def identify_and_resimulate(trials: list[Trial], *, order: int | None = None, max_order: int = 6,
                            monotone: bool = False, window_s: float | None = None,
                            thrust_tolerance_N: float | None = None, boat: dict[str, float] | None = None,
                            config: TwinConfig | None = None) -> TrialsIdentification:
    """Recorded trials pooled in one identification (:func:`identify_pooled` on their known samples), the
    identified twin's vessel built (:func:`~boat_twin.ident.twin_config.identified_vessel`: ``boat`` facts from
    a boat file, the rest carried from the default boat), then each trial re-simulated with that vessel (closing
    the loop). Each trial is read as :func:`~boat_twin.ident.trial_record.trial_record` reads it under ``config``
    (default the built-in boat; ``boat`` facts over its vessel): its thrust commands delivered by the configured
    engines and actuators, its surge along the heading at the GNSS latency, the sway-yaw coupling."""
    boat = boat or {}
    config = config or TwinConfig()
    facts: dict[str, Any] = {k: v for k, v in boat.items() if k in VesselParams.__dataclass_fields__}
    config = replace(config, vessel=vessel_with_facts(config.vessel, facts))
    windy = [trial for trial in trials if measured_wind_mps(trial) is not None]
    records = [trial_record(trial, config, wind=bool(windy)) for trial in trials]
    samples = [(rec.t_s, rec.thrust_N, rec.speed_mps) for rec in records]
    fallback = boat["mass_kg"] * (1.0 + boat.get("surge_added_mass_ratio", VesselParams().surge_added_mass_ratio)) \
        if "mass_kg" in boat else None
    found = identify_pooled(
        samples, order=order, max_order=max_order, monotone=monotone, window_s=window_s,
        thrust_tolerance_N=thrust_tolerance_N,
        noise_correlation_s=max(trial.metadata.speed_smoothing_s for trial in trials),
        speed_noise_mps=max(trial.metadata.derived_speed_noise_mps for trial in trials) or None,
        fallback_mass_kg=fallback, couplings=[rec.coupling_N for rec in records], thrust_name=DELIVERED_THRUST,
        sources=[str(trial.metadata.source) for trial in trials])
    found.warnings += [w for trial in trials for w in trial_warnings(trial, boat)]
    if not boat:
        found.warnings.append(ASSUMED_BOAT)
    with_fix = [trial for trial in trials if np.any(np.isfinite(trial.lat_deg))]
    result = TrialsIdentification(found, [], None, origin=with_fix[0].metadata.origin if with_fix else None,
                                  wind_drag=wind_drag_result(found.output_error, len(windy)))
    try:
        if found.physical_problems:
            raise InputError("the identified model is not physical: " + "; ".join(found.physical_problems))
        result.vessel, result.vessel_sources = identified_vessel(
            found.model, boat, thrust_seen(trials, config.vessel), mass_held=found.output_error.selected.mass_fixed)
        _identified_windage(result, boat)
    except InputError as err:
        result.twin_error = str(err)
        found.warnings.append(f"no twin configuration: {err}")
    if result.vessel is not None and "mass_kg" in boat and found.output_error.mass_identified:
        departure = result.vessel.mass_kg / boat["mass_kg"] - 1.0
        if abs(departure) > MASS_DEPARTURE:
            found.warnings.append(
                f"the identified mass {result.vessel.mass_kg:.4g} kg is {abs(departure):.0%} "
                f"{'above' if departure > 0 else 'below'} the boat file's {boat['mass_kg']:.4g} kg (more than "
                f"{MASS_DEPARTURE:.0%}): the twin uses the identified one; check the boat file's mass (as loaded: "
                "batteries, payload, crew), the thrust's units and calibration, and whether the thrust logged is "
                "what the propellers delivered")
    oe = found.output_error
    mass_source = "identified" if oe.mass_identified else \
        "boat file" if oe.selected.mass_fixed else "NOT identified: the fit's point estimate"
    resim_model = {**found.model, "effective_mass_kg": oe.selected.mass_kg}
    for trial in trials:
        meta = trial.metadata
        replay = TrialReplay(str(meta.source), meta.summary_line(), meta.gaps, meta.missing, meta.derived, None)
        try:
            replay.resimulation = resimulate(trial, resim_model, result.vessel, mass_source)
        except InputError as err:  # the identification stands; say why the loop could not be closed
            replay.error = str(err)
        result.trials.append(replay)
    return result


def _identified_windage(result: TrialsIdentification, boat: dict[str, Any]) -> None:
    """The twin's frontal windage area from the fitted wind drag (selected model) when its 95 % interval lies
    above 0 and the boat file does not state the area."""
    drag = result.wind_drag
    if result.vessel is None or drag is None or "frontal_windage_area_m2" in boat \
            or not drag.selected.ci95_Ns2pm2[0] > 0.0:
        return
    result.vessel = replace(result.vessel, frontal_windage_area_m2=drag.selected.frontal_area_m2)
    result.vessel_sources["frontal_windage_area_m2"] = "identified (the measured wind's drag)"


def trial_warnings(trial: Trial, boat: dict[str, float] | None = None) -> list[str]:
    """What a trial's reading did to its data, as identify warnings (:meth:`TrialMetadata.warnings`: signals
    missing, spans without samples, clock faults, dropouts, derived streams);
    and what in its commands no fit should take on trust: thrust samples beyond 5 times the bollard thrust of
    ``boat`` (boat-file facts; default the default boat's) and thrust held unchanged longer than the default
    boat's :func:`~boat_twin.vessel.params.held_command_limit_s` (the boat being identified has no time constant
    yet)."""
    source = trial.metadata.source
    meta = trial.metadata
    prior = VesselParams()
    commands = [thrust_outliers(trial, (boat or {}).get("bollard_thrust_N", prior.bollard_thrust_N)),
                long_holds(trial, held_command_limit_s(prior), f"{HELD_COMMAND_TIME_CONSTANTS:g} x the default "
                           f"boat's surge response time, {surge_response_time_s(prior):.0f} s")]
    return [f"{source}: {w}" for w in commands if w] + meta.warnings()


def identify_table(monotone: bool = False, order: int | None = None, max_order: int = 8,
                   through_origin: bool = False) -> tuple[dict[str, Any], FitResult]:
    """Dyda & Chumakova (2021) Table 1: the paper's reproduction (kn, kgf) with the selected fit, plus that fit
    in SI (``result["si"]``) and as a :class:`FitResult` (the model a simulator loads)."""
    result = reproduce(monotone, order, max_order, through_origin)
    speed_si, thrust_si = dyda2021_table1_si()
    si_fit = fit_power_series(speed_si, thrust_si, result["selected_order"], monotone, through_origin)
    result["si"] = {
        "order": si_fit.order,
        "coefficients": si_fit.coefficients.tolist(),
        "stderr": si_fit.stderr.tolist(),
        "max_speed_mps": si_fit.domain[1],
        "units": {"speed": "m/s", "force": "N", "coefficients": "N/(m/s)^i", "knot_mps": KNOT_MPS, "kgf_N": KGF_N},
    }
    return result, si_fit
