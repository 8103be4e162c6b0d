"""A recorded trial as the output-error surge fit reads it: the physics the live twin's record has
(:mod:`boat_twin.shadow.adapt`), from the measurements instead of a twin's state.

Assumption: the trial's thrust commands are thrust *requests*, delivered by the configured engines
(:func:`~boat_twin.vessel.propulsion.engine_thrust_N`: at most η·P/u ahead, the reverse ratio astern) through the
configured actuators (:meth:`~boat_twin.vessel.dynamics.Dynamics.actuator_history`: the outboards swing to the
commanded angle + offset at the steering rate; the engines' first-order lag). Per sample:

- the surge u = the GNSS velocity through the water (the configured current removed) along the heading when it
  was measured (the IMU yaw less the configured yaw offset, at stamp − GNSS latency); the sway v across it;
- the thrust along the hull Σ k·T·cos δ delivered at the measured surge, as its mean over each interval (the
  outboards swing between samples), then held over the intervals between the times the speeds describe
  (:func:`~boat_twin.ident.output_error.horizon_record`, as live);
- the sway-yaw coupling m₂₂·v·r (the configured boat's m₂₂, the sway across the heading the compass and the gyro
  give together (:func:`fused_heading`), the gyro's yaw rate less its configured bias),
  whose scale the fit estimates — where the trial turns: a coupling below :data:`COUPLING_MIN_SHARE` of the
  thrust (RMS over the trial) is left out, its scale is noise there (the thrust-steps sample, which never
  steers: 0.09 %, and fitting c = −8 ± 29 widened its mass interval 4.5-fold; the twin's random-command trials
  15-23 %).

A trial without a heading (no IMU) keeps the speed over ground |v| and no coupling; the envelope, the actuators and
the latency still apply.

A measured true wind (an anemometer: :attr:`~boat_twin.io.trial.Trial.wind_east_mps`) is a known, time-varying
input (:func:`wind_record`): the wind force along the hull the twin's model applies (boat_twin.vessel.dynamics:
X_w = k·(|V_a|·u_a + |V|·u), air relative to the hull from the measured wind, GNSS velocity and heading at the
times the samples describe) per unit of its drag coefficient k = ½ρ_a·C_a·A_F, whose value the fit estimates in
the place of the coupling's scale; the sway-yaw coupling then enters the force at its model's value (c = 1).
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from boat_twin.config import TwinConfig
from boat_twin.errors import InputError
from boat_twin.ident.output_error import SurgeRecord, horizon_record
from boat_twin.io.trial import COMMAND_ROLES, Trial
from boat_twin.vessel.dynamics import Dynamics
from boat_twin.vessel.params import derive_coefficients
from boat_twin.vessel.propulsion import surge_thrust_N

SURGE_ROLES = ("gnss_vel",) + COMMAND_ROLES
"""Streams the surge samples come from: a gap in any of them makes the samples inside it unknown."""
DELIVERED_THRUST = ("thrust delivered along the hull (the commands through the configured engines' envelope and "
                    "steering)")
"""What the record's thrust is, as messages about it name it."""
HEADING_SMOOTHING_S = 5.0
"""Standard deviation of the Gaussian window over which :func:`fused_heading` trusts the compass heading (below:
the gyro's integral), s."""
COUPLING_MIN_SHARE = 0.01
"""A sway-yaw coupling whose RMS over the trial is below this share of the thrust's is left out of the record
(a trial that does not turn: its scale is not identifiable, and below the mass intervals' width), -."""


def known_samples(trial: Trial, thrust_N: np.ndarray, speed_mps: np.ndarray) -> np.ndarray:
    """(n,) True where a trial's sample is known: ``thrust_N`` and ``speed_mps`` finite. Samples before the first
    command or velocity fix and inside the reported gaps of any stream the surge uses (GNSS velocity, the
    outboards' thrust and angle commands) are unknown; a NaN anywhere else is a non-finite value in the recording
    itself and refused (InputError), as is a trial without the thrusts or the velocity."""
    source = trial.metadata.source
    for role, what in (("thrust_left", "left outboard's thrust"), ("thrust_right", "right outboard's thrust"),
                       ("gnss_vel", "GNSS velocity")):
        if role in trial.metadata.missing:
            raise InputError(f"{source}: no {what} ({role}) in the trial: the identifier needs the surge thrust of "
                             "both outboards and the speed over ground")
    t = trial.t_s
    known = np.isfinite(thrust_N) & np.isfinite(speed_mps)
    if not np.any(known):
        blank = [what for what, values in (("thrust", thrust_N), ("GNSS speed", speed_mps))
                 if not np.any(np.isfinite(values))]
        raise InputError(f"{source}: every {' and every '.join(blank)} value is NaN (not a number)" if blank else
                         f"{source}: no sample has both a thrust command and a GNSS velocity "
                         "(commands and GNSS do not overlap in time)")
    in_gap = np.zeros(t.size, dtype=bool)
    for role, start_s, end_s in trial.metadata.gaps:
        if role in SURGE_ROLES:
            in_gap |= (t > start_s) & (t < end_s)
    bad = ~known & ~in_gap & (t >= t[np.argmax(known)])
    if np.any(bad):
        first = int(np.argmax(bad))
        name = "surge thrust" if not np.isfinite(thrust_N[first]) else "speed over ground"
        raise InputError(f"{source}: {int(bad.sum())} sample(s) are NaN outside the reported gaps (first: "
                         f"{name} at t = {t[first]:.1f} s): the recording holds non-finite values")
    return known


def _interval_mean(values: np.ndarray) -> np.ndarray:
    """Each sample's mean since the previous one from values at the samples (trapezoids; the first, and one after
    an unknown value, as is)."""
    out = np.array(values, dtype=float)
    previous = values[:-1]
    out[1:] = np.where(np.isfinite(previous), 0.5 * (values[1:] + previous), values[1:])
    return out


def fused_heading(t_s: np.ndarray, heading_rad: np.ndarray, yaw_rate_radps: np.ndarray,
                  smoothing_s: float = HEADING_SMOOTHING_S) -> np.ndarray:
    """(n,) the heading from the compass at low frequencies and the gyro's integral at high ones (a complementary
    filter, zero-phase: ψ = θ + G(ψ_compass − θ), θ = ∫r dt, G a Gaussian window of σ = ``smoothing_s``), rad;
    over each stretch where both are known, the compass heading as is elsewhere. The compass's white noise
    (the UM7's 3°) leaks the surge into the sway across the heading (u·ε: 0.26 m/s at 5 m/s), whose product with
    the yaw rate is the sway-yaw coupling: a noisy regressor, whose scale the fit attenuates and the mass takes up
    (errors in variables). Through the gyro that noise falls by √(2√π·σ/Δt) (11× at 10 Hz), while the gyro's own
    noise, integrated over σ, stays below 0.05° (a constant gyro bias cancels in ψ_compass − θ); what the
    compass gets wrong slowly stays."""
    heading = np.asarray(heading_rad, dtype=float)
    out = heading.copy()
    known = np.isfinite(heading) & np.isfinite(yaw_rate_radps)
    if t_s.size < 2 or not np.any(known):
        return out
    dt = float(np.median(np.diff(t_s)))
    edges = np.flatnonzero(np.diff(np.concatenate([[0], known.astype(int), [0]])))
    for start, stop in zip(edges[::2], edges[1::2], strict=True):
        if stop - start < 2:
            continue
        rate = yaw_rate_radps[start:stop]
        theta = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(t_s[start:stop]))])
        out[start:stop] = theta + ndimage.gaussian_filter1d(heading[start:stop] - theta, smoothing_s / dt,
                                                            mode="nearest")
    return out


def trial_record(trial: Trial, config: TwinConfig, wind: bool = False) -> SurgeRecord:
    """The trial's known samples as the surge fit reads them under ``config`` (module docstring): times the speeds
    describe (s), the delivered thrust along the hull (N), the surge (m/s; without a heading, the speed over
    ground) and the sway-yaw coupling (N; None without a heading or a turn). With ``wind`` (a pooled fit whose
    trials measured the wind) the coupling is part of the force and the record's further force is the measured
    wind's per unit drag coefficient (:func:`wind_record`; None where this trial has no anemometer)."""
    known_samples(trial, trial.surge_thrust_N, trial.speed_mps)  # the recording's own faults, as commanded
    vessel, t = config.vessel, trial.t_s
    dt = float(np.median(np.diff(t))) if t.size > 1 else 0.1
    actuators = Dynamics(vessel).actuator_history(dt, trial.commands, trial.command_switch_s)
    angles, thrusts = actuators[:, :2], actuators[:, 2:]
    latency = config.gnss.latency_s
    east = trial.vel_east_mps - config.environment.current_east_mps
    north = trial.vel_north_mps - config.environment.current_north_mps
    has_heading = bool(np.any(np.isfinite(trial.heading_rad)))
    if has_heading:  # the heading and yaw rate when each velocity was measured
        gyro = trial.yaw_rate_radps - float(config.um7.gyro_bias_radps[2])
        yaw = np.interp(t - latency, t, trial.heading_rad - config.um7.yaw_offset_rad)
        surge = east * np.cos(yaw) + north * np.sin(yaw)
        sway = -east * np.sin(yaw) + north * np.cos(yaw)
        fused = np.interp(t - latency, t, fused_heading(t, trial.heading_rad, gyro) - config.um7.yaw_offset_rad)
        across = -east * np.sin(fused) + north * np.cos(fused)  # the coupling's sway: the compass' noise filtered
        rate = np.interp(t - latency, t, gyro)
        coupling = derive_coefficients(vessel).m22_kg * across * rate  # at the times the samples describe
    else:
        surge = np.hypot(east, north)
    u_now = np.interp(t, t - latency, surge)  # the surge at each stamp's own time: where the envelope is read
    held = np.vstack([thrusts[:1], thrusts[:-1]])  # each interval's thrust: the command held from its start
    u_mid = _interval_mean(u_now)
    thrust = 0.5 * (surge_thrust_N(vessel, held, np.vstack([angles[:1], angles[:-1]]), u_mid)
                    + surge_thrust_N(vessel, held, angles, u_mid))
    known = np.isfinite(thrust) & np.isfinite(surge) & (np.isfinite(coupling) if has_heading else True)
    coupling_N = coupling[known] if has_heading else None
    if not wind and coupling_N is not None and np.sqrt(np.mean(coupling_N**2)) < COUPLING_MIN_SHARE * np.sqrt(
            np.mean(thrust[known] ** 2)):
        coupling_N = None
    if wind:
        force = wind_force_per_drag(trial, yaw, surge, sway) if has_heading else None
        if force is not None:
            known &= np.isfinite(force)
        return wind_record(horizon_record(t[known], thrust[known], surge[known], latency,
                                          coupling[known] if has_heading else None),
                           None if force is None else horizon_record(t[known], thrust[known], surge[known], latency,
                                                                     force[known]).coupling_N, trial)
    record = horizon_record(t[known], thrust[known], surge[known], latency, coupling_N)
    if record.t_s.size < 3:
        raise InputError(f"{trial.metadata.source}: fewer than 3 samples with a known thrust, surge and heading")
    return record


def wind_force_per_drag(trial: Trial, yaw_rad: np.ndarray, surge_mps: np.ndarray, sway_mps: np.ndarray
                        ) -> np.ndarray | None:
    """(n,) the surge wind force per unit drag coefficient, m²/s² (N per N·s²/m²), at the times the samples
    describe (heading ``yaw_rad``; surge and sway through the water ``surge_mps``, ``sway_mps``): |V_a|·u_a +
    |V|·u as the twin's model has it, the air relative to the hull being the measured wind (held across the
    anemometer's gaps: NaN outside them) less the GNSS velocity over ground, along the hull. None without an
    anemometer."""
    if trial.wind_east_mps is None or trial.wind_north_mps is None:
        return None
    air_east, air_north = trial.wind_east_mps - trial.vel_east_mps, trial.wind_north_mps - trial.vel_north_mps
    u_air = air_east * np.cos(yaw_rad) + air_north * np.sin(yaw_rad)
    v_air = -air_east * np.sin(yaw_rad) + air_north * np.cos(yaw_rad)
    return np.hypot(u_air, v_air) * u_air + np.hypot(surge_mps, sway_mps) * surge_mps


def wind_record(record: SurgeRecord, wind_force: np.ndarray | None, trial: Trial) -> SurgeRecord:
    """``record`` (its coupling, if any, at its model's value) with the wind force per unit drag coefficient
    (held over its intervals as :func:`~boat_twin.ident.output_error.horizon_record` holds a coupling; None: this
    trial has none) as the further force whose scale, the wind drag coefficient k in N·s²/m², the fit estimates."""
    thrust = record.thrust_N if record.coupling_N is None else record.thrust_N + record.coupling_N
    if record.t_s.size < 3:
        raise InputError(f"{trial.metadata.source}: fewer than 3 samples with a known thrust, surge, heading and "
                         "wind")
    return SurgeRecord(record.t_s, thrust, record.speed_mps, wind_force)
