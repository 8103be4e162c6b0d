"""The twin kept in step with a real boat: fed its commands and measurements as they arrive, it predicts each
sensor sample before it comes and corrects its state with a small filter (no ROS here).

Arrival: samples come in any order, at any rate, duplicated or late. They wait :attr:`SyncSettings.reorder_s`
in a queue and are processed in stamp order (commands first at one stamp) once a newer stamp has passed them by
that much (``flush()`` takes
the rest). A sample older than the twin's time is late and dropped, the same stamp twice on one stream a
duplicate, a non-finite value or one no sensor or command can hold (:data:`~boat_twin.io.trial.VALUE_LIMITS`,
the bound every reader applies: a velocity beyond 343 m/s, a thrust beyond 1 MN) dropped; each kind is counted
and logged once. A step forward of more than :attr:`SyncSettings.gap_s` without a sample (a stream on another
clock) is not integrated over: the twin re-synchronises. A stamp more than
:attr:`SyncSettings.restart_s` before the newest one of its own stream is a clock jump backwards (a restarted
player, a bag looped): logged, and the twin starts afresh from the samples that follow. (One stream lagging the
others, a backlog drained late, is not a jump: its samples are late.)

State: the 3-DOF state of :mod:`boat_twin.vessel.dynamics` (ENU position, yaw, body velocity through the
water, yaw rate), propagated by the same kernel under the held commands, from the first complete set of
measurements (a fix, a velocity, an IMU yaw) and again after a gap of :attr:`SyncSettings.gap_s` in the sensors.

Prediction and correction: before each sensor sample the twin says what the sensor should read (the expected
measurement of :mod:`boat_twin.sensors`: the GNSS fix and velocity of the state ``latency_s`` earlier, the gyro
with its bias, the IMU yaw). The innovation (measured − predicted) then corrects the state through one scalar
Kalman filter per channel (position, velocity over ground, yaw, yaw rate): the variance P grows by the
channel's process noise between samples, the gain is P / (P + R) with R the sensor's stated noise variance
(:class:`~boat_twin.sensors.gnss.GnssConfig`, :class:`~boat_twin.sensors.um7.Um7Config`). The process noise
is small on purpose: the twin trusts its model, so its innovations measure what the model gets wrong (a wrong
mass or resistance leaves the speed innovations several times the sensor's noise; the right model leaves
them at it) instead of being tracked away.
"""

from __future__ import annotations

import heapq
import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pymap3d

from boat_twin.config import TwinConfig
from boat_twin.frames import wrap_pi
from boat_twin.io.roles import COMMAND_ROLES, SENSOR_ROLES
from boat_twin.io.trial import VALUE_LIMITS
from boat_twin.vessel.dynamics import Dynamics
from boat_twin.vessel.params import derive_coefficients
from boat_twin.vessel.propulsion import surge_thrust_N
from boat_twin.vessel.tow import tow_drag_table
from boat_twin.vessel.truth import ground_velocity_enu

KIND_ORDER = {kind: i for i, kind in enumerate(COMMAND_ROLES + SENSOR_ROLES)}
"""Samples with one stamp are processed in this order (commands first), whatever order they arrived in."""
INTEGRATION_STEP_S = 0.05
"""Longest RK4 step of the propagation, s (the diagnosis replays at 20 Hz as well)."""
INNOVATION_CHANNELS = ("speed_mps", "vel_east_mps", "vel_north_mps", "east_m", "north_m", "yaw_rate_radps",
                       "heading_rad")
"""The channels the twin's innovations come on (SI unit in the name): a live view opens them all at its start."""


@dataclass(frozen=True)
class SyncSettings:
    """How the twin takes its samples and how much it trusts its model (SI)."""

    reorder_s: float = 0.3
    """Samples wait this long for late siblings before they are processed in stamp order, s (3 periods at
    10 Hz: a DDS reorder or a busy executor)."""
    gap_s: float = 2.0
    """No sensor sample for this long: the twin re-synchronises from the next measurements, s."""
    restart_s: float = 5.0
    """A stamp this far before the newest one of its stream is a clock jump backwards (a restarted player):
    reset, s."""
    velocity_walk_mps_per_sqrt_s: float = 0.008
    """Process noise of the velocity over ground, m/s/√s: unmodelled forces (waves, gusts) as a random walk.
    With the M8's 0.05 m/s at 10 Hz it gives a gain of ~0.05 per fix: the model carries the velocity for
    ~20 fixes (2 s), so a model error of 0.01 m/s² shows as a ~0.2 m/s innovation."""
    position_walk_m_per_sqrt_s: float = 0.1
    """Process noise of the position, m/√s."""
    yaw_walk_rad_per_sqrt_s: float = math.radians(0.5)
    """Process noise of the yaw, rad/√s."""
    yaw_rate_walk_radps_per_sqrt_s: float = math.radians(0.5)
    """Process noise of the yaw rate, rad/s/√s (the gyro is 20× more precise than the model's yaw rate)."""


@dataclass(frozen=True)
class Innovation:
    """One sensor sample against the twin's prediction of it."""

    t_s: float
    """Sample stamp, s (the stream's clock)."""
    channel: str
    """``speed_mps``, ``vel_east_mps``, ``vel_north_mps``, ``east_m``, ``north_m``, ``heading_rad``,
    ``yaw_rate_radps``."""
    measured: float
    predicted: float
    stdev: float
    """The innovation's stated standard deviation √(P + R): sensor noise plus the twin's own uncertainty."""

    @property
    def value(self) -> float:
        """measured − predicted (angles wrapped to (−π, π])."""
        diff = self.measured - self.predicted
        return float(wrap_pi(np.array(diff))) if self.channel == "heading_rad" else diff


class ScalarFilter:
    """One channel's Kalman variance: P grows by ``q``·Δt, shrinks by each measurement of variance ``r``."""

    def __init__(self, q: float, r: float) -> None:
        self.q, self.r = q, max(r, 1e-12)
        self.p = self.r

    def grow(self, dt_s: float) -> None:
        """Time passes."""
        self.p += self.q * max(dt_s, 0.0)

    def gain(self) -> float:
        """Kalman gain of the next measurement; P shrinks accordingly."""
        k = self.p / (self.p + self.r)
        self.p *= 1.0 - k
        return k

    def stdev(self) -> float:
        """√(P + R): the stated spread of the next innovation."""
        return math.sqrt(self.p + self.r)


Log = Callable[[str], None]
Sink = Callable[[str, float, tuple[float, ...]], None]


class ShadowTwin:
    """The twin state following one boat (see the module docstring).

    ``config`` is the model it predicts with (:meth:`set_config` swaps it live). ``log`` receives one line per
    event worth a log (reset, gap, clock jump, first bad sample of a kind); ``sink`` every accepted sample in
    stamp order (kind, stamp s, values): what the adaptation and the rolling diagnosis learn from.
    """

    def __init__(self, config: TwinConfig, settings: SyncSettings | None = None, log: Log | None = None,
                 sink: Sink | None = None) -> None:
        self.settings = settings or SyncSettings()
        self.log = log or (lambda _line: None)
        self.sink = sink or (lambda _kind, _t, _values: None)
        self.innovations: deque[Innovation] = deque(maxlen=4096)
        """The latest innovations, oldest first (a consumer may clear it)."""
        self.counts = {"late": 0, "duplicate": 0, "non_finite": 0, "absurd": 0, "resets": 0, "restarts": 0,
                       "processed": 0}
        self._logged: set[str] = set()
        self.impulse_epoch = 0
        """Counts the restarts of :attr:`surge_impulse_Ns` (a synchronisation, the force known again): two
        readings of one epoch differ by the impulse between them."""
        self.set_config(config)
        self.reset()
        self._warm_up()

    def _warm_up(self) -> None:
        """Load the compiled kernels now (a step and a run on a scratch boat), not on the first live sample: a
        live node would lose the samples arriving meanwhile."""
        scratch, steering = np.zeros((1, 6)), np.zeros((1, 2))
        commands = np.zeros((1, 4))
        self.dynamics.step(scratch, commands, self._environment, INTEGRATION_STEP_S, steering)
        self.dynamics.run(scratch, commands[None], self._environment, INTEGRATION_STEP_S, 1, steering)

    # --- configuration and state -------------------------------------------------------------------------
    def set_config(self, config: TwinConfig) -> None:
        """Predict with ``config`` from now on (the state is kept: a hot swap)."""
        self.config = config
        self.dynamics = Dynamics(config.vessel, tow_drag_table(config.tow, config.vessel))
        self._m22_kg = derive_coefficients(config.vessel).m22_kg
        self._environment = config.environment.as_vector()[None, :]
        s, g, u = self.settings, config.gnss, config.um7
        self._filters = {
            "position": ScalarFilter(s.position_walk_m_per_sqrt_s**2, g.horizontal_stdev_m**2),
            "velocity": ScalarFilter(s.velocity_walk_mps_per_sqrt_s**2, g.velocity_stdev_mps**2),
            "yaw": ScalarFilter(s.yaw_walk_rad_per_sqrt_s**2, u.yaw_stdev_rad**2),
            "yaw_rate": ScalarFilter(s.yaw_rate_walk_radps_per_sqrt_s**2, u.gyro_stdev_radps**2),
        }

    def reset(self) -> None:
        """Forget the state, the queue and the held commands: the next measurements start the twin afresh."""
        self.state: np.ndarray | None = None
        """(6,) east_m, north_m, yaw_rad, u_mps, v_mps, r_radps; None until synchronised."""
        self.t_s = -math.inf
        """Time the state describes (and up to which samples are processed), s."""
        self.commands = np.array([math.nan, math.nan, 0.0, 0.0])
        self._steering: np.ndarray | None = None
        self._surge_offset_mps = 0.0
        """The latest velocity innovation along the hull left after the correction, m/s: added to the state's
        surge where the engines' envelope is read (:meth:`surge_thrust_N`)."""
        self.surge_impulse_Ns = math.nan
        """∫ :meth:`surge_thrust_N` dt over the twin's propagation since :attr:`impulse_epoch` began, N·s (NaN
        while the thrust is not known)."""
        self._queue: list[tuple[float, int, int, str, tuple[float, ...]]] = []
        self._seq = 0
        self.newest_s = -math.inf
        self._newest: dict[str, float] = {}
        self._last_stamp: dict[str, float] = {}
        self._latest: dict[str, tuple[float, tuple[float, ...]]] = {}
        self._last_sensor_s = -math.inf
        self._history: deque[tuple[float, ...]] = deque(maxlen=64)
        self.origin: tuple[float, float, float] | None = None

    @property
    def synchronised(self) -> bool:
        """True once the state has been set from measurements (and not lost to a gap since)."""
        return self.state is not None

    def _once(self, key: str, line: str) -> None:
        if key not in self._logged:
            self._logged.add(key)
            self.log(line)

    # --- intake ------------------------------------------------------------------------------------------
    def add(self, kind: str, stamp_s: float, values: tuple[float, ...]) -> None:
        """One sample of stream ``kind`` (:data:`COMMAND_ROLES`: one value; :data:`SENSOR_ROLES`: their
        columns; an IMU yaw or acceleration may be NaN, "not provided"), stamped ``stamp_s`` seconds."""
        if kind not in COMMAND_ROLES + SENSOR_ROLES:
            raise ValueError(f"unknown sample kind {kind!r}")
        needed = values[:2] if kind == "imu" else values
        if not math.isfinite(stamp_s) or not all(math.isfinite(v) for v in needed):
            self.counts["non_finite"] += 1
            self._once(f"nan-{kind}", f"{kind}: sample with a non-finite stamp or value at {stamp_s:.3f} s dropped "
                       "(further ones counted, not logged)")
            return
        for value, (name, low, high, unit) in zip(values, VALUE_LIMITS[kind], strict=False):
            if not low <= value <= high and not math.isnan(value):  # (an IMU's NaN: "not provided")
                self.counts["absurd"] += 1
                self._once(f"absurd-{kind}", f"{kind}: {name} {value:.6g} {unit} at {stamp_s:.3f} s is outside "
                           f"[{low:g}, {high:g}] {unit} (a decoding or unit error): dropped (further ones "
                           "counted, not logged)")
                return
        newest = self._newest.get(kind, -math.inf)
        if stamp_s < newest - self.settings.restart_s:
            self.counts["restarts"] += 1
            self.log(f"clock jumped back {newest - stamp_s:.1f} s ({kind} stamped {stamp_s:.3f} s after "
                     f"{newest:.3f} s): a restarted player or a looped bag; the twin starts afresh")
            self.reset()
        self._newest[kind] = max(self._newest.get(kind, -math.inf), stamp_s)
        same = stamp_s == self._last_stamp.get(kind)
        if same or stamp_s < self.t_s:
            self.counts["duplicate" if same else "late"] += 1
            self._once(f"late-{kind}-{same}", f"{kind}: {'duplicate' if same else 'late'} sample at {stamp_s:.3f} s "
                       f"(twin at {self.t_s:.3f} s) dropped (further ones counted, not logged)")
            return
        heapq.heappush(self._queue, (stamp_s, KIND_ORDER[kind], self._seq, kind, tuple(values)))
        self._seq += 1
        self.newest_s = max(self.newest_s, stamp_s)
        self._drain(self.newest_s - self.settings.reorder_s)

    def flush(self) -> None:
        """Process every queued sample (end of a recording)."""
        self._drain(math.inf)

    def _drain(self, until_s: float) -> None:
        while self._queue and self._queue[0][0] <= until_s:
            stamp_s, _, _, kind, values = heapq.heappop(self._queue)
            if stamp_s == self._last_stamp.get(kind):
                self.counts["duplicate"] += 1
                self._once(f"dup-{kind}", f"{kind}: duplicate sample at {stamp_s:.3f} s dropped (further ones "
                           "counted, not logged)")
                continue
            self._last_stamp[kind] = stamp_s
            self._process(kind, stamp_s, values)

    # --- processing --------------------------------------------------------------------------------------
    def _process(self, kind: str, stamp_s: float, values: tuple[float, ...]) -> None:
        self.counts["processed"] += 1
        if kind in COMMAND_ROLES:
            self._propagate(stamp_s)
            self.commands[COMMAND_ROLES.index(kind)] = values[0]
            self.sink(kind, stamp_s, values)
            return
        if self.state is not None and stamp_s - self._last_sensor_s > self.settings.gap_s:
            self.log(f"no sensor sample for {stamp_s - self._last_sensor_s:.1f} s (to {stamp_s:.3f} s): the twin "
                     "re-synchronises from the next measurements")
            self.state = None
            self._latest.clear()
        self._last_sensor_s = stamp_s
        if self.state is None:
            self.t_s = stamp_s
            self._latest[kind] = (stamp_s, values)
            self._try_start()
        else:
            self._propagate(stamp_s)
            correct = {"gnss_fix": self._correct_gnss_fix, "gnss_vel": self._correct_gnss_vel,
                       "imu": self._correct_imu}[kind]
            correct(stamp_s, values)
        self.sink(kind, stamp_s, values)

    def _enu(self, lat_deg: float, lon_deg: float, alt_m: float) -> tuple[float, float]:
        if self.origin is None:
            self.origin = (lat_deg, lon_deg, alt_m)
        east, north, _ = pymap3d.geodetic2enu(lat_deg, lon_deg, alt_m, *self.origin)
        return float(east), float(north)

    def _try_start(self) -> None:
        """Set the state from the latest fix, velocity and IMU yaw once all three are in."""
        imu = self._latest.get("imu")
        if len(self._latest) < 3 or imu is None or not math.isfinite(imu[1][0]):
            return
        east, north = self._enu(*self._latest["gnss_fix"][1][:3])
        vel_east, vel_north = self._latest["gnss_vel"][1]
        yaw, rate = imu[1][0], imu[1][1] - float(self.config.um7.gyro_bias_radps[2])
        env = self.config.environment
        we, wn = vel_east - env.current_east_mps, vel_north - env.current_north_mps
        u, v = we * math.cos(yaw) + wn * math.sin(yaw), -we * math.sin(yaw) + wn * math.cos(yaw)
        self.state = np.array([east, north, yaw, u, v, rate])
        self._steering = None
        self.surge_impulse_Ns, self.impulse_epoch = 0.0, self.impulse_epoch + 1
        self._surge_offset_mps = 0.0
        self._history.clear()
        self._history.append((self.t_s, east, north, vel_east, vel_north, yaw, rate))
        for f in self._filters.values():
            f.p = f.r
        self.counts["resets"] += 1
        self.log(f"synchronised at {self.t_s:.3f} s from the measurements: {math.hypot(u, v):.2f} m/s, "
                 f"heading {math.degrees(yaw):.0f}° (ENU)")

    def _propagate(self, to_s: float) -> None:
        """Advance the state to ``to_s`` under the held commands (nothing before the twin is synchronised)."""
        if self.state is None:
            self.t_s = max(self.t_s, to_s)
            return
        dt_total = to_s - self.t_s
        if dt_total <= 0.0:
            return
        if dt_total > self.settings.gap_s:  # nothing to integrate over (a stream on another clock, a stall)
            self.log(f"nothing for {dt_total:.1f} s (to {to_s:.3f} s): the twin re-synchronises from the next "
                     "measurements")
            self.state, self.t_s = None, to_s
            self._latest.clear()
            return
        commands = np.where(np.isfinite(self.commands), self.commands, 0.0)[None, :]
        if self._steering is None:
            self._steering = self.dynamics.steering_targets(commands)
        states = self.state[None, :]
        steps = max(1, math.ceil(dt_total / INTEGRATION_STEP_S - 1e-9))
        force = self.surge_thrust_N()  # under the commands held from now on
        if math.isfinite(force) and not math.isfinite(self.surge_impulse_Ns):
            self.surge_impulse_Ns, self.impulse_epoch = 0.0, self.impulse_epoch + 1
        for _ in range(steps):
            self.dynamics.step(states, commands, self._environment, dt_total / steps, self._steering)
            after = self.surge_thrust_N()
            self.surge_impulse_Ns += 0.5 * (force + after) * dt_total / steps  # trapezoids over the RK4 step
            force = after
        self.state = states[0]
        for f in self._filters.values():
            f.grow(dt_total)
        self.t_s = to_s
        east, north, yaw, u, v, rate = self.state
        ve, vn = ground_velocity_enu(yaw, u, v, *self._environment[0, :2])
        self._history.append((to_s, float(east), float(north), float(ve), float(vn), float(yaw), float(rate)))

    def _delayed(self, stamp_s: float) -> tuple[float, float, float, float]:
        """(east, north, vel_east, vel_north) of the state ``latency_s`` before ``stamp_s`` (from the history;
        the oldest kept when the history is shorter)."""
        east, north, vel_east, vel_north = self._at(stamp_s - self.config.gnss.latency_s)[:4]
        return east, north, vel_east, vel_north

    def motion_at(self, t_s: float) -> tuple[float, float, float]:
        """The twin's heading (ENU yaw, rad), sway through the water (m/s, FLU: positive to port) and yaw rate
        (rad/s, positive turning left) at ``t_s`` from the history (a velocity sample's time: its stamp minus the
        GNSS latency); the oldest or the newest kept outside it. Heading and yaw rate follow the IMU closely (the
        filter's corrections); the sway is the twin's model's, corrected by the GNSS velocity."""
        _, _, vel_east, vel_north, yaw, rate = self._at(t_s)
        east, north = vel_east - self._environment[0, 0], vel_north - self._environment[0, 1]
        return yaw, -east * math.sin(yaw) + north * math.cos(yaw), rate

    def _at(self, at_s: float) -> tuple[float, ...]:
        t = np.array([h[0] for h in self._history])
        return tuple(float(np.interp(at_s, t, np.array([h[k] for h in self._history]))) for k in range(1, 7))

    def _record(self, stamp_s: float, channel: str, measured: float, predicted: float, stdev: float) -> None:
        """One innovation on ``channel`` (one of :data:`INNOVATION_CHANNELS`)."""
        self.innovations.append(Innovation(stamp_s, channel, measured, predicted, stdev))

    def _correct_gnss_vel(self, stamp_s: float, values: tuple[float, ...]) -> None:
        assert self.state is not None
        _, _, pred_e, pred_n = self._delayed(stamp_s)
        meas_e, meas_n = values[0], values[1]
        f = self._filters["velocity"]
        sd = f.stdev()
        self._record(stamp_s, "speed_mps", math.hypot(meas_e, meas_n), math.hypot(pred_e, pred_n), sd)
        self._record(stamp_s, "vel_east_mps", meas_e, pred_e, sd)
        self._record(stamp_s, "vel_north_mps", meas_n, pred_n, sd)
        k = f.gain()
        yaw = self.state[2]
        surge = (meas_e - pred_e) * math.cos(yaw) + (meas_n - pred_n) * math.sin(yaw)
        sway = -(meas_e - pred_e) * math.sin(yaw) + (meas_n - pred_n) * math.cos(yaw)
        self.state[3] += k * surge
        self.state[4] += k * sway
        self._surge_offset_mps = (1.0 - k) * surge

    def _correct_gnss_fix(self, stamp_s: float, values: tuple[float, ...]) -> None:
        assert self.state is not None
        east, north = self._enu(*values[:3])
        pred_e, pred_n, _, _ = self._delayed(stamp_s)
        f = self._filters["position"]
        sd = f.stdev()
        self._record(stamp_s, "east_m", east, pred_e, sd)
        self._record(stamp_s, "north_m", north, pred_n, sd)
        k = f.gain()
        self.state[0] += k * (east - pred_e)
        self.state[1] += k * (north - pred_n)

    def _correct_imu(self, stamp_s: float, values: tuple[float, ...]) -> None:
        assert self.state is not None
        yaw, rate = values[0], values[1]
        bias = float(self.config.um7.gyro_bias_radps[2])
        f = self._filters["yaw_rate"]
        self._record(stamp_s, "yaw_rate_radps", rate, self.state[5] + bias, f.stdev())
        self.state[5] += f.gain() * (rate - bias - self.state[5])
        if math.isfinite(yaw):
            f = self._filters["yaw"]
            self._record(stamp_s, "heading_rad", yaw, self.state[2], f.stdev())
            self.state[2] += f.gain() * float(wrap_pi(np.array(yaw - self.state[2])))

    def surge_thrust_N(self) -> float:
        """The thrust along the hull on the twin now, N: the held thrust commands delivered (the engines' envelope
        at the surge through the water the latest velocity fix says: the state's plus what the correction left
        of the innovation) at the outboards' real angles; NaN before synchronisation or before both thrusts are
        known. Integrated over every propagation step into :attr:`surge_impulse_Ns`: the outboards swing between
        samples, and a force read at one sample and held to the next lags them by half a sample period, which
        the surge fit reads as inertia."""
        if self.state is None:
            return math.nan
        u = float(self.state[3]) + self._surge_offset_mps
        return float(surge_thrust_N(self.config.vessel, np.asarray(self.commands[:2], dtype=float),
                                    self.steering_rad, u))

    @property
    def m22_kg(self) -> float:
        """The twin's sway mass m₂₂ (added mass included), kg: its model's (:func:`derive_coefficients`)."""
        return self._m22_kg

    # --- what the front ends publish -----------------------------------------------------------------------
    @property
    def steering_rad(self) -> np.ndarray:
        """(2,) the outboards' real angles (left, right) in the twin, rad (the targets before the first step)."""
        if self._steering is None:
            commands = np.where(np.isfinite(self.commands), self.commands, 0.0)[None, :]
            return self.dynamics.steering_targets(commands)[0]
        return self._steering[0]
