"""A real-like boat for the diagnosis against the twin's own error (issue 42): written apart from the twin (its own
equations and RK4 integrator, numpy only), with what the twin's 3-DOF model does not hold — a planing hump in the
resistance, cubic sway and yaw damping, an engine lag, waves (Ornstein-Uhlenbeck surge, sway and yaw forces) — and
effects a recording may hide (a command delay, thrust factors, a current, an IMU heading offset, a gyro scale).
Shared by test/test_model_error.py and benchmarks/bench_real_like.py."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from boat_twin.io.trial import Trial, TrialMetadata

DT_S = 0.1
"""Log period, s (10 Hz); the boat is integrated at 100 Hz."""


@dataclass(frozen=True)
class Boat:
    """The independent boat (SI). Not the twin's equations: see the module docstring."""

    mass_kg: float = 950.0
    surge_added_kg: float = 70.0
    sway_added_kg: float = 600.0
    yaw_inertia_kgm2: float = 2600.0
    linear_drag_Nspm: float = 45.0
    quadratic_drag_Ns2pm2: float = 30.0
    hump_N: float = 260.0
    """Planing hump: an extra resistance hump_N·exp(−((u − 4.5)/1.4)²) around 4.5 m/s."""
    sway_linear_Nspm2: float = 600.0
    sway_cubic_Ns3pm3: float = 900.0
    yaw_linear_Nms: float = 2600.0
    yaw_cubic_Nms3: float = 1.5e4
    engine_x_m: float = -2.4
    engine_y_m: float = 0.5
    """The outboards at (engine_x_m, ±engine_y_m): a thrust difference turns the boat."""
    engine_lag_s: float = 0.35
    max_steering_rad: float = math.radians(30.0)
    steering_rate_radps: float = math.radians(20.0)
    wave_force_N: float = 45.0
    wave_moment_Nm: float = 90.0
    wave_time_s: float = 2.5


@dataclass(frozen=True)
class Hidden:
    """What a recording hides (defaults: nothing)."""

    delay_s: float = 0.0
    left_factor: float = 1.0
    right_factor: float = 1.0
    current_mps: tuple[float, float] = (0.0, 0.0)
    heading_offset_rad: float = 0.0
    gyro_scale: float = 1.0


def commands(rng: np.random.Generator, n: int, boat: Boat) -> np.ndarray:
    """(n, 2) random commands on the log grid: thrust per engine (N, both alike, 20-100 % of 1800 N held
    8-25 s) and steering (rad, within ±45 % of the limit, held 4-15 s)."""
    out = np.zeros((n, 2))
    for column, (low, high, hold) in enumerate(((0.2, 1.0, (8.0, 25.0)), (-0.45, 0.45, (4.0, 15.0)))):
        i = 0
        while i < n:
            span = int(rng.uniform(*hold) / DT_S)
            level = rng.uniform(low, high)
            out[i:i + span, column] = level * (1800.0 if column == 0 else boat.max_steering_rad)
            i += span
    return out


def simulate(boat: Boat, hidden: Hidden, duration_s: float, seed: int) -> Trial:
    """One recording of ``boat`` with ``hidden``, random commands of ``seed``."""
    rng = np.random.default_rng(seed)
    n = int(round(duration_s / DT_S)) + 1
    cmd = commands(rng, n, boat)
    delay = int(round(hidden.delay_s / DT_S))
    acting = np.vstack([np.repeat(cmd[:1], delay, axis=0), cmd])[:n]
    m11, m22 = boat.mass_kg + boat.surge_added_kg, boat.mass_kg + boat.sway_added_kg
    substeps, h = 10, DT_S / 10
    wave = np.zeros(3)
    wave_scale = np.array([boat.wave_force_N, boat.wave_force_N, boat.wave_moment_Nm])
    decay = math.exp(-h / boat.wave_time_s)
    # state: x, y, psi, u, v, r, thrust_left, thrust_right, steering
    s = np.array([0.0, 0.0, 0.4, 4.0, 0.0, 0.0, cmd[0, 0], cmd[0, 0], cmd[0, 1]])

    def rates(s: np.ndarray, target: np.ndarray, wave: np.ndarray) -> np.ndarray:
        psi, u, v, r, tl, tr, d = s[2:]
        left, right = hidden.left_factor * tl, hidden.right_factor * tr
        thrust = left + right
        fx, fy = thrust * math.cos(d), thrust * math.sin(d)
        drag = (boat.linear_drag_Nspm * u + boat.quadratic_drag_Ns2pm2 * u * abs(u)
                + boat.hump_N * math.exp(-((abs(u) - 4.5) / 1.4) ** 2) * math.copysign(1.0, u))
        du = (fx + m22 * v * r - drag + wave[0]) / m11
        dv = (fy - m11 * u * r - boat.sway_linear_Nspm2 * abs(u) * v - boat.sway_cubic_Ns3pm3 * v**3 + wave[1]) / m22
        munk = (m22 - m11) * u * v
        moment = boat.engine_x_m * fy + boat.engine_y_m * (right - left) * math.cos(d)
        dr = (moment - munk - boat.yaw_linear_Nms * abs(u) * r - boat.yaw_cubic_Nms3 * r**3
              + wave[2]) / boat.yaw_inertia_kgm2
        dt_thrust = (target[0] - np.array([tl, tr])) / boat.engine_lag_s
        dd = float(np.clip((target[1] - d) / h, -boat.steering_rate_radps, boat.steering_rate_radps))
        east, north = hidden.current_mps
        return np.array([u * math.cos(psi) - v * math.sin(psi) + east, u * math.sin(psi) + v * math.cos(psi) + north,
                         r, du, dv, dr, dt_thrust[0], dt_thrust[1], dd])

    states = np.zeros((n, s.size))
    for i in range(n):
        states[i] = s
        for _ in range(substeps):
            wave = wave * decay + wave_scale * math.sqrt(1 - decay**2) * rng.standard_normal(3)
            k1 = rates(s, acting[i], wave)
            k2 = rates(s + 0.5 * h * k1, acting[i], wave)
            k3 = rates(s + 0.5 * h * k2, acting[i], wave)
            k4 = rates(s + h * k3, acting[i], wave)
            s = s + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
    return _recorded(states, cmd, hidden, rng, f"real-like seed {seed}")


def _recorded(states: np.ndarray, cmd: np.ndarray, hidden: Hidden, rng: np.random.Generator, source: str) -> Trial:
    """The sensors' record of ``states`` (a Trial as the bag reader gives it)."""
    n = len(states)
    psi, u, v, r = states[:, 2], states[:, 3], states[:, 4], states[:, 5]
    east, north = hidden.current_mps
    vel_e = u * np.cos(psi) - v * np.sin(psi) + east
    vel_n = u * np.sin(psi) + v * np.cos(psi) + north
    late = np.maximum(np.arange(n) - 1, 0)  # GNSS 0.1 s late

    def noisy(x: np.ndarray, sigma: float) -> np.ndarray:
        return x + rng.normal(0.0, sigma, n)

    heading = noisy(psi + hidden.heading_offset_rad, math.radians(3.0))  # unwrapped, as a Trial holds it
    return Trial(
        t_s=np.arange(n) * DT_S, thrust_left_N=cmd[:, 0].copy(), thrust_right_N=cmd[:, 0].copy(),
        angle_left_rad=cmd[:, 1].copy(), angle_right_rad=cmd[:, 1].copy(), lat_deg=np.full(n, np.nan),
        lon_deg=np.full(n, np.nan), heading_rad=heading,
        yaw_rate_radps=noisy(hidden.gyro_scale * r, math.radians(0.06)), accel_x_mps2=np.full(n, np.nan),
        accel_y_mps2=np.full(n, np.nan), east_m=noisy(states[late, 0], 2.1), north_m=noisy(states[late, 1], 2.1),
        vel_east_mps=noisy(vel_e[late], 0.05), vel_north_mps=noisy(vel_n[late], 0.05),
        metadata=TrialMetadata(source=source))


