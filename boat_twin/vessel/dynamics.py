"""3-DOF maneuvering model (surge, sway, yaw) of a twin-outboard boat, stepped with fixed-step RK4.

State per boat, SI: ``[east_m, north_m, yaw_rad, u_mps, v_mps, r_radps]`` — position in the ENU world frame,
ENU yaw, and the body-frame (FLU) velocity *through the water* (u forward, v to port) and yaw rate.
Commands per boat: ``[thrust_left_N, thrust_right_N, angle_left_rad, angle_right_rad]`` (the VRX convention).
In a constant, irrotational current the rigid-body and added-mass terms can be written in the relative
velocity alone (Fossen 2011, Property 8.1), so::

    m11·u̇ = X + m22·v·r − Fc(u)
    m22·v̇ = Y − m11·u·r − a_v·|u|·v − Y_vv·|v|·v
    m33·ṙ = N − (m22 − m11)·u·v − x_c·a_v·|u|·v − a_r·|u|·r − N_rr·|r|·r
    ė = u·cos ψ − v·sin ψ + c_e,   ṅ = u·sin ψ + v·cos ψ + c_n,   ψ̇ = r

with the outboards' thrust vectors (thrust T_i at steering angle δ_i, at (x_e, ±y_e)) plus the wind's::

    X = Σ T_i·cos δ_i + X_w,   Y = Σ T_i·sin δ_i + Y_w,   N = Σ (x_e·T_i·sin δ_i − y_i·T_i·cos δ_i) + x_w·Y_w

Delivered thrust is the engine's factor k_i times the command limited to the engine's envelope: astern down to
−k·T_bollard, ahead up to min(T_bollard, η·P/|u|). The outboards swing at a finite rate: each real steering
angle δ_i is an actuator state that moves towards its target (the command plus a constant offset, limited to
±δ_max) at the steering rate ρ and stops there, δ_i(t + τ) = δ_i + clip(target − δ_i, −ρτ, ρτ) under a held
command — solved exactly inside every RK4 stage, so the actuator runs at the integration rate (ρ = 0: the
angle is the target at once). The wind force is quadratic drag on the above-water areas in the apparent wind
(u_a, v_a) (body frame, air relative to the hull): X_w = ½ρ_a·C_a·A_F·(|V_a|·u_a + |V|·u), Y_w likewise with
A_L and v, acting at x_w (the centre of windage); the |V|·u term removes the calm-air drag the measured
resistance already holds, so the wind force vanishes in calm air and still water.
Fc(u) is any :class:`~boat_twin.vessel.resistance.ResistanceModel`, tabulated on a fine uniform grid for the
compiled kernel (linear interpolation, quadratic tail as the model itself).
The kernel steps N boats at once (an ensemble), compiled with numba; the boats share one design, or each has
its own sway/yaw coefficients (``Dynamics(..., boats=...)``: a training set of perturbed boats in one run).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass

import numba
import numpy as np

from boat_twin.threads import configure_openmp
from boat_twin.units import AIR_DENSITY_KGPM3, SEAWATER_DENSITY_KGPM3
from boat_twin.vessel.actuators import (
    COMMAND_MAPS,
    SLIPSTREAM_KAPPA,
    TABLE_MAX_POINTS,
    Propulsion,
)
from boat_twin.vessel.helms import CompiledHelm, fresh_memory, helm_command
from boat_twin.vessel.params import WINDAGE_DRAG_COEFFICIENT, VesselParams, derive_coefficients
from boat_twin.vessel.steering import steering_target

configure_openmp()  # before the first parallel kernel loads the OpenMP runtime: idle threads sleep, never spin

RESISTANCE_TABLE_POINTS = 4001
"""Grid points of the tabulated resistance over [0, u_max]; linear-interpolation error < 1e-5 of Fc here."""


@dataclass(frozen=True)
class CompiledModel:
    """The numbers the kernel needs: coefficients (see ``_K_*`` indices) and the tabulated resistance."""

    coefficients: np.ndarray
    resistance_N: np.ndarray
    resistance_max_speed_mps: float
    extra_drag_N: np.ndarray


# Indices into CompiledModel.coefficients.
_K_M11, _K_M22, _K_M33, _K_AV, _K_XC, _K_AR, _K_YVV, _K_NRR = range(8)
_K_XE, _K_YE, _K_ETA_P, _K_BOLLARD, _K_REVERSE, _K_MAX_STEER = range(8, 14)
_K_FACTOR_LEFT, _K_FACTOR_RIGHT, _K_STEER_OFFSET, _K_WIND_X, _K_WIND_Y, _K_WIND_XC, _K_STEER_RATE = range(14, 21)
_K_THRUST_TAU = 21
_K_GENERAL = 22
"""0: the default layout (two steerable outboards in N at (x_e, ±y_e): the seed boat's arithmetic, kept bit for
bit); 1: the boat file's thrusters and rudders (:mod:`boat_twin.vessel.actuators`), read from the slots below."""
# Per thruster slot j, at _K_SLOTS + j·_SLOT: present, position, fixed angle, steered, command map, slipstream
# diameter, propeller (K_T coefficients, wake, astern share), thrust table (points, commands, thrusts).
_K_SLOTS = 23
_S_PRESENT, _S_X, _S_Y, _S_ANGLE, _S_STEERED, _S_MAP, _S_DIAMETER = range(7)
_S_KT0, _S_KT1, _S_KT2, _S_WAKE, _S_ASTERN, _S_POINTS, _S_TABLE = range(7, 14)
_SLOT = _S_TABLE + 2 * TABLE_MAX_POINTS
# Per rudder r, at _K_RUDDERS + r·_RUDDER: present, position, ½ρ·A_R·f_α, the washing slot (−1: none), D/span.
_K_RUDDERS = _K_SLOTS + 2 * _SLOT
_R_PRESENT, _R_X, _R_Y, _R_GAIN, _R_WASHED, _R_ETA = range(6)
_RUDDER = 6
_K_SIZE = _K_RUDDERS + 2 * _RUDDER


def resistance_grid_mps(params: VesselParams) -> np.ndarray:
    """Speeds through water at which the kernel tabulates resistance and any extra drag, m/s."""
    return np.linspace(0.0, params.resistance.max_speed_mps, RESISTANCE_TABLE_POINTS)


def compile_model(params: VesselParams, extra_drag_N: np.ndarray | None = None) -> CompiledModel:
    """Derive the coefficients of ``params`` and tabulate its resistance for the kernel.

    ``extra_drag_N`` is an optional additional surge drag (e.g. a towed body) tabulated on the same grid.
    """
    u_max = params.resistance.max_speed_mps
    grid = resistance_grid_mps(params)
    table = np.asarray(params.resistance.force_N(grid), dtype=float)
    extra = np.zeros_like(grid) if extra_drag_N is None else np.asarray(extra_drag_N, dtype=float)
    return CompiledModel(compile_coefficients(params), table, float(u_max), extra)


def compile_coefficients(params: VesselParams) -> np.ndarray:
    """The kernel's coefficient vector of ``params`` (``_K_*`` order)."""
    coeff = derive_coefficients(params)
    return np.array(
        [
            coeff.m11_kg,
            coeff.m22_kg,
            coeff.m33_kgm2,
            coeff.sway_damping_Nspm2,
            coeff.lateral_centre_x_m,
            coeff.yaw_damping_Nms,
            coeff.sway_quadratic_Ns2pm2,
            coeff.yaw_quadratic_Nms2,
            params.engine_x_m,
            params.engine_y_m,
            params.propulsive_efficiency * params.engine_power_W,
            params.bollard_thrust_N,
            params.reverse_thrust_ratio * params.bollard_thrust_N,
            params.max_steering_rad,
            params.thrust_factor_left,
            params.thrust_factor_right,
            params.steering_offset_rad,
            0.5 * AIR_DENSITY_KGPM3 * WINDAGE_DRAG_COEFFICIENT * params.frontal_windage_area_m2,
            0.5 * AIR_DENSITY_KGPM3 * WINDAGE_DRAG_COEFFICIENT * params.lateral_windage_area_m2,
            params.windage_centre_x_m,
            params.steering_rate_radps,
            params.thrust_time_constant_s,
            0.0 if params.propulsion is None else 1.0,
            *_layout_coefficients(params.propulsion),
        ]
    )


def _layout_coefficients(propulsion: Propulsion | None) -> np.ndarray:
    """The slots and rudders of the kernel's coefficient row (``_S_*``, ``_R_*``): zeros for the default layout."""
    out = np.zeros(_K_SIZE - _K_SLOTS)
    if propulsion is None:
        return out
    maps = {name: float(i) for i, name in enumerate(COMMAND_MAPS)}
    for j, thruster in enumerate(propulsion.thrusters):
        slot = out[j * _SLOT:(j + 1) * _SLOT]
        slot[[_S_PRESENT, _S_X, _S_Y, _S_ANGLE, _S_STEERED, _S_MAP, _S_DIAMETER]] = [
            1.0, thruster.x_m, thruster.y_m, thruster.angle_rad, float(thruster.steered), maps[thruster.command],
            thruster.diameter_m]
        if thruster.propeller is not None:
            p = thruster.propeller
            slot[[_S_KT0, _S_KT1, _S_KT2, _S_WAKE, _S_ASTERN]] = [*p.kt, p.wake_fraction, p.astern_ratio]
        if thruster.table is not None:
            points = len(thruster.table.command)
            slot[_S_POINTS] = points
            slot[_S_TABLE:_S_TABLE + points] = thruster.table.command
            slot[_S_TABLE + TABLE_MAX_POINTS:_S_TABLE + TABLE_MAX_POINTS + points] = thruster.table.thrust_N
    names = [t.name for t in propulsion.thrusters]
    base = _K_RUDDERS - _K_SLOTS
    for r, rudder in enumerate(propulsion.rudders):
        washed = -1 if rudder.washed_by is None else names.index(rudder.washed_by)
        diameter = propulsion.thrusters[washed].diameter_m if washed >= 0 else 0.0
        gain = 0.5 * SEAWATER_DENSITY_KGPM3 * rudder.area_m2 * rudder.lift_slope
        out[base + r * _RUDDER:base + (r + 1) * _RUDDER] = [
            1.0, rudder.x_m, rudder.y_m, gain, float(washed), min(1.0, diameter / rudder.span_m)]
    return out


@numba.njit(cache=True)
def _resistance(u: float, table: np.ndarray, u_max: float) -> float:
    """Tabulated Fc(u): linear on [0, u_max], quadratic beyond, odd in u."""
    a = abs(u)
    if a >= u_max:
        value = table[-1] * (a / u_max) ** 2
    else:
        x = a / u_max * (table.size - 1)
        i = int(x)
        value = table[i] + (x - i) * (table[i + 1] - table[i])
    return value if u >= 0.0 else -value


@numba.njit(cache=True)
def _delivered_thrust(command: float, u: float, k: np.ndarray) -> float:
    """Commanded thrust limited to the engine envelope at speed through water u."""
    ahead = k[_K_BOLLARD]
    if abs(u) > 1e-9:
        ahead = min(ahead, k[_K_ETA_P] / abs(u))
    return min(max(command, -k[_K_REVERSE]), ahead)


@numba.njit(cache=True)
def _slot_thrust(j: int, command: float, u_p: float, k: np.ndarray) -> float:
    """Thrust of slot ``j``'s thruster under ``command`` (after the lag) at the surge through the water at the
    thruster ``u_p``, N, before its thrust factor: its command map (:mod:`boat_twin.vessel.actuators`; the numpy
    copy is :func:`boat_twin.vessel.propulsion.thruster_thrust_N`)."""
    base = _K_SLOTS + j * _SLOT
    kind = k[base + _S_MAP]
    if kind == 0.0:
        return _delivered_thrust(command, u_p, k)
    if kind == 1.0:
        points = int(k[base + _S_POINTS])
        xs = k[base + _S_TABLE:base + _S_TABLE + points]
        ys = k[base + _S_TABLE + TABLE_MAX_POINTS:base + _S_TABLE + TABLE_MAX_POINTS + points]
        return np.interp(command, xs, ys)
    if abs(command) <= 1e-9:
        return 0.0
    d = k[base + _S_DIAMETER]
    j_advance = (1.0 - k[base + _S_WAKE]) * u_p / (abs(command) * d)
    kt = k[base + _S_KT0] + k[base + _S_KT1] * j_advance + k[base + _S_KT2] * j_advance * j_advance
    thrust = SEAWATER_DENSITY_KGPM3 * command * abs(command) * d**4 * kt
    return thrust if command >= 0.0 else k[base + _S_ASTERN] * thrust


@numba.njit(cache=True)
def _thrust_command(j: int, thrust_N: float, u_p: float, k: np.ndarray) -> float:
    """The command of slot ``j``'s thruster that asks for ``thrust_N`` at the surge ``u_p`` (its map read
    backwards): N itself; the table read from thrust to command; the shaft speed n solving
    ρ·D⁴·(k₀·n² + k₁·n·V_A/D + k₂·V_A²/D²) = T (ahead; astern at rest, with its astern share), rev/s."""
    base = _K_SLOTS + j * _SLOT
    kind = k[base + _S_MAP]
    if kind == 0.0:
        return thrust_N
    if kind == 1.0:
        points = int(k[base + _S_POINTS])
        xs = k[base + _S_TABLE:base + _S_TABLE + points]
        ys = k[base + _S_TABLE + TABLE_MAX_POINTS:base + _S_TABLE + TABLE_MAX_POINTS + points]
        return np.interp(thrust_N, ys, xs)
    d = k[base + _S_DIAMETER]
    scale = SEAWATER_DENSITY_KGPM3 * d**4
    if thrust_N < 0.0:
        return -np.sqrt(-thrust_N / (scale * k[base + _S_KT0] * k[base + _S_ASTERN]))
    advance = (1.0 - k[base + _S_WAKE]) * max(u_p, 0.0) / d
    a, b, c = k[base + _S_KT0], k[base + _S_KT1] * advance, k[base + _S_KT2] * advance * advance - thrust_N / scale
    return (-b + np.sqrt(max(b * b - 4.0 * a * c, 0.0))) / (2.0 * a)


@numba.njit(cache=True)
def _layout_command(demand: np.ndarray, u: float, k: np.ndarray, out: np.ndarray) -> None:
    """A scenario's demand — thrust per outboard (N) and steering angle (rad) of the default layout — as this
    boat's four commands into ``out`` (4,) at its surge ``u``: a single thruster takes both outboards' thrust; a
    boat with no steering input turns by differential thrust (the steering angle as a share s = δ/δ_max of the
    mean thrust, added on the side that turns the bow like the angle would, s = 1 at full steering); each
    thrust becomes its thruster's command (:func:`_thrust_command`). The default layout: the demand itself."""
    if k[_K_GENERAL] == 0.0:
        out[:] = demand
        return
    left, right, angle_left, angle_right = demand[0], demand[1], demand[2], demand[3]
    second = _K_SLOTS + _SLOT
    if k[second + _S_PRESENT] == 0.0:
        left, right = left + right, 0.0
    elif k[_K_SLOTS + _S_STEERED] == 0.0 and k[second + _S_STEERED] == 0.0 and k[_K_RUDDERS + _R_PRESENT] == 0.0:
        share = min(max(angle_left / k[_K_MAX_STEER], -1.0), 1.0) if k[_K_MAX_STEER] > 0.0 else 0.0
        if k[_K_SLOTS + _S_Y] < k[second + _S_Y]:  # the first thruster is the starboard one
            share = -share
        mean, half_difference = 0.5 * (left + right), 0.5 * (left - right)
        left, right = mean * (1.0 + share) + half_difference, mean * (1.0 - share) - half_difference
        angle_left = angle_right = 0.0
    out[0] = _thrust_command(0, left, u, k)
    out[1] = _thrust_command(1, right, u, k) if k[second + _S_PRESENT] != 0.0 else 0.0
    out[2] = angle_left
    out[3] = angle_right


@numba.njit(cache=True)
def _layout_commands(demands: np.ndarray, surge: np.ndarray, k: np.ndarray, out: np.ndarray) -> None:
    """:func:`_layout_command` of each row of ``demands`` (n, 4) at ``surge`` (n,)."""
    for i in range(demands.shape[0]):
        _layout_command(demands[i], surge[i], k, out[i])


@numba.njit(cache=True)
def _layout_forces(u: float, v: float, r: float, thrust_left: float, thrust_right: float, d_left: float,
                   d_right: float, k: np.ndarray, out: np.ndarray) -> None:
    """Surge and sway force and yaw moment (N, N, N·m) of a boat file's thrusters and rudders into ``out`` (3,):
    each thruster's thrust along its direction (its steering angle, or its fixed angle), each rudder's normal
    force from its inflow (the hull's velocity at the rudder, and the slipstream of the thruster that washes it;
    module docstring of :mod:`boat_twin.vessel.actuators`)."""
    commands = (thrust_left, thrust_right)
    angles = (d_left, d_right)
    thrusts = np.zeros(2)
    out[:] = 0.0
    for j in range(2):
        base = _K_SLOTS + j * _SLOT
        if k[base + _S_PRESENT] == 0.0:
            continue
        x, y = k[base + _S_X], k[base + _S_Y]
        factor = k[_K_FACTOR_LEFT] if j == 0 else k[_K_FACTOR_RIGHT]
        thrusts[j] = factor * _slot_thrust(j, commands[j], u - y * r, k)
        direction = angles[j] if k[base + _S_STEERED] == 1.0 else k[base + _S_ANGLE]
        fx, fy = thrusts[j] * np.cos(direction), thrusts[j] * np.sin(direction)
        out[0] += fx
        out[1] += fy
        out[2] += x * fy - y * fx
    for i in range(2):
        base = _K_RUDDERS + i * _RUDDER
        if k[base + _R_PRESENT] == 0.0:
            continue
        x, y = k[base + _R_X], k[base + _R_Y]
        u_r, v_r = u - y * r, v + x * r
        washed = int(k[base + _R_WASHED])
        if washed >= 0 and thrusts[washed] > 0.0:
            d = k[_K_SLOTS + washed * _SLOT + _S_DIAMETER]
            far = np.sqrt(u_r * u_r + 8.0 * thrusts[washed] / (SEAWATER_DENSITY_KGPM3 * np.pi * d * d))
            eta = k[base + _R_ETA]
            wash = abs(u_r) + SLIPSTREAM_KAPPA * (far - abs(u_r))
            u_r = np.sqrt(eta * wash * wash + (1.0 - eta) * u_r * u_r)
        delta = angles[i]
        attack = delta - np.arctan2(v_r, u_r) if u_r >= 0.0 else delta - np.arctan2(-v_r, -u_r)
        normal = k[base + _R_GAIN] * (u_r * u_r + v_r * v_r) * np.sin(attack)
        if u_r < 0.0:  # astern the water meets the rudder's trailing edge: the force turns the other way
            normal = -normal
        fx, fy = -normal * np.sin(delta), normal * np.cos(delta)
        out[0] += fx
        out[1] += fy
        out[2] += x * fy - y * fx


@numba.njit(cache=True)
def _steering_target(command: float, k: np.ndarray) -> float:
    """Where the outboard is driven: the commanded angle plus the offset, within ±δ_max, rad (the kernel's copy
    of :func:`~boat_twin.vessel.steering.steering_target`; test_steering.py checks they agree)."""
    return min(max(command + k[_K_STEER_OFFSET], -k[_K_MAX_STEER]), k[_K_MAX_STEER])


@numba.njit(cache=True)
def _steering_after(angle: float, target: float, k: np.ndarray, tau: float) -> float:
    """The steering angle ``tau`` seconds on, swinging from ``angle`` towards ``target`` at the rate limit (the
    kernel's copy of :func:`~boat_twin.vessel.steering.steering_after`)."""
    rate = k[_K_STEER_RATE]
    if rate <= 0.0:
        return target
    reach = rate * tau
    return angle + min(max(target - angle, -reach), reach)


@numba.njit(cache=True)
def _thrust_after(thrust: float, target: float, k: np.ndarray, tau: float) -> float:
    """An engine's thrust command ``tau`` seconds on, approaching ``target`` with the first-order lag's time
    constant (0: at once), N."""
    constant = k[_K_THRUST_TAU]
    if constant <= 0.0:
        return target
    return target + (thrust - target) * np.exp(-tau / constant)


@numba.njit(cache=True)
def _derivative(
    s: np.ndarray,
    thrust_left: float,
    thrust_right: float,
    d_left: float,
    d_right: float,
    k: np.ndarray,
    table: np.ndarray,
    u_max: float,
    extra: np.ndarray,
    env: np.ndarray,
    out: np.ndarray,
) -> None:
    """Time derivative of one boat's state ``s`` under the engines' thrust commands ``thrust_left``,
    ``thrust_right`` (N, after the lag) and real steering angles ``d_left``, ``d_right`` (rad), written into
    ``out``."""
    psi, u, v, r = s[2], s[3], s[4], s[5]
    if k[_K_GENERAL] == 0.0:
        t_left = k[_K_FACTOR_LEFT] * _delivered_thrust(thrust_left, u, k)
        t_right = k[_K_FACTOR_RIGHT] * _delivered_thrust(thrust_right, u, k)
        x_force = t_left * np.cos(d_left) + t_right * np.cos(d_right)
        y_force = t_left * np.sin(d_left) + t_right * np.sin(d_right)
        n_moment = k[_K_XE] * y_force - k[_K_YE] * (t_left * np.cos(d_left) - t_right * np.cos(d_right))
    else:
        forces = np.empty(3)
        _layout_forces(u, v, r, thrust_left, thrust_right, d_left, d_right, k, forces)
        x_force, y_force, n_moment = forces[0], forces[1], forces[2]
    c, sn = np.cos(psi), np.sin(psi)
    # Apparent wind in the body frame: wind over ground minus the hull's velocity over ground.
    air_east = env[2] - (u * c - v * sn + env[0])
    air_north = env[3] - (u * sn + v * c + env[1])
    u_air = air_east * c + air_north * sn
    v_air = -air_east * sn + air_north * c
    air_speed = np.sqrt(u_air * u_air + v_air * v_air)
    calm_speed = np.sqrt(u * u + v * v)
    # Minus the calm-air drag at the speed through water: the measured resistance Fc(u) already holds it.
    x_wind = k[_K_WIND_X] * (air_speed * u_air + calm_speed * u)
    y_wind = k[_K_WIND_Y] * (air_speed * v_air + calm_speed * v)
    x_force += x_wind
    y_force += y_wind
    n_moment += k[_K_WIND_XC] * y_wind
    m11, m22, m33 = k[_K_M11], k[_K_M22], k[_K_M33]
    drag = _resistance(u, table, u_max) + _resistance(u, extra, u_max)
    out[3] = (x_force + m22 * v * r - drag) / m11
    out[4] = (y_force - m11 * u * r - k[_K_AV] * abs(u) * v - k[_K_YVV] * abs(v) * v) / m22
    out[5] = (
        n_moment
        - (m22 - m11) * u * v
        - k[_K_XC] * k[_K_AV] * abs(u) * v
        - k[_K_AR] * abs(u) * r
        - k[_K_NRR] * abs(r) * r
    ) / m33
    out[0] = u * c - v * sn + env[0]
    out[1] = u * sn + v * c + env[1]
    out[2] = r


@numba.njit(cache=True)
def _step_boat(
    s: np.ndarray,
    steer: np.ndarray,
    thrust: np.ndarray,
    cmd: np.ndarray,
    k: np.ndarray,
    table: np.ndarray,
    u_max: float,
    extra: np.ndarray,
    env: np.ndarray,
    dt: float,
    substeps: int,
) -> None:
    """Advance one boat's state ``s``, steering angles ``steer`` (2,) and thrust commands ``thrust`` (2,) in
    place by ``substeps`` RK4 steps of ``dt`` under a held command; every stage sees the actuators of its own
    instant."""
    k1 = np.empty(6)
    k2 = np.empty(6)
    k3 = np.empty(6)
    k4 = np.empty(6)
    tmp = np.empty(6)
    target_left = _steering_target(cmd[2], k)
    target_right = _steering_target(cmd[3], k)
    for _ in range(substeps):
        half_left = _steering_after(steer[0], target_left, k, 0.5 * dt)
        half_right = _steering_after(steer[1], target_right, k, 0.5 * dt)
        end_left = _steering_after(steer[0], target_left, k, dt)
        end_right = _steering_after(steer[1], target_right, k, dt)
        half_tl = _thrust_after(thrust[0], cmd[0], k, 0.5 * dt)
        half_tr = _thrust_after(thrust[1], cmd[1], k, 0.5 * dt)
        end_tl = _thrust_after(thrust[0], cmd[0], k, dt)
        end_tr = _thrust_after(thrust[1], cmd[1], k, dt)
        _derivative(s, thrust[0], thrust[1], steer[0], steer[1], k, table, u_max, extra, env, k1)
        for j in range(6):
            tmp[j] = s[j] + 0.5 * dt * k1[j]
        _derivative(tmp, half_tl, half_tr, half_left, half_right, k, table, u_max, extra, env, k2)
        for j in range(6):
            tmp[j] = s[j] + 0.5 * dt * k2[j]
        _derivative(tmp, half_tl, half_tr, half_left, half_right, k, table, u_max, extra, env, k3)
        for j in range(6):
            tmp[j] = s[j] + dt * k3[j]
        _derivative(tmp, end_tl, end_tr, end_left, end_right, k, table, u_max, extra, env, k4)
        for j in range(6):
            s[j] += dt / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
        steer[0] = end_left
        steer[1] = end_right
        thrust[0] = end_tl
        thrust[1] = end_tr


@numba.njit(cache=True)
def _start_step(steer: np.ndarray, thrust: np.ndarray, cmd: np.ndarray, k: np.ndarray) -> None:
    """One boat's outboard angles (left, right) and thrust commands at the first instant under ``cmd``: an
    instantaneous actuator (rate 0, lag 0) is already at the new command; a rate-limited or lagging one has not
    moved yet."""
    steer[0] = _steering_after(steer[0], _steering_target(cmd[2], k), k, 0.0)
    steer[1] = _steering_after(steer[1], _steering_target(cmd[3], k), k, 0.0)
    thrust[0] = _thrust_after(thrust[0], cmd[0], k, 0.0)
    thrust[1] = _thrust_after(thrust[1], cmd[1], k, 0.0)


@numba.njit(cache=True)
def _segment(
    s: np.ndarray,
    steer: np.ndarray,
    thrust: np.ndarray,
    cmd: np.ndarray,
    k: np.ndarray,
    table: np.ndarray,
    u_max: float,
    extra: np.ndarray,
    env: np.ndarray,
    dt: float,
    length: float,
) -> None:
    """Advance one boat over ``length`` seconds under ``cmd``, in RK4 steps of at most ``dt``."""
    if length <= 0.0:
        return
    steps = max(1, int(np.ceil(length / dt - 1e-9)))
    _start_step(steer, thrust, cmd, k)
    _step_boat(s, steer, thrust, cmd, k, table, u_max, extra, env, length / steps, steps)


@numba.njit(cache=True)
def _boat_ticks(
    b: int,
    states: np.ndarray,
    steering: np.ndarray,
    thrust: np.ndarray,
    commands: np.ndarray,
    switch: np.ndarray,
    before: np.ndarray,
    coefficients: np.ndarray,
    table: np.ndarray,
    u_max: float,
    extra: np.ndarray,
    environments: np.ndarray,
    dt: float,
    substeps: int,
    out_states: np.ndarray,
    out_derivatives: np.ndarray,
    out_steering: np.ndarray,
) -> None:
    """Boat ``b``'s output ticks: at each tick i record its state, steering and derivative under the command
    in force, then step the tick. ``coefficients`` has one row per boat, or one row for all.

    ``switch[i, b]``, s: ``commands[i]`` takes over at tick i's time plus this (the previous command, ``before``
    for tick 0, holds until then when it is positive; when it is negative, ``commands[i]`` already took over
    that long before the tick, within tick i − 1). 0 everywhere: every command acts over its own tick (then the
    arithmetic is exactly that of a run without switch times)."""
    k = coefficients[0] if coefficients.shape[0] == 1 else coefficients[b]  # (prange's b is unsigned)
    tick = dt * substeps
    ticks = commands.shape[0]
    for i in range(ticks):
        late = min(max(switch[i, b], 0.0), tick)
        early = min(max(switch[i + 1, b], -tick), 0.0) if i + 1 < ticks else 0.0
        previous = before[b] if i == 0 else commands[i - 1, b]
        if late == 0.0 and early == 0.0:
            _start_step(steering[b], thrust[b], commands[i, b], k)
            out_states[i, b] = states[b]
            out_steering[i, b] = steering[b]
            _derivative(states[b], thrust[b, 0], thrust[b, 1], steering[b, 0], steering[b, 1], k, table, u_max,
                        extra, environments[b], out_derivatives[i, b])
            _step_boat(states[b], steering[b], thrust[b], commands[i, b], k, table, u_max, extra, environments[b],
                       dt, substeps)
            continue
        first = previous if late > 0.0 else commands[i, b]
        _start_step(steering[b], thrust[b], first, k)
        out_states[i, b] = states[b]
        out_steering[i, b] = steering[b]
        _derivative(states[b], thrust[b, 0], thrust[b, 1], steering[b, 0], steering[b, 1], k, table, u_max,
                    extra, environments[b], out_derivatives[i, b])
        _segment(states[b], steering[b], thrust[b], previous, k, table, u_max, extra, environments[b], dt, late)
        _segment(states[b], steering[b], thrust[b], commands[i, b], k, table, u_max, extra, environments[b], dt,
                 tick + early - late)
        if i + 1 < ticks:
            _segment(states[b], steering[b], thrust[b], commands[i + 1, b], k, table, u_max, extra,
                     environments[b], dt, -early)


@numba.njit(cache=True)
def _actuator_history(commands: np.ndarray, switch: np.ndarray, k: np.ndarray, tick: float, out: np.ndarray
                      ) -> None:
    """(n, 4) into ``out``: the outboards' real angles (left, right) and thrust commands after the lag (left,
    right) at every tick of a recorded command series (n, 4) with its switch times (n,) (as
    :func:`_boat_ticks`'s), starting where the first known command drives them; NaN after an unknown command
    (the next known command starts afresh at its own)."""
    state = np.full(4, np.nan)
    previous = np.full(4, np.nan)
    n = commands.shape[0]
    for i in range(n):
        cmd = commands[i]
        known = True
        for j in range(4):
            if not np.isfinite(cmd[j]):
                known = False
        if not known:  # its start is known; what follows an unknown command is not
            out[i] = state
            state[:] = np.nan
            previous[:] = np.nan
            continue
        if not np.isfinite(state[0]):
            state[0] = _steering_target(cmd[2], k)
            state[1] = _steering_target(cmd[3], k)
            state[2] = cmd[0]
            state[3] = cmd[1]
            previous[:] = cmd
        late = min(max(switch[i], 0.0), tick)
        early = min(max(switch[i + 1], -tick), 0.0) if i + 1 < n and np.isfinite(commands[i + 1, 0]) else 0.0
        first = previous if late > 0.0 else cmd
        state[0] = _steering_after(state[0], _steering_target(first[2], k), k, 0.0)
        state[1] = _steering_after(state[1], _steering_target(first[3], k), k, 0.0)
        state[2] = _thrust_after(state[2], first[0], k, 0.0)
        state[3] = _thrust_after(state[3], first[1], k, 0.0)
        out[i] = state
        for part in range(3):
            use = previous if part == 0 else (cmd if part == 1 else commands[min(i + 1, n - 1)])
            length = late if part == 0 else (tick + early - late if part == 1 else -early)
            if length <= 0.0:
                continue
            state[0] = _steering_after(state[0], _steering_target(use[2], k), k, length)
            state[1] = _steering_after(state[1], _steering_target(use[3], k), k, length)
            state[2] = _thrust_after(state[2], use[0], k, length)
            state[3] = _thrust_after(state[3], use[1], k, length)
        previous[:] = cmd


@numba.njit(cache=True)
def _run_ticks(
    states: np.ndarray,
    steering: np.ndarray,
    thrust: np.ndarray,
    commands: np.ndarray,
    switch: np.ndarray,
    before: np.ndarray,
    coefficients: np.ndarray,
    table: np.ndarray,
    u_max: float,
    extra: np.ndarray,
    environments: np.ndarray,
    dt: float,
    substeps: int,
    out_states: np.ndarray,
    out_derivatives: np.ndarray,
    out_steering: np.ndarray,
) -> None:
    """:func:`_boat_ticks` of every boat, one after another."""
    for b in range(states.shape[0]):
        _boat_ticks(b, states, steering, thrust, commands, switch, before, coefficients, table, u_max, extra,
                    environments, dt, substeps, out_states, out_derivatives, out_steering)


@numba.njit(cache=True, parallel=True)
def _run_ticks_parallel(
    states: np.ndarray,
    steering: np.ndarray,
    thrust: np.ndarray,
    commands: np.ndarray,
    switch: np.ndarray,
    before: np.ndarray,
    coefficients: np.ndarray,
    table: np.ndarray,
    u_max: float,
    extra: np.ndarray,
    environments: np.ndarray,
    dt: float,
    substeps: int,
    out_states: np.ndarray,
    out_derivatives: np.ndarray,
    out_steering: np.ndarray,
) -> None:
    """:func:`_run_ticks` with the boats shared among numba's threads (each boat's arithmetic is the same)."""
    for b in numba.prange(states.shape[0]):
        _boat_ticks(b, states, steering, thrust, commands, switch, before, coefficients, table, u_max, extra,
                    environments, dt, substeps, out_states, out_derivatives, out_steering)


@numba.njit(cache=True)
def _boat_step(
    b: int,
    states: np.ndarray,
    steering: np.ndarray,
    thrust: np.ndarray,
    commands: np.ndarray,
    coefficients: np.ndarray,
    table: np.ndarray,
    u_max: float,
    extra: np.ndarray,
    environments: np.ndarray,
    dt: float,
) -> None:
    """Advance boat ``b`` one RK4 step of ``dt`` under its command ``commands[b]``, recording nothing."""
    k = coefficients[0] if coefficients.shape[0] == 1 else coefficients[b]  # (prange's b is unsigned)
    _start_step(steering[b], thrust[b], commands[b], k)
    _step_boat(states[b], steering[b], thrust[b], commands[b], k, table, u_max, extra, environments[b], dt, 1)


@numba.njit(cache=True)
def _step_all(
    states: np.ndarray,
    steering: np.ndarray,
    thrust: np.ndarray,
    commands: np.ndarray,
    coefficients: np.ndarray,
    table: np.ndarray,
    u_max: float,
    extra: np.ndarray,
    environments: np.ndarray,
    dt: float,
) -> None:
    """:func:`_boat_step` of every boat, one after another."""
    for b in range(states.shape[0]):
        _boat_step(b, states, steering, thrust, commands, coefficients, table, u_max, extra, environments, dt)


@numba.njit(cache=True, parallel=True)
def _step_all_parallel(
    states: np.ndarray,
    steering: np.ndarray,
    thrust: np.ndarray,
    commands: np.ndarray,
    coefficients: np.ndarray,
    table: np.ndarray,
    u_max: float,
    extra: np.ndarray,
    environments: np.ndarray,
    dt: float,
) -> None:
    """:func:`_step_all` with the boats shared among numba's threads."""
    for b in numba.prange(states.shape[0]):
        _boat_step(b, states, steering, thrust, commands, coefficients, table, u_max, extra, environments, dt)


@numba.njit(cache=True)
def _observe_sway_boat(
    b: int,
    start: np.ndarray,
    vessel: np.ndarray,
    lags: int,
    heading: np.ndarray,
    surge: np.ndarray,
    yaw_rate: np.ndarray,
    acting: np.ndarray,
    switch: np.ndarray,
    actuators: np.ndarray,
    coefficients: np.ndarray,
    table: np.ndarray,
    u_max: float,
    extra: np.ndarray,
    environments: np.ndarray,
    dt: float,
    out: np.ndarray,
) -> None:
    """Boat ``b``'s sway observer (:meth:`Dynamics.observe_sway`): from rest at sample ``start[b] - lags``, each
    sample one tick of :func:`_boat_ticks` (its command ``acting[i]`` from ``switch[i]`` after the sample, the
    previous before it, the next from ``switch[i + 1]`` when negative) from the measured heading, surge and yaw
    rate with the observer's sway, keeping the sway it ends with when finite and the sample is in the trial."""
    k = coefficients[0] if coefficients.shape[0] == 1 else coefficients[b]  # (prange's b is unsigned)
    env = environments[0] if environments.shape[0] == 1 else environments[b]
    last = acting.shape[0] - 1
    s = np.empty(6)
    steer = np.empty(2)
    thrust = np.empty(2)
    sway = 0.0
    for lag in range(lags, 0, -1):
        index = start[b] - lag
        inside = index >= 0
        index = max(index, 0)
        following = min(index + 1, last)
        cmd = acting[index]
        previous = acting[max(index - 1, 0)]
        s[0] = 0.0
        s[1] = 0.0
        s[2] = heading[index]
        s[3] = surge[index]
        s[4] = sway
        s[5] = yaw_rate[index]
        known = actuators[index, vessel[b]]
        for j in range(2):
            steer[j] = known[j] if np.isfinite(known[j]) else _steering_target(cmd[2 + j], k)
            thrust[j] = known[2 + j] if np.isfinite(known[2 + j]) else cmd[j]
        late = min(max(switch[index], 0.0), dt)
        early = min(max(switch[following], -dt), 0.0)
        if late == 0.0 and early == 0.0:
            _start_step(steer, thrust, cmd, k)
            _step_boat(s, steer, thrust, cmd, k, table, u_max, extra, env, dt, 1)
        else:
            _start_step(steer, thrust, previous if late > 0.0 else cmd, k)
            _segment(s, steer, thrust, previous, k, table, u_max, extra, env, dt, late)
            _segment(s, steer, thrust, cmd, k, table, u_max, extra, env, dt, dt + early - late)
            _segment(s, steer, thrust, acting[following], k, table, u_max, extra, env, dt, -early)
        if inside and np.isfinite(s[4]):
            sway = s[4]
    out[b] = sway


@numba.njit(cache=True, parallel=True)
def _observe_sway_parallel(
    start: np.ndarray,
    vessel: np.ndarray,
    lags: int,
    heading: np.ndarray,
    surge: np.ndarray,
    yaw_rate: np.ndarray,
    acting: np.ndarray,
    switch: np.ndarray,
    actuators: np.ndarray,
    coefficients: np.ndarray,
    table: np.ndarray,
    u_max: float,
    extra: np.ndarray,
    environments: np.ndarray,
    dt: float,
    out: np.ndarray,
) -> None:
    """:func:`_observe_sway_boat` of every boat, shared among numba's threads (one thread: the same loop)."""
    for b in numba.prange(start.shape[0]):
        _observe_sway_boat(b, start, vessel, lags, heading, surge, yaw_rate, acting, switch, actuators,
                           coefficients, table, u_max, extra, environments, dt, out)


@numba.njit(cache=True)
def _step_time(n: int, substeps: int, output_rate: float, dt: float) -> float:
    """Time of global integration step ``n``, s: its output tick's time plus its substeps (as the Python step loop
    of ``vessel.simulate`` computes it, so the helms see the same floats)."""
    return (n // substeps) / output_rate + (n % substeps) * dt


@numba.njit(cache=True)
def _acting_lags(first_step: int, steps: int, substeps: int, output_rate: float, dt: float, delay: float,
                 out: np.ndarray) -> None:
    """For each of ``steps`` integration steps from global step ``first_step``: how many steps back the command
    acting on the outboards was issued (the last issued at least ``delay`` s before the step; 0 without a
    delay), or -1 when none was issued that early yet (then the first command acts: the boat was held there)."""
    for i in range(steps):
        n = first_step + i
        due = _step_time(n, substeps, output_rate, dt) - delay + 1e-9
        m = n
        while m >= 0 and not _step_time(m, substeps, output_rate, dt) <= due:
            m -= 1
        out[i] = n - m if m >= 0 else -1


@numba.njit(cache=True)
def _closed_loop_boat(
    b: int,
    states: np.ndarray,
    steering: np.ndarray,
    thrust: np.ndarray,
    kind: int,
    helm_parameters: np.ndarray,
    memory: np.ndarray,
    history: np.ndarray,
    last: np.ndarray,
    changed: np.ndarray,
    first_tick: int,
    lags: np.ndarray,
    coefficients: np.ndarray,
    table: np.ndarray,
    u_max: float,
    extra: np.ndarray,
    environments: np.ndarray,
    dt: float,
    substeps: int,
    output_rate: float,
    reference_surge: float,
    out_states: np.ndarray,
    out_derivatives: np.ndarray,
    out_steering: np.ndarray,
    out_commands: np.ndarray,
    out_issued: np.ndarray,
) -> None:
    """Boat ``b`` under its compiled helm for ``out_states.shape[0]`` output ticks from ``first_tick``: at every
    integration step the helm decides (:func:`~boat_twin.vessel.helms.helm_command`), the command issued
    ``lags`` steps back acts (``history``: a ring of the issued commands), and one RK4 step follows; at each tick
    the state, steering, derivative, the issued command and when it was issued (``changed``: when the helm last
    changed it) are recorded. The arithmetic and order are those of the Python step loop of ``vessel.simulate``
    (``test/test_helms.py`` checks them bit for bit)."""
    k = coefficients[0] if coefficients.shape[0] == 1 else coefficients[b]  # (prange's b is unsigned)
    ring = history.shape[1]
    command = np.empty(4)
    for i in range(out_states.shape[0]):
        tick = first_tick + i
        t = tick / output_rate
        for j in range(substeps):
            n = tick * substeps + j
            now_s = t + j * dt
            helm_command(kind, helm_parameters, now_s, states[b], memory[b], command)
            if k[_K_GENERAL] != 0.0:  # the helm's demand as this boat's commands, read at the run's reference surge
                _layout_command(command.copy(), reference_surge, k, command)
            differs = n == 0
            for c in range(4):
                if command[c] != last[b, c]:
                    differs = True
                last[b, c] = command[c]
                history[b, n % ring, c] = command[c]
            if differs:
                changed[b] = now_s
            lag = lags[i * substeps + j]
            acting = command if lag < 0 else history[b, (n - lag) % ring]
            if n == 0:  # the outboards and engines start where the first command holds them
                steering[b, 0] = _steering_target(acting[2], k)
                steering[b, 1] = _steering_target(acting[3], k)
                thrust[b, 0] = acting[0]
                thrust[b, 1] = acting[1]
            _start_step(steering[b], thrust[b], acting, k)
            if j == 0:
                out_states[i, b] = states[b]
                out_steering[i, b] = steering[b]
                _derivative(states[b], thrust[b, 0], thrust[b, 1], steering[b, 0], steering[b, 1], k, table, u_max,
                            extra, environments[b], out_derivatives[i, b])
                out_commands[i, b] = command
                out_issued[i, b] = changed[b] if changed[b] > t - 1.0 / output_rate + 1e-9 else t
            _step_boat(states[b], steering[b], thrust[b], acting, k, table, u_max, extra, environments[b], dt, 1)


@numba.njit(cache=True, parallel=True)
def _closed_loop_parallel(
    states: np.ndarray, steering: np.ndarray, thrust: np.ndarray, kind: int, helm_parameters: np.ndarray,
    memory: np.ndarray, history: np.ndarray, last: np.ndarray, changed: np.ndarray, first_tick: int,
    lags: np.ndarray, coefficients: np.ndarray, table: np.ndarray, u_max: float, extra: np.ndarray,
    environments: np.ndarray, dt: float, substeps: int, output_rate: float, reference_surge: float,
    out_states: np.ndarray,
    out_derivatives: np.ndarray, out_steering: np.ndarray, out_commands: np.ndarray, out_issued: np.ndarray,
) -> None:
    """:func:`_closed_loop_boat` of every boat, shared among numba's threads: one parallel region for the whole
    run. Also the one-thread form (numba on one thread): compiled as a parallel loop it runs 1.7x faster than
    the same loop compiled serially (benchmarks/bench_closed_loop.py), since numba compiles a parallel loop's
    body with its arrays marked non-aliasing, which the plain loop cannot be told."""
    for b in numba.prange(states.shape[0]):
        _closed_loop_boat(b, states, steering, thrust, kind, helm_parameters, memory, history, last, changed,
                          first_tick, lags, coefficients, table, u_max, extra, environments, dt, substeps,
                          output_rate, reference_surge, out_states, out_derivatives, out_steering, out_commands,
                          out_issued)


PARALLEL_MIN_BOATS = 64
"""Ensembles of at least this many boats are stepped on numba's threads (one per core). Measured per RK4 step
(benchmarks/bench_simulator.py, idle 2-core machine): 1 boat 2.3 µs threaded against 1.3 µs on one thread,
4 boats 0.86×, 8 boats 1.25× faster, 64 boats 2.9×. On a busy machine the threads compete with the other work
(measured while OpenMP's workers still spun as they waited; they now sleep: boat_twin.threads): with the
threshold at 8 the test suite on both cores (pytest-xdist) took 5:49 and twice the CPU time instead of 2:35, since
the diagnosis replays of 8-60 boats went threaded. 64 keeps the threads to the ensembles where a call's work dwarfs
that (training sets, a fit's batched Jacobian)."""


@dataclass
class ClosedLoopRun:
    """A run of N boats under a compiled helm, carried from one :meth:`Dynamics.run_closed_loop` call to the next
    (a long run in chunks of ticks): the helm, its per-boat memory, the outboards' angles and the engines'
    thrust, the issued commands still to act (a ring of ``ring`` steps), each boat's last command and when it
    changed, s. Made by :meth:`Dynamics.closed_loop`."""

    helm: CompiledHelm
    delay_s: float
    memory: np.ndarray
    steering_rad: np.ndarray
    thrust_N: np.ndarray
    history: np.ndarray
    last_command: np.ndarray
    changed_s: np.ndarray
    next_tick: int = 0
    reference_surge_mps: float = 0.0
    """The surge at which a boat file's thrusters turn the helm's thrust demand into their commands (the
    scenario's initial surge: a constant demand stays a constant command), m/s."""


PRANGE_MIN_BOAT_TICKS = 20
"""Runs of fewer boats × output ticks than this (below :data:`PARALLEL_MIN_BOATS` boats) take the plain serial
kernel: the parallel form, 1.5x faster per boat-tick (1.9 against 2.9 µs of CPU), costs about 6 µs more a call
(a live twin's single tick: 12.6 against 7.0 µs). Measured with ``benchmarks/bench_closed_loop.py --parts open``
(docs/benchmarks.md)."""


@contextmanager
def _threads_for(n_boats: int) -> Iterator[None]:
    """numba's threads (its thread count for this caller) for the block if ``n_boats`` reach
    :data:`PARALLEL_MIN_BOATS`, else one thread: the parallel kernels' one-thread form."""
    threads = numba.get_num_threads()
    numba.set_num_threads(threads if n_boats >= PARALLEL_MIN_BOATS else 1)
    try:
        yield
    finally:
        numba.set_num_threads(threads)


CALL_BOAT_STEPS = 1_000_000
"""Most boats × RK4 steps one compiled call of :meth:`Dynamics.run` takes (about 0.5 s of one core; a larger
ensemble is run in groups of boats): Python acts on Ctrl-C and SIGTERM only between calls, and the diagnosis
replays every window of a trial as one ensemble (a 2-hour trial: 6 s in one call that held the signal)."""
CLOSED_LOOP_CHUNK_BOATS = 16
"""Boats a thread takes at a time from a closed-loop ensemble (numba's dynamic chunks): a thread descheduled by
other work on the cores leaves the rest of its boats to the others, instead of a fixed share that the whole run
waits for."""


class Dynamics:
    """The equations of motion of one boat design, stepping an ensemble of N boats together.

    ``boats``: one vessel per boat of the ensemble instead (e.g. sway/yaw coefficients drawn around ``params``),
    each with the resistance model of ``params`` (the one tabulated); None: every boat is ``params``.
    """

    def __init__(self, params: VesselParams, extra_drag_N: np.ndarray | None = None,
                 boats: Sequence[VesselParams] | None = None) -> None:
        self.params = params
        self.model = compile_model(params, extra_drag_N)
        if boats is not None and any(b.resistance is not params.resistance for b in boats):
            raise ValueError("every boat of the ensemble must share the resistance model of params")
        rows = [self.model.coefficients]
        if boats is not None:  # a vessel given for many boats (each window of a replay): derived once
            compiled = {id(b): compile_coefficients(b) for b in {id(b): b for b in boats}.values()}
            rows = [compiled[id(b)] for b in boats]
        self.coefficients = np.array(rows)
        """(boats or 1, coefficients) rows the kernel reads: one per boat, or one for all."""

    def _check_boats(self, n_boats: int) -> None:
        """The kernel reads one coefficient row for all boats or one per boat: any other count is a caller's
        error (it would read past the rows)."""
        if self.coefficients.shape[0] not in (1, n_boats):
            raise ValueError(f"{n_boats} boats stepped with the coefficients of {self.coefficients.shape[0]}")

    def steering_targets(self, commands: np.ndarray) -> np.ndarray:
        """(N, 2) angles the outboards are driven to under ``commands`` (N, 4): command + offset, within ±δ_max
        (:func:`~boat_twin.vessel.steering.steering_target` with each boat's coefficients)."""
        return steering_target(commands[:, 2:4], self.coefficients[:, _K_STEER_OFFSET, None],
                               self.coefficients[:, _K_MAX_STEER, None])

    def thrust_start(self, commands: np.ndarray) -> np.ndarray:
        """(N, 2) the engines' thrust commands after the lag where ``commands`` (N, 4) has held them: the
        commanded thrust."""
        return np.array(commands[:, :2], dtype=float)

    def layout_commands(self, demands: np.ndarray, surge_mps: np.ndarray | float = 0.0) -> np.ndarray:
        """(n, 4) a scenario's demands (n, 4) — thrust per outboard, N, and steering, rad, of the default layout —
        as this boat's commands at the surge ``surge_mps`` (:func:`_layout_command`; the default layout: the
        demands themselves)."""
        demands = np.ascontiguousarray(demands, dtype=float)
        out = np.empty_like(demands)
        surge = np.broadcast_to(np.asarray(surge_mps, dtype=float), demands.shape[:1]).copy()
        _layout_commands(demands, surge, self.model.coefficients, out)
        return out

    def actuator_history(self, dt_s: float, commands: np.ndarray, switch_s: np.ndarray | None = None
                         ) -> np.ndarray:
        """(n, 4) the outboards' real angles (left, right, rad) and the engines' thrust commands after the lag
        (left, right, N) at each of ``n`` samples ``dt_s`` apart of a recorded command series (n, 4), each held
        from its switch time (``switch_s`` (n,), s after its sample, as :meth:`run`'s; None: at its sample): the
        rate-limited swing towards each target and the first-order lag, starting at the first known command;
        NaN where the commands are unknown (the next known command starts afresh)."""
        commands = np.ascontiguousarray(commands, dtype=float)
        switch = np.zeros(len(commands)) if switch_s is None else np.ascontiguousarray(switch_s, dtype=float)
        out = np.empty((len(commands), 4))
        _actuator_history(commands, switch, self.model.coefficients, float(dt_s), out)
        return out

    def steering_history(self, dt_s: float, commands: np.ndarray, switch_s: np.ndarray | None = None
                         ) -> np.ndarray:
        """(n, 2) the outboards' real angles of :meth:`actuator_history`, rad."""
        return self.actuator_history(dt_s, commands, switch_s)[:, :2]

    def step(self, states: np.ndarray, commands: np.ndarray, environments: np.ndarray, dt_s: float,
             steering_rad: np.ndarray, thrust_N: np.ndarray | None = None) -> None:
        """Advance ``states`` (N, 6), ``steering_rad`` (N, 2) and ``thrust_N`` (N, 2; None: the lag-free engines
        of a boat without one, at ``commands``' thrust) in place by one RK4 step of ``dt_s`` under ``commands``
        (N, 4): :meth:`run` of one tick and one substep without its records (a closed-loop helm's steps between
        output ticks)."""
        m = self.model
        self._check_boats(states.shape[0])
        thrust = self.thrust_start(commands) if thrust_N is None else thrust_N
        kernel = _step_all_parallel if states.shape[0] >= PARALLEL_MIN_BOATS else _step_all
        kernel(states, steering_rad, thrust, commands, self.coefficients, m.resistance_N,
               m.resistance_max_speed_mps, m.extra_drag_N, environments, dt_s)

    def closed_loop(self, helm: CompiledHelm, n_boats: int, delay_s: float, dt_s: float,
                    reference_surge_mps: float = 0.0) -> ClosedLoopRun:
        """A fresh run of ``n_boats`` boats under ``helm``, its commands acting ``delay_s`` late (s), stepped at
        ``dt_s`` (s); its thrust demands read as commands at ``reference_surge_mps`` (:func:`_layout_command`)."""
        self._check_boats(n_boats)
        ring = int(np.ceil(delay_s / dt_s - 1e-9)) + 2
        return ClosedLoopRun(helm, float(delay_s), fresh_memory(n_boats), np.zeros((n_boats, 2)),
                             np.zeros((n_boats, 2)), np.zeros((n_boats, ring, 4)), np.zeros((n_boats, 4)),
                             np.zeros(n_boats), reference_surge_mps=float(reference_surge_mps))

    def run_closed_loop(self, run: ClosedLoopRun, states: np.ndarray, environments: np.ndarray, ticks: int,
                        dt_s: float, substeps: int, output_rate_hz: float
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The next ``ticks`` output ticks (``output_rate_hz``) of ``run``, its helm deciding at every RK4 step of
        ``dt_s`` (``substeps`` per tick) inside the compiled kernel; ``states`` (N, 6) advanced in place.
        Returns, at each tick (ticks, N, ...): the states, their derivatives, the real steering angles, the
        commands issued and when each was issued, s (within the previous tick when the helm changed it between
        ticks), as the Python step loop of ``vessel.simulate`` records them."""
        m = self.model
        n_boats = states.shape[0]
        if run.memory.shape[0] != n_boats:
            raise ValueError(f"this run steers {run.memory.shape[0]} boats, got states of {n_boats}")
        lags = np.empty(ticks * substeps, dtype=np.int64)
        _acting_lags(run.next_tick * substeps, lags.size, substeps, output_rate_hz, dt_s, run.delay_s, lags)
        if lags.size and lags.max() >= run.history.shape[1]:
            raise ValueError(f"a command delay of {run.delay_s} s needs more than the ring's steps")
        out_states = np.empty((ticks, n_boats, 6))
        out_derivatives = np.empty_like(out_states)
        out_steering = np.empty((ticks, n_boats, 2))
        out_commands = np.empty((ticks, n_boats, 4))
        out_issued = np.empty((ticks, n_boats))
        with _threads_for(n_boats), numba.parallel_chunksize(CLOSED_LOOP_CHUNK_BOATS):
            _closed_loop_parallel(
                states, run.steering_rad, run.thrust_N, run.helm.kind, run.helm.parameters, run.memory,
                run.history, run.last_command, run.changed_s, run.next_tick, lags, self.coefficients,
                m.resistance_N, m.resistance_max_speed_mps, m.extra_drag_N, environments, dt_s, substeps,
                output_rate_hz, run.reference_surge_mps, out_states, out_derivatives, out_steering, out_commands,
                out_issued)
        run.next_tick += ticks
        return out_states, out_derivatives, out_steering, out_commands, out_issued

    def run(
        self, states: np.ndarray, commands: np.ndarray, environments: np.ndarray, dt_s: float, substeps: int,
        steering_rad: np.ndarray | None = None, thrust_N: np.ndarray | None = None,
        switch_s: np.ndarray | None = None, before: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Run len(commands) output ticks of ``substeps``·``dt_s`` each, commands held over a tick.

        ``states`` (N, 6) is advanced in place; ``commands`` is (ticks, N, 4), ``environments`` (N, 4)
        :meth:`Environment.as_vector` rows (current and wind over ground, ENU, m/s). ``steering_rad`` (N, 2)
        holds the outboards' real angles (left, right), advanced in place; None: they start where the first
        command drives them (an outboard that has been held there). ``thrust_N`` (N, 2) likewise the engines'
        thrust commands after the lag (None: the first command's, held there).
        ``switch_s`` (ticks, N), s: ``commands[i]`` takes over at tick i's time plus this (positive: ``before``
        (N, 4) for tick 0, else the previous command, holds until then; negative: it took over that long before
        the tick) — commands that change between ticks (a helm faster than the log, a command delay); None: each
        at its tick (then the arithmetic is exactly that of a run without them).
        Returns the states at the start of every tick and their time derivatives, both (ticks, N, 6), and
        the real steering angles then, (ticks, N, 2).
        """
        self._check_boats(states.shape[0])
        if steering_rad is None:
            steering_rad = self.steering_targets(commands[0]) if len(commands) else np.zeros((len(states), 2))
        if thrust_N is None:
            thrust_N = self.thrust_start(commands[0]) if len(commands) else np.zeros((len(states), 2))
        switch = np.zeros(commands.shape[:2]) if switch_s is None else np.ascontiguousarray(switch_s, dtype=float)
        if before is None:
            before = commands[0] if len(commands) else np.zeros((len(states), 4))
        out_states = np.empty((commands.shape[0],) + states.shape)
        out_derivatives = np.empty_like(out_states)
        out_steering = np.empty((commands.shape[0], states.shape[0], 2))
        before = np.ascontiguousarray(before, dtype=float)
        n_boats = states.shape[0]
        group = max(1, CALL_BOAT_STEPS // max(commands.shape[0] * substeps, 1))
        if group >= n_boats:
            self._run_group(states, steering_rad, thrust_N, commands, switch, before, self.coefficients,
                            environments, dt_s, substeps, out_states, out_derivatives, out_steering)
            return out_states, out_derivatives, out_steering
        for a in range(0, n_boats, group):  # each boat's arithmetic is its own: the same numbers as one call
            b = min(a + group, n_boats)
            state, steering, thrust = (np.ascontiguousarray(x[a:b]) for x in (states, steering_rad, thrust_N))
            path, rates = np.empty((commands.shape[0], b - a, 6)), np.empty((commands.shape[0], b - a, 6))
            angles = np.empty((commands.shape[0], b - a, 2))
            rows = self.coefficients if self.coefficients.shape[0] == 1 else self.coefficients[a:b]
            sea = environments[a:b] if len(environments) == n_boats else environments
            self._run_group(state, steering, thrust, np.ascontiguousarray(commands[:, a:b]),
                            np.ascontiguousarray(switch[:, a:b]), before[a:b], rows, np.ascontiguousarray(sea),
                            dt_s, substeps, path, rates, angles)
            states[a:b], steering_rad[a:b], thrust_N[a:b] = state, steering, thrust
            out_states[:, a:b], out_derivatives[:, a:b], out_steering[:, a:b] = path, rates, angles
        return out_states, out_derivatives, out_steering

    def observe_sway(self, start: np.ndarray, vessel: np.ndarray, lags: int, heading_rad: np.ndarray,
                     surge_mps: np.ndarray, yaw_rate_radps: np.ndarray, commands: np.ndarray, switch_s: np.ndarray,
                     actuators: np.ndarray, environments: np.ndarray, dt_s: float) -> np.ndarray:
        """(N,) sway, m/s, of N boats each observed from rest over the ``lags`` samples (``dt_s`` apart) before
        its sample ``start`` (N,): at every sample one RK4 tick as :meth:`run`'s (the command ``commands[i]``
        (n, 4) from ``switch_s[i]`` (n,) after it) from the measured ``heading_rad``, ``surge_mps`` and
        ``yaw_rate_radps`` (n,) with the observer's sway, the outboards' angles and lagged thrust where
        ``actuators`` (n, vessels, 4) knows them for the boat's ``vessel`` (N,) index (else where the command
        drives them), in its row of ``environments`` (N, 4) or their one row (4,); the sway held where a step
        is not finite or before the first sample. Boats are run in
        compiled calls of at most :data:`CALL_BOAT_STEPS` (Ctrl-C acts between them); each boat's arithmetic is
        its own, so the numbers do not depend on the grouping."""
        m = self.model
        self._check_boats(len(start))
        heading, surge, yaw_rate, acting, switch, known, env = (
            np.ascontiguousarray(x, dtype=float)
            for x in (heading_rad, surge_mps, yaw_rate_radps, commands, switch_s, actuators,
                      np.atleast_2d(environments)))
        start, vessel = (np.ascontiguousarray(x, dtype=np.int64) for x in (start, vessel))
        out = np.zeros(len(start))
        group = max(1, CALL_BOAT_STEPS // max(lags, 1))
        for a in range(0, len(start), group):
            b = min(a + group, len(start))
            rows = self.coefficients if self.coefficients.shape[0] == 1 else self.coefficients[a:b]
            sea = env if env.shape[0] == 1 else env[a:b]
            part = np.zeros(b - a)
            with _threads_for(b - a):
                _observe_sway_parallel(start[a:b], vessel[a:b], int(lags), heading, surge, yaw_rate, acting, switch,
                                       known, rows, m.resistance_N, m.resistance_max_speed_mps, m.extra_drag_N, sea,
                                       float(dt_s), part)
            out[a:b] = part
        return out

    def _run_group(self, states: np.ndarray, steering_rad: np.ndarray, thrust_N: np.ndarray, commands: np.ndarray,
                   switch: np.ndarray, before: np.ndarray, coefficients: np.ndarray, environments: np.ndarray,
                   dt_s: float, substeps: int, out_states: np.ndarray, out_derivatives: np.ndarray,
                   out_steering: np.ndarray) -> None:
        """One compiled call of :meth:`run` over the boats of the arrays given (their own coefficient rows)."""
        m = self.model
        arguments = (states, steering_rad, thrust_N, commands, switch, before, coefficients, m.resistance_N,
                     m.resistance_max_speed_mps, m.extra_drag_N, environments, dt_s, substeps, out_states,
                     out_derivatives, out_steering)
        if states.shape[0] < PARALLEL_MIN_BOATS and commands.shape[0] * states.shape[0] < PRANGE_MIN_BOAT_TICKS:
            _run_ticks(*arguments)
        else:  # the prange form, also on one thread: 1.5x faster than the plain loop (_closed_loop_parallel)
            with _threads_for(states.shape[0]):
                _run_ticks_parallel(*arguments)
