"""``Trial``: the one data structure every analysis reads — commands and measurements on one time grid.

Streams arrive as (stamps, values) arrays per *role* (``gnss_fix``, ``gnss_vel``, ``imu``, the four command
roles). :func:`build_trial` puts them on a uniform grid at the GNSS rate: commands by zero-order hold on the
nearest grid time (a command topic may publish at any rate, or only on change), sensors by linear interpolation between
neighbouring samples, never across a gap longer than :data:`GAP_TOLERANCE_PERIODS` sample periods (NaN there,
and the gap is reported). Local ENU comes from the geodetic origin with pymap3d (WGS-84).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
import pymap3d

from boat_twin.errors import InputError
from boat_twin.io.roles import COMMAND_ROLES, MEASURED_INPUT_ROLES, SENSOR_ROLES
from boat_twin.validation import THRUST_LIMIT_N

GAP_TOLERANCE_PERIODS = 2.5
"""A sensor stream is interpolated only between samples at most this many nominal periods apart."""
GRID_BLOCK = 8192
"""Grid points interpolated (and converted to ENU) at a time: bounds the temporaries of a long trial."""


@dataclass
class Stream:
    """One role's samples as read: ``stamps_s`` (n,) seconds (absolute or relative), ``values`` (n, k)."""

    stamps_s: np.ndarray
    values: np.ndarray


def empty_second_thruster(streams: dict[str, Stream]) -> None:
    """A boat file's single thruster (its command in ``thrust_left``): the second thrust slot in ``streams`` at
    0 from the first command's stamp on, not missing."""
    streams["thrust_right"] = Stream(streams["thrust_left"].stamps_s[:1], np.zeros((1, 1)))


@dataclass
class TrialMetadata:
    """Where a trial came from and how good its streams are."""

    source: str
    topics: dict[str, str] = field(default_factory=dict)
    """Role → topic (or log message) it was read from."""
    rates_hz: dict[str, float] = field(default_factory=dict)
    """Role → median sample rate, Hz."""
    counts: dict[str, int] = field(default_factory=dict)
    """Role → number of samples read."""
    gaps: list[tuple[str, float, float]] = field(default_factory=list)
    """(role, start_s, end_s) of every interval longer than the gap tolerance without samples."""
    missing: list[str] = field(default_factory=list)
    """Roles with no samples at all."""
    backward_stamps: dict[str, tuple[int, float]] = field(default_factory=dict)
    """Role → (samples dropped because their stamp ran backwards, largest step back in s): a clock fault."""
    dropouts: dict[str, int] = field(default_factory=dict)
    """GNSS role → samples dropped because a value they normally carry was NaN (dropouts, become gaps)."""
    derived: dict[str, str] = field(default_factory=dict)
    """Role → how it was derived from another stream (e.g. GNSS velocity from positions), in words."""
    speed_smoothing_s: float = 0.0
    """Window of the smoother that derived the velocity from positions, s (0: a measured velocity)."""
    derived_speed_noise_mps: float = 0.0
    """Noise of that derived speed, stated by the smoother from the positions' noise, m/s (0: not derived)."""
    stream_choices: list[str] = field(default_factory=list)
    """How the reader chose streams it did not find by their default names, in words."""
    start_time_s: float = 0.0
    """Absolute time of t = 0 (e.g. Unix time of the first GNSS sample), s."""
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """Geodetic origin of the local ENU frame: latitude deg, longitude deg, ellipsoidal height m."""

    def warnings(self) -> list[str]:
        """What reading the trial lost or took on a guess, one line each naming the source: signals missing,
        spans of a stream without samples (left as gaps: a dropout, a recorder that stopped, a damaged stretch
        of the file — the reader cannot tell which), samples dropped (a clock running back, NaN values), streams
        derived or found by something other than their names. Empty: read whole."""
        source = self.source
        spans: dict[str, list[tuple[float, float]]] = {}
        for role, start_s, end_s in self.gaps:
            spans.setdefault(role, []).append((start_s, end_s))
        lines = [f"{source}: {role}: not in the trial (signal missing)" for role in self.missing]
        for role, found in spans.items():
            start_s, end_s = max(found, key=lambda span: span[1] - span[0])
            lines.append(f"{source}: {role}: {len(found)} span(s) without samples, {sum(b - a for a, b in found):.1f} "
                         f"s in all, the longest {end_s - start_s:.1f} s (t = {start_s:.1f} to {end_s:.1f} s): "
                         "left as gaps")
        return (lines
                + [f"{source}: {role}: {count} sample(s) whose stamp ran backwards (up to {back_s:.3g} s) were "
                   "dropped: the recording's clock is faulty there" for role, (count, back_s)
                   in self.backward_stamps.items()]
                + [f"{source}: {role}: {count} sample(s) with NaN values dropped as dropouts (gaps)"
                   for role, count in self.dropouts.items()]
                + [f"{source}: {role} {how}" for role, how in self.derived.items()]
                + [f"{source}: {note}" for note in self.stream_choices])

    def summary_line(self) -> str:
        """One readable line: rates, counts, gaps, missing streams."""
        parts = [f"{role} {self.counts.get(role, 0)} msgs @ {self.rates_hz.get(role, 0.0):.1f} Hz"
                 for role in self.topics if role in self.counts]
        if self.gaps:
            parts.append(f"{len(self.gaps)} gap(s), longest {max(g[2] - g[1] for g in self.gaps):.1f} s")
        if self.missing:
            parts.append("missing: " + ", ".join(self.missing))
        for role, (count, back_s) in self.backward_stamps.items():
            parts.append(f"{role}: {count} stamp(s) ran backwards (up to {back_s:.3g} s), dropped")
        parts += [f"{role}: {count} NaN sample(s) dropped" for role, count in self.dropouts.items()]
        parts += [f"{role} {how}" for role, how in self.derived.items()]
        parts += self.stream_choices
        return f"{self.source}: " + "; ".join(parts)


@dataclass
class Trial:
    """Commands and measurements on a uniform time grid ``t_s`` (seconds since start). SI, ENU/FLU.

    NaN marks a sample that is not known (before the first command, inside a sensor gap).
    """

    t_s: np.ndarray
    thrust_left_N: np.ndarray
    thrust_right_N: np.ndarray
    angle_left_rad: np.ndarray
    angle_right_rad: np.ndarray
    lat_deg: np.ndarray
    lon_deg: np.ndarray
    east_m: np.ndarray
    north_m: np.ndarray
    vel_east_mps: np.ndarray
    vel_north_mps: np.ndarray
    heading_rad: np.ndarray
    """IMU heading as ENU yaw (counter-clockwise from east), rad, unwrapped."""
    yaw_rate_radps: np.ndarray
    accel_x_mps2: np.ndarray
    accel_y_mps2: np.ndarray
    metadata: TrialMetadata
    command_switch_s: np.ndarray | None = None
    """(n,) when the commands held from each grid time were issued, relative to it, s (within ±half a period:
    a helm faster than the grid changes them between grid times; 0 where nothing changed); None: at the grid
    times. The mean over the command roles that changed at that sample."""
    gnss_bridged: np.ndarray | None = None
    """(n,) True where the GNSS velocity and position were interpolated across a lost sample (a dropout): not
    a measurement, and smoother than one; None: none was."""
    wind_east_mps: np.ndarray | None = None
    """Measured true wind over ground, east component of the air's velocity (where it blows to), m/s, where the
    recording has an anemometer (the ``wind`` role); None: not recorded. A known input of the diagnosis."""
    wind_north_mps: np.ndarray | None = None
    """Measured true wind over ground, north component, m/s; None: not recorded."""
    actual_angle_rad: np.ndarray | None = None
    """The outboards' actual steering angle (mean of the two), rad, where the recording has it (a rudder-angle
    indicator; the simulator's actuator state, :func:`~boat_twin.twin.sea_trial.actual_angle_on_grid`): it trails
    the commanded angle at the steering rate and differs from it by the steering offset. None: not recorded."""

    @property
    def speed_mps(self) -> np.ndarray:
        """Speed over ground, m/s."""
        return np.hypot(self.vel_east_mps, self.vel_north_mps)

    @property
    def surge_thrust_N(self) -> np.ndarray:
        """Thrust along the hull: Σ T_i·cos δ_i, N."""
        return self.thrust_left_N * np.cos(self.angle_left_rad) + self.thrust_right_N * np.cos(self.angle_right_rad)

    @property
    def commands(self) -> np.ndarray:
        """Commands (n, 4): thrust_left_N, thrust_right_N, angle_left_rad, angle_right_rad."""
        return np.column_stack([self.thrust_left_N, self.thrust_right_N, self.angle_left_rad, self.angle_right_rad])

    def __len__(self) -> int:
        return int(self.t_s.size)


def _median_period_s(stamps_s: np.ndarray) -> float:
    steps = np.diff(stamps_s)
    steps = steps[steps > 0]
    return float(np.median(steps)) if steps.size else float("nan")


def _hold(stamps_s: np.ndarray, values: np.ndarray, grid_s: np.ndarray, period_s: float) -> np.ndarray:
    """Zero-order hold on the nearest grid time: at each grid time, the last value stamped before the middle of
    its sample period (a tie goes to the later sample); NaN before the first sample.

    An analysis holds a grid sample's command through the period that follows it, so a command that came between
    two grid times acts from the nearer one: its timing errs by at most half a period, either way. The last value
    at or before each grid time would make every such command act late, by half a period on average, a delay
    that a fit then absorbs into the boat's coefficients (a 50 Hz helm's zigzag logged on a 10 Hz grid: a_r
    +42 %, docs/identification.md)."""
    index = np.searchsorted(stamps_s, grid_s + 0.5 * period_s - 1e-9, side="left") - 1
    out = values[np.maximum(index, 0)].astype(float)
    out[index < 0] = np.nan
    return out


def _switch_offsets(stamps_s: np.ndarray, values: np.ndarray, grid_s: np.ndarray, period_s: float
                     ) -> np.ndarray:
    """(n,) for each grid time whose :func:`_hold` value differs from the previous grid time's, when that value
    was first issued (its run of equal values began), relative to the grid time, s; NaN elsewhere."""
    index = np.searchsorted(stamps_s, grid_s + 0.5 * period_s - 1e-9, side="left") - 1
    changed = np.concatenate([[True], values[1:] != values[:-1]])
    run_start = stamps_s[np.maximum.accumulate(np.where(changed, np.arange(values.size), 0))]
    held = values[np.maximum(index, 0)]
    new = (index >= 0) & np.concatenate([[False], (held[1:] != held[:-1]) & (index[:-1] >= 0)])
    offset = np.clip(run_start[np.maximum(index, 0)] - grid_s, -0.5 * period_s, 0.5 * period_s)
    return np.where(new, np.where(np.abs(offset) < 1e-6, 0.0, offset), np.nan)


def _bridged(stamps_s: np.ndarray, grid_s: np.ndarray, period_s: float) -> np.ndarray:
    """(n,) True at grid times strictly between two samples more than 1.5 periods apart (a lost sample
    between them): an interpolation across a dropout."""
    right = np.clip(np.searchsorted(stamps_s, grid_s, side="left"), 1, max(stamps_s.size - 1, 1))
    left = right - 1
    span = stamps_s[right] - stamps_s[left]
    inside = (grid_s > stamps_s[left] + 1e-6) & (grid_s < stamps_s[right] - 1e-6)
    return inside & (span > 1.5 * period_s)


def _interpolate(stamps_s: np.ndarray, values: np.ndarray, grid_s: np.ndarray, max_gap_s: float,
                 out: np.ndarray | None = None) -> np.ndarray:
    """Linear interpolation between samples at most ``max_gap_s`` apart; NaN elsewhere. Into ``out`` if given.

    Works through the grid :data:`GRID_BLOCK` points at a time, so its temporaries do not grow with the trial.
    """
    out = np.empty((grid_s.size, values.shape[1])) if out is None else out
    for start in range(0, grid_s.size, GRID_BLOCK):
        block = slice(start, start + GRID_BLOCK)
        out[block] = _interpolate_block(stamps_s, values, grid_s[block], max_gap_s)
    return out


def _interpolate_block(stamps_s: np.ndarray, values: np.ndarray, grid_s: np.ndarray, max_gap_s: float
                       ) -> np.ndarray:
    right = np.clip(np.searchsorted(stamps_s, grid_s, side="left"), 1, stamps_s.size - 1)
    left = right - 1
    t0, t1 = stamps_s[left], stamps_s[right]
    span = t1 - t0
    w = np.where(span > 0, (grid_s - t0) / np.where(span > 0, span, 1.0), 0.0)
    out = values[left] + w[:, None] * (values[right] - values[left])
    exact_left, exact_right = np.abs(grid_s - t0) <= 1e-6, np.abs(grid_s - t1) <= 1e-6
    out[exact_left] = values[left[exact_left]]
    out[exact_right] = values[right[exact_right]]
    outside = (grid_s < stamps_s[0] - 1e-6) | (grid_s > stamps_s[-1] + 1e-6)
    out[((span > max_gap_s) & ~exact_left & ~exact_right) | outside] = np.nan
    return out


_THRUST_LIMIT = (-THRUST_LIMIT_N, THRUST_LIMIT_N, "N")
_ANGLE_LIMIT = (-np.pi, np.pi, "rad")
VALUE_LIMITS: dict[str, tuple[tuple[str, float, float, str], ...]] = {
    "thrust_left": (("thrust", *_THRUST_LIMIT),),
    "thrust_right": (("thrust", *_THRUST_LIMIT),),
    "angle_left": (("steering angle", *_ANGLE_LIMIT),),
    "angle_right": (("steering angle", *_ANGLE_LIMIT),),
    "gnss_fix": (("latitude", -90.0, 90.0, "deg"), ("longitude", -180.0, 180.0, "deg"),
                 ("altitude", -1e4, 1e5, "m")),
    "gnss_vel": (("east velocity", -343.0, 343.0, "m/s"), ("north velocity", -343.0, 343.0, "m/s")),
    "imu": (("yaw", -2 * np.pi, 2 * np.pi, "rad"), ("yaw rate", -35.0, 35.0, "rad/s"),
            ("x acceleration", -160.0, 160.0, "m/s^2"), ("y acceleration", -160.0, 160.0, "m/s^2")),
    "wind": (("wind east", -120.0, 120.0, "m/s"), ("wind north", -120.0, 120.0, "m/s")),
}
"""Role → per value column (name, lowest, highest, unit) a recording can hold: thrust within ±1 MN (500 times
the seed boat's bollard thrust), steering within ±π, geodetic coordinates, velocities below the speed of sound
in air, yaw rate and accelerations within the ±2000 °/s and ±16 g full scales of MEMS IMUs. A value beyond is a
decoding or unit error, refused; NaN means "not provided" and passes."""


def _check_values(source: str, role: str, stream: Stream) -> None:
    values = np.asarray(stream.values)
    for column, (name, low, high, unit) in enumerate(VALUE_LIMITS[role]):
        bad = np.flatnonzero(~((values[:, column] >= low) & (values[:, column] <= high)
                               | np.isnan(values[:, column])))
        if bad.size:
            raise InputError(f"{source}: {role} {name} {values[bad[0], column]:.6g} {unit} at sample {bad[0]} is "
                             f"outside [{low:g}, {high:g}] {unit} ({bad.size} such sample(s))")


def _monotone_stream(role: str, stream: Stream, meta: TrialMetadata) -> Stream:
    """Drop non-finite stamps and every sample whose stamp is not later than all before it (a duplicate, or a
    stamp running backwards: recorded in ``meta.backward_stamps``, never reordered into the data); no copy of a
    clean stream."""
    stamps = np.asarray(stream.stamps_s, dtype=float)
    values = np.asarray(stream.values, dtype=float).reshape(stamps.size, -1)
    keep = np.isfinite(stamps)
    if not keep.all():
        stamps, values = stamps[keep], values[keep]
    if stamps.size and not np.all(np.diff(stamps) > 0):
        latest = np.concatenate([[-np.inf], np.maximum.accumulate(stamps)[:-1]])
        back = stamps < latest
        if np.any(back):
            meta.backward_stamps[role] = (int(back.sum()), float(np.max(latest[back] - stamps[back])))
        keep = stamps > latest
        stamps, values = stamps[keep], values[keep]
    return Stream(stamps, values)


def _drop_nan_rows(role: str, stream: Stream, meta: TrialMetadata) -> Stream:
    """Drop the samples of a GNSS stream with a NaN in a column that is finite in most samples: dropouts
    (counted in ``meta.dropouts``), which interpolation then bridges or reports as a gap. A column NaN in most
    samples (a field the receiver never fills) is left alone."""
    values = stream.values
    if values.shape[0] == 0:
        return stream
    finite = np.isfinite(values)
    provided = finite.mean(axis=0) > 0.5
    bad = ~np.all(finite[:, provided], axis=1)
    if not np.any(bad):
        return stream
    meta.dropouts[role] = int(bad.sum())
    return Stream(stream.stamps_s[~bad], values[~bad])


SPEED_NOISE_TARGET_MPS = 0.05
"""Velocity from positions: the smoothing window is sized for this noise (a u-blox M8's velocity stdev), m/s."""
SPEED_WINDOW_S = (1.0, 10.0)
"""Velocity from positions: the shortest and longest smoothing window, s."""


def velocity_from_positions(east_m: np.ndarray, north_m: np.ndarray, period_s: float
                            ) -> tuple[np.ndarray, np.ndarray, float, float, str]:
    """ENU velocity (m/s) from positions on a uniform grid, the smoothing window (s), the speed noise it states
    (m/s) and how it was derived, in words.

    Smoother: Savitzky–Golay, a local quadratic fitted over a centred window of N samples, differentiated at its
    centre — no lag for motion up to constant acceleration. For white position noise σ_p its velocity noise is
    σ_v = σ_p·√(12/(N(N²−1)))/dt; N is the smallest odd count giving σ_v ≤ :data:`SPEED_NOISE_TARGET_MPS`, within
    :data:`SPEED_WINDOW_S`. σ_p comes from the positions' second differences (white-noise estimate: a receiver
    whose error wanders slowly has more low-frequency error than this states). Each run of known positions is
    smoothed alone; runs shorter than the window stay unknown (NaN)."""
    from boat_twin.signal_noise import savgol_filter, white_noise_stdev

    sigma_p = float(np.nanmax([white_noise_stdev(east_m), white_noise_stdev(north_m), 0.0]))
    wanted = (12.0 * sigma_p**2 / (period_s**2 * SPEED_NOISE_TARGET_MPS**2)) ** (1.0 / 3.0)
    lo, hi = (max(5, int(np.ceil(w / period_s))) for w in SPEED_WINDOW_S)
    n = int(np.clip(np.ceil(wanted), lo, hi)) | 1
    sigma_v = sigma_p * np.sqrt(12.0 / (n * (n * n - 1.0))) / period_s
    vel = np.full((east_m.size, 2), np.nan)
    known = np.isfinite(east_m) & np.isfinite(north_m)
    edges = np.flatnonzero(np.diff(np.r_[0, known.astype(np.int8), 0]))
    for start, stop in zip(edges[::2], edges[1::2], strict=True):
        if stop - start >= n:
            for k, pos in enumerate((east_m, north_m)):
                vel[start:stop, k] = savgol_filter(pos[start:stop], n, 2, deriv=1, delta=period_s)
    how = (f"derived from GNSS positions (no velocity stream): Savitzky-Golay local quadratic over "
           f"{n * period_s:.3g} s, no lag; position noise {sigma_p:.3g} m gives speed noise {sigma_v:.3g} m/s")
    return vel[:, 0], vel[:, 1], n * period_s, float(sigma_v), how


def _nan_runs(role: str, t_s: np.ndarray, values: np.ndarray) -> list[tuple[str, float, float]]:
    """(role, start_s, end_s) of each run of NaN in ``values`` after its first known sample: the known neighbours'
    times bound it (the end of the trial when no known sample follows)."""
    known = np.isfinite(values)
    if not np.any(known):
        return []
    unknown = ~known & (np.arange(values.size) > np.argmax(known))
    edges = np.flatnonzero(np.diff(np.r_[0, unknown.astype(np.int8), 0]))
    return [(role, float(t_s[start - 1]), float(t_s[min(stop, t_s.size - 1)]))
            for start, stop in zip(edges[::2], edges[1::2], strict=True)]


MAX_GRID_PER_SAMPLE = 20
"""The trial grid may hold at most this many samples per GNSS sample (gaps included): more means a stamp far off
the recording's time (a clock error), which would allocate a grid of the whole empty span."""


def _check_span(source: str, role: str, stamps_s: np.ndarray, period_s: float) -> None:
    """Refuse, before allocating, a GNSS clock whose stamps span far more time than its samples cover."""
    n_grid = (stamps_s[-1] - stamps_s[0]) / period_s
    if n_grid > MAX_GRID_PER_SAMPLE * stamps_s.size + 1000:
        jump = int(np.argmax(np.diff(stamps_s)))
        raise InputError(
            f"{source}: {role} stamps jump by {stamps_s[jump + 1] - stamps_s[jump]:.3g} s after "
            f"{stamps_s[jump] - stamps_s[0]:.1f} s ({stamps_s.size} samples would span {n_grid:.3g} grid steps): "
            "a clock error in the recording; cut the bag before it or fix the stamps")


def build_trial(
    streams: dict[str, Stream],
    source: str,
    topics: dict[str, str],
    origin: tuple[float, float, float] | None = None,
    *,
    release: bool = False,
    derive_velocity: bool = True,
) -> Trial:
    """Put the streams of one trial on a common grid (see the module docstring), in five named stages: the
    streams checked, the grid, the commands held on it, the sensors interpolated, the positions in ENU.

    Requires a GNSS fix or velocity stream (it sets the grid) and at least one command overlapping it.
    ``origin`` is the geodetic origin of the local ENU frame (default: the first fix). With ``release`` the
    caller hands the streams over: each is removed from ``streams`` once it is on the grid, so a long trial's
    samples and its grid are not both held in full. Without a velocity stream, the velocity is derived from the
    positions (:func:`velocity_from_positions`) unless ``derive_velocity`` is False (a velocity source was
    named and is absent: it stays missing).
    """
    meta = TrialMetadata(source=source, topics=dict(topics))
    data = _checked_streams(streams, source, meta)
    grid_abs, period = _grid(data, source, meta)
    t0 = meta.start_time_s
    columns, switch = _commands_on_grid(data, streams, grid_abs, period, release)
    bridged = _sensors_on_grid(data, streams, grid_abs, meta, columns, release)
    wind = None
    if "wind" in data:  # held across the anemometer's own gaps only
        wind = _interpolate(data["wind"].stamps_s, data["wind"].values, grid_abs,
                            GAP_TOLERANCE_PERIODS / max(meta.rates_hz["wind"], 1e-9))
    fix = columns["gnss_fix"]
    east, north, vel = _positions(fix, columns["gnss_vel"], grid_abs, period, origin, meta, derive_velocity)
    imu = columns["imu"]
    return Trial(
        t_s=grid_abs - t0,
        thrust_left_N=columns["thrust_left"],
        thrust_right_N=columns["thrust_right"],
        angle_left_rad=columns["angle_left"],
        angle_right_rad=columns["angle_right"],
        lat_deg=fix[:, 0],
        lon_deg=fix[:, 1],
        east_m=east,
        north_m=north,
        vel_east_mps=vel[:, 0],
        vel_north_mps=vel[:, 1],
        heading_rad=imu[:, 0],
        yaw_rate_radps=imu[:, 1],
        accel_x_mps2=imu[:, 2],
        accel_y_mps2=imu[:, 3],
        metadata=meta,
        command_switch_s=switch if switch is not None and np.any(switch != 0.0) else None,
        gnss_bridged=bridged if bridged is not None and bridged.any() else None,
        wind_east_mps=None if wind is None else wind[:, 0],
        wind_north_mps=None if wind is None else wind[:, 1],
    )


def _checked_streams(streams: dict[str, Stream], source: str, meta: TrialMetadata) -> dict[str, Stream]:
    """Stage 1: each role's stream checked, its stamps monotone, a GNSS row with a NaN dropped; counts, rates and
    the missing roles into ``meta``."""
    data = {}
    for role in COMMAND_ROLES + SENSOR_ROLES + MEASURED_INPUT_ROLES:
        stream = streams.get(role)
        if stream is None or np.asarray(stream.stamps_s).size == 0:
            if role not in MEASURED_INPUT_ROLES:  # an anemometer is a bonus, not a missing stream
                meta.missing.append(role)
            continue
        _check_values(source, role, stream)
        data[role] = _monotone_stream(role, stream, meta)
        if data[role].stamps_s.size == 0:
            raise InputError(f"{source}: {role}: none of its {np.asarray(stream.stamps_s).size} sample(s) has a "
                             "finite time stamp")
        if role in ("gnss_fix", "gnss_vel"):  # an IMU field may be NaN by design (REP-145: not provided)
            data[role] = _drop_nan_rows(role, data[role], meta)
        meta.counts[role] = int(np.asarray(stream.stamps_s).size)
        period = _median_period_s(data[role].stamps_s)
        meta.rates_hz[role] = 1.0 / period if np.isfinite(period) and period > 0 else 0.0
    return data


def _grid(data: dict[str, Stream], source: str, meta: TrialMetadata) -> tuple[np.ndarray, float]:
    """Stage 2: the grid (absolute stamps, s) at the GNSS period, from the first command (or GNSS, if that comes
    more than the gap tolerance later) to the last GNSS sample; its start into ``meta``; and the period, s."""
    clock = data.get("gnss_vel") or data.get("gnss_fix")
    if clock is None or clock.stamps_s.size < 2:
        raise InputError(f"{source}: no GNSS velocity or fix stream (need at least 2 samples)")
    commands = [data[r] for r in COMMAND_ROLES if r in data]
    if not commands:
        raise InputError(f"{source}: no command stream (thrusters/*/thrust or pos)")
    period = _median_period_s(clock.stamps_s)
    t0, t1 = float(clock.stamps_s[0]), float(clock.stamps_s[-1])
    _check_span(source, "gnss_vel" if "gnss_vel" in data else "gnss_fix", clock.stamps_s, period)
    first_command = min(float(c.stamps_s[0]) for c in commands)
    if first_command > t1:
        raise InputError(f"{source}: commands and GNSS do not overlap in time (first command after the last fix)")
    t0 = first_command if t0 - GAP_TOLERANCE_PERIODS * period <= first_command else t0
    meta.start_time_s = t0
    return t0 + np.arange(int(np.floor((t1 - t0) / period + 1e-6)) + 1) * period, period


def _commands_on_grid(data: dict[str, Stream], streams: dict[str, Stream], grid_abs: np.ndarray, period: float,
                      release: bool) -> tuple[dict[str, np.ndarray], np.ndarray | None]:
    """Stage 3: each command held on the grid (an absent angle 0, an absent thrust NaN), and the mean offset of
    the commands' changes from their grid samples (None: no command)."""
    columns: dict[str, np.ndarray] = {}
    offsets = []
    for role in COMMAND_ROLES:
        columns[role] = _hold(data[role].stamps_s, data[role].values[:, 0], grid_abs, period) if role in data \
            else np.full(grid_abs.size, 0.0 if role.startswith("angle") else np.nan)
        if role in data:
            offsets.append(_switch_offsets(data[role].stamps_s, data[role].values[:, 0], grid_abs, period))
        if release:
            data.pop(role, None)
            streams.pop(role, None)
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # no role changed at most samples: an all-NaN mean
        switch = np.nan_to_num(np.nanmean(np.array(offsets), axis=0), nan=0.0) if offsets else None
    return columns, switch


def _sensors_on_grid(data: dict[str, Stream], streams: dict[str, Stream], grid_abs: np.ndarray,
                     meta: TrialMetadata, columns: dict[str, np.ndarray], release: bool) -> np.ndarray | None:
    """Stage 4: each sensor interpolated on the grid into ``columns`` (NaN across its gaps, recorded in ``meta``;
    the IMU heading unwrapped first); returns the GNSS velocity's bridged samples (None: no velocity stream)."""
    t0 = meta.start_time_s
    bridged: np.ndarray | None = None
    for role, width in (("gnss_fix", 3), ("gnss_vel", 2), ("imu", 4)):
        if role not in data:
            columns[role] = np.full((grid_abs.size, width), np.nan)
            continue
        stream = data[role]
        max_gap = GAP_TOLERANCE_PERIODS / max(meta.rates_hz[role], 1e-9)
        if role == "gnss_vel":
            bridged = _bridged(stream.stamps_s, grid_abs, 1.0 / max(meta.rates_hz[role], 1e-9))
        if role == "imu":  # unwrap the heading before interpolating it
            yaw = stream.values[:, :1].copy()
            known = np.isfinite(yaw[:, 0])  # a yaw not provided (NaN) must not poison the unwrap after it
            yaw[known, 0] = np.unwrap(yaw[known, 0])
            columns[role] = np.empty((grid_abs.size, stream.values.shape[1]))
            _interpolate(stream.stamps_s, yaw, grid_abs, max_gap, columns[role][:, :1])
            _interpolate(stream.stamps_s, stream.values[:, 1:], grid_abs, max_gap, columns[role][:, 1:])
        else:
            columns[role] = _interpolate(stream.stamps_s, stream.values, grid_abs, max_gap)
        jumps = np.flatnonzero(np.diff(stream.stamps_s) > max_gap)
        meta.gaps += [(role, float(stream.stamps_s[j] - t0), float(stream.stamps_s[j + 1] - t0)) for j in jumps]
        if release:
            del data[role], streams[role], stream
    return bridged


def _positions(fix: np.ndarray, vel: np.ndarray, grid_abs: np.ndarray, period: float,
               origin: tuple[float, float, float] | None, meta: TrialMetadata,
               derive_velocity: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stage 5: the fixes in the local ENU frame about ``origin`` (default: the first fix; into ``meta``), and the
    velocity over ground (n, 2), derived from the positions where no velocity was recorded."""
    t0 = meta.start_time_s
    if origin is None:
        valid = np.flatnonzero(np.all(np.isfinite(fix), axis=1))
        lat, lon, alt = (float(x) for x in fix[valid[0]]) if valid.size else (0.0, 0.0, 0.0)
        origin = (lat, lon, alt)
    meta.origin = origin
    east, north = np.empty(grid_abs.size), np.empty(grid_abs.size)
    for start in range(0, grid_abs.size, GRID_BLOCK):
        block = slice(start, start + GRID_BLOCK)
        east[block], north[block], _ = pymap3d.geodetic2enu(fix[block, 0], fix[block, 1], fix[block, 2], *origin)
    if derive_velocity and "gnss_vel" in meta.missing and "gnss_fix" in meta.counts:
        vel_east, vel_north, meta.speed_smoothing_s, meta.derived_speed_noise_mps, how = velocity_from_positions(
            east, north, period)
        vel = np.column_stack([vel_east, vel_north])
        meta.missing.remove("gnss_vel")
        meta.derived["gnss_vel"] = how
        meta.topics["gnss_vel"] = f"derived from {meta.topics.get('gnss_fix', 'gnss_fix')}"
        meta.gaps += _nan_runs("gnss_vel", grid_abs - t0, vel_east)
    return east, north, vel


def thrust_outliers(trial: Trial, bollard_thrust_N: float, factor: float = 5.0) -> str | None:
    """A warning naming the thrust samples beyond ``factor`` times the boat's bollard thrust (physically
    possible by :data:`VALUE_LIMITS`, yet no command this boat can give: a unit or logging error that would pull
    a fit), with their count, the largest and the first time; None if there are none."""
    limit = factor * bollard_thrust_N
    named = []
    for role, thrust in (("thrust_left", trial.thrust_left_N), ("thrust_right", trial.thrust_right_N)):
        beyond = np.flatnonzero(np.abs(np.nan_to_num(thrust)) > limit)
        if beyond.size:
            named.append(f"{role}: {beyond.size} sample(s) beyond {limit:.4g} N ({factor:g} x the boat's bollard "
                         f"thrust), up to {np.max(np.abs(thrust[beyond])):.4g} N, first at t = "
                         f"{trial.t_s[beyond[0]]:.1f} s")
    return "; ".join(named) or None


def long_holds(trial: Trial, limit_s: float, reason: str) -> str | None:
    """A warning naming each thrust command held at one exact value longer than ``limit_s`` (``reason``: what
    the limit is, in words): its role, value, span and how many such holds; None if there are none. A held value
    is the zero-order hold of the command stream, so a stream that stopped publishing looks exactly like a helm
    that held still: the warning says both."""
    named = []
    for role, thrust in (("thrust_left", trial.thrust_left_N), ("thrust_right", trial.thrust_right_N)):
        topics = trial.metadata.topics
        if thrust.size < 2 or (role not in topics and ("thrust_left" in topics or "thrust_right" in topics)):
            continue  # a slot with no stream (a single thruster's second): nothing was held
        starts = np.flatnonzero(np.r_[True, thrust[1:] != thrust[:-1]])  # NaN != NaN: every NaN its own run
        ends = np.r_[starts[1:], thrust.size - 1]  # a run lasts until the next value (or the trial's end)
        spans = trial.t_s[ends] - trial.t_s[starts]
        long = np.flatnonzero((spans > limit_s) & np.isfinite(thrust[starts]))
        if long.size:
            i = long[np.argmax(spans[long])]
            t0, t1 = trial.t_s[starts[i]], trial.t_s[ends[i]]
            more = f" (and {long.size - 1} more such hold(s))" if long.size > 1 else ""
            named.append(f"{role}: {thrust[starts[i]]:.4g} N held unchanged for {spans[i]:.0f} s, t = {t0:.1f} to "
                         f"{t1:.1f} s{more}")
    if not named:
        return None
    return (f"{'; '.join(named)}: longer than {limit_s:.0f} s ({reason}); a command stream that stopped "
            "publishing is held the same way: check the log there")
