"""A plain RK4 integrator for the tests' independent boats: written apart from the twin's numba kernel, so the
analyses are also checked on data whose equations and integration the package did not make."""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from boat_twin.io.trial import Trial


def rk4_held(deriv: Callable[[np.ndarray, float], np.ndarray], state: np.ndarray, commands: np.ndarray,
             h: float, substeps: int) -> np.ndarray:
    """Integrate ``deriv(state, command)`` with classic RK4 steps of ``h``, each command held for ``substeps``
    steps; returns the state at the start of every command, shape (len(commands), len(state))."""
    rows = np.empty((len(commands), state.size))
    for i, u in enumerate(commands):
        rows[i] = state
        for _ in range(substeps):
            k1 = deriv(state, u)
            k2 = deriv(state + h / 2 * k1, u)
            k3 = deriv(state + h / 2 * k2, u)
            k4 = deriv(state + h * k3, u)
            state = state + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return rows


def boat_trial(params: Any, thrust_N: Callable[[float], float], steering_rad: Callable[[float], float],
               duration_s: float, rng: np.random.Generator, *, delay_s: float = 0.0, lag_s: float = 0.0,
               yaw_offset_rad: float = 0.0, latency_s: float = 0.1, dropout: float = 0.0,
               initial_surge_mps: float = 5.0, heading_rad: float = 0.3, engines: bool = False,
               wind_mps: Callable[[float], tuple[float, float]] | None = None,
               accel_stdev_mps2: float | None = None) -> Trial:
    """A trial of a twin-outboard boat of ``params`` (a VesselParams: its derived coefficients, documented in
    boat_twin.vessel.dynamics' docstring) integrated here with classic RK4 at 100 Hz, written apart from the twin's
    kernel: both outboards at ``thrust_N(t)`` each (N, within the envelope: no limit is applied) and
    ``steering_rad(t)`` (an instantaneous actuator), no current. With ``engines`` the commands are requests
    the boat's engines deliver at most η·P/|u| ahead (``params``' power, efficiency and bollard thrust; astern its
    reverse ratio) and the outboards swing to the commanded angle at ``params.steering_rate_radps`` (the angle moved
    once per 10 ms step, written here apart from the twin's exact actuator). The boat acts on the commands
    ``delay_s`` late; each engine's thrust follows its command with a first-order lag ``lag_s`` (an extra state
    integrated with the motion); the IMU's yaw reads the true heading plus ``yaw_offset_rad``. Logged at 10 Hz with
    the twin's default sensor noise (GNSS velocity 0.05 m/s, position 2.1 m, delivered ``latency_s`` late; IMU yaw
    3°, gyro 0.06°/s) and each GNSS fix lost with probability ``dropout``. The command log holds what was commanded
    (the undelayed ``thrust_N``, ``steering_rad``) as a recorder of stamped command messages gives it
    (:func:`logged_commands`): each change at the log sample nearest the instant it was issued, and that instant in
    ``command_switch_s``. ``wind_mps(t)``: a true wind over ground (east, north, m/s) acting as the twin's model
    documents it (quadratic drag on the frontal and lateral windage in the apparent wind, less the calm-air drag,
    the lateral force at the centre of windage; the drag coefficient as boat_twin.vessel.params states it), logged
    by an anemometer with 0.3 m/s noise per component. With ``accel_stdev_mps2`` the IMU also logs its accelerometer,
    u̇ − v·r and v̇ + u·r (the rates at each logged sample) plus white noise of that σ; without, no
    accelerometer (NaN)."""
    from boat_twin.io.trial import Trial, TrialMetadata
    from boat_twin.units import AIR_DENSITY_KGPM3
    from boat_twin.vessel.params import WINDAGE_DRAG_COEFFICIENT, derive_coefficients

    c = derive_coefficients(params)
    k_x = 0.5 * AIR_DENSITY_KGPM3 * WINDAGE_DRAG_COEFFICIENT * params.frontal_windage_area_m2
    k_y = 0.5 * AIR_DENSITY_KGPM3 * WINDAGE_DRAG_COEFFICIENT * params.lateral_windage_area_m2

    def windage(psi: float, u: float, v: float, t: float) -> tuple[float, float]:
        if wind_mps is None:
            return 0.0, 0.0
        we, wn = wind_mps(t)
        ae, an = we - (u * math.cos(psi) - v * math.sin(psi)), wn - (u * math.sin(psi) + v * math.cos(psi))
        ua, va = ae * math.cos(psi) + an * math.sin(psi), -ae * math.sin(psi) + an * math.cos(psi)
        air, calm = math.hypot(ua, va), math.hypot(u, v)
        return k_x * (air * ua + calm * u), k_y * (air * va + calm * v)
    m11, m22, m33 = c.m11_kg, c.m22_kg, c.m33_kgm2
    x_e = params.engine_x_m

    angle = [steering_rad(-delay_s)]  # the outboards' real angle (engines), moved between steps

    def rates(s: np.ndarray, t: float) -> np.ndarray:
        psi, u, v, r, thrust = s[2], s[3], s[4], s[5], s[6]
        d = angle[0] if engines else steering_rad(t - delay_s)
        commanded = thrust_N(t - delay_s)
        dthrust = (commanded - thrust) / lag_s if lag_s > 0 else 0.0
        thrust = thrust if lag_s > 0 else commanded
        if engines:
            ahead = params.bollard_thrust_N if abs(u) < 1e-9 else \
                min(params.bollard_thrust_N, params.propulsive_efficiency * params.engine_power_W / abs(u))
            thrust = min(max(thrust, -params.reverse_thrust_ratio * params.bollard_thrust_N), ahead)
        xw, yw = windage(psi, u, v, t)
        fx, fy = 2.0 * thrust * math.cos(d) + xw, 2.0 * thrust * math.sin(d) + yw
        drag = float(params.resistance.force_N(abs(u))) * (1.0 if u >= 0.0 else -1.0)  # opposes the motion
        du = (fx + m22 * v * r - drag) / m11
        dv = (fy - m11 * u * r - c.sway_damping_Nspm2 * abs(u) * v - c.sway_quadratic_Ns2pm2 * abs(v) * v) / m22
        dr = (x_e * (fy - yw) + params.windage_centre_x_m * yw - (m22 - m11) * u * v
              - c.lateral_centre_x_m * c.sway_damping_Nspm2 * abs(u) * v
              - c.yaw_damping_Nms * abs(u) * r - c.yaw_quadratic_Nms2 * abs(r) * r) / m33
        return np.array([u * math.cos(psi) - v * math.sin(psi), u * math.sin(psi) + v * math.cos(psi), r, du, dv,
                         dr, dthrust])

    n, h = int(round(duration_s * 10)) + 1, 0.01
    states = np.zeros((n, 7))
    s = np.array([0.0, 0.0, heading_rad, initial_surge_mps, 0.0, 0.0, thrust_N(-delay_s)])
    t = 0.0
    for i in range(n):
        states[i] = s
        for _ in range(10):
            k1 = rates(s, t)
            k2 = rates(s + 0.5 * h * k1, t + 0.5 * h)
            k3 = rates(s + 0.5 * h * k2, t + 0.5 * h)
            k4 = rates(s + h * k3, t + h)
            s = s + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
            t += h
            if engines:
                target, reach = steering_rad(t - delay_s), params.steering_rate_radps * h
                angle[0] = angle[0] + min(max(target - angle[0], -reach), reach) if reach > 0.0 else target
    time_s = np.arange(n) / 10.0
    psi, u, v = states[:, 2], states[:, 3], states[:, 4]
    accel = np.full((n, 2), np.nan)
    if accel_stdev_mps2 is not None:
        for i in range(n):
            d = rates(states[i], time_s[i])
            accel[i] = (d[3] - states[i, 4] * states[i, 5] + rng.normal(0.0, accel_stdev_mps2),
                        d[4] + states[i, 3] * states[i, 5] + rng.normal(0.0, accel_stdev_mps2))
    vel_e, vel_n = u * np.cos(psi) - v * np.sin(psi), u * np.sin(psi) + v * np.cos(psi)
    late = np.maximum(np.arange(n) - int(round(latency_s * 10)), 0)  # the fix at t holds the state at t − latency

    def noisy(x: np.ndarray, sigma: float) -> np.ndarray:
        return x + rng.normal(0.0, sigma, n)

    lost = rng.random(n) < dropout
    lost[[0, -1]] = False
    gnss = {"east_m": noisy(states[late, 0], 2.1), "north_m": noisy(states[late, 1], 2.1),
            "vel_east_mps": noisy(vel_e[late], 0.05), "vel_north_mps": noisy(vel_n[late], 0.05)}
    bridged = np.zeros(n, dtype=bool)
    if lost.any():  # a lost fix: the reader interpolates across it (one lost) or leaves a gap (more)
        kept = ~lost
        gap = lost & (np.roll(lost, 1) | np.roll(lost, -1))
        for key, values in gnss.items():
            bridged_values = np.interp(time_s, time_s[kept], values[kept])
            gnss[key] = np.where(gap, np.nan, np.where(lost, bridged_values, values))
        bridged = lost & ~gap
    thrust, thrust_switch = logged_commands(thrust_N, n, 0.1)
    angle, angle_switch = logged_commands(steering_rad, n, 0.1)
    with warnings.catch_warnings():  # the mean over the commands that changed at a sample, as the reader's
        warnings.simplefilter("ignore", RuntimeWarning)
        switch = np.nan_to_num(np.nanmean(np.stack([thrust_switch, angle_switch]), axis=0), nan=0.0)
    return Trial(
        t_s=time_s, thrust_left_N=thrust, thrust_right_N=thrust.copy(), angle_left_rad=angle,
        angle_right_rad=angle.copy(), lat_deg=np.full(n, np.nan), lon_deg=np.full(n, np.nan),
        heading_rad=noisy(psi + yaw_offset_rad, math.radians(3.0)),
        yaw_rate_radps=noisy(states[:, 5], math.radians(0.06)), accel_x_mps2=accel[:, 0],
        accel_y_mps2=accel[:, 1], metadata=TrialMetadata(source="independent integrator"), **gnss,
        **({"gnss_bridged": bridged} if bridged.any() else {}),
        **({"command_switch_s": switch} if np.any(switch != 0.0) else {}),
        **({} if wind_mps is None else dict(zip(("wind_east_mps", "wind_north_mps"), (
            noisy(np.array([wind_mps(t)[k] for t in time_s]), 0.3) for k in range(2)), strict=True))),
    )


def logged_commands(command: Callable[[float], float], n: int, period_s: float, resolution_s: float = 0.01
                    ) -> tuple[np.ndarray, np.ndarray]:
    """A piecewise-constant ``command(t)`` as the trial reader logs a stamped command stream on a grid of ``n``
    samples ``period_s`` apart (boat_twin.io.trial: each value from the grid time nearest the instant it was
    issued, a tie to the later): (n,) values and (n,) the instant each change was issued relative to its grid
    time, s (NaN where nothing changed). Changes are found every ``resolution_s`` and located by bisection."""
    fine = np.arange(int(round((n - 1) * period_s / resolution_s)) + 1) * resolution_s
    values = np.array([command(t) for t in fine])
    grid_values = np.full(n, values[0])
    switch = np.full(n, np.nan)
    for k in np.flatnonzero(values[1:] != values[:-1]):
        early, late = fine[k], fine[k + 1]  # the old value at early, the new at late
        for _ in range(40):
            middle = 0.5 * (early + late)
            early, late = (middle, late) if command(middle) == values[k] else (early, middle)
        sample = int(math.floor(late / period_s + 0.5))  # the grid time nearest the change, a tie to the later
        if sample < n:
            grid_values[sample:] = values[k + 1]
            switch[sample] = late - sample * period_s
    return grid_values, switch
