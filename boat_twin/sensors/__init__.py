"""Sensor models (GNSS receiver, UM7 AHRS): ground truth -> seeded, noisy measurements.

This module holds what both models share: config validation, reading a config from a YAML mapping,
rate decimation and coloured (Gauss-Markov) noise. The models live in :mod:`boat_twin.sensors.gnss`
and :mod:`boat_twin.sensors.um7`, each as two pieces:

- an expected-measurement function (``gnss.expected_fix``, ``um7.expected_imu``): what the sensor reads
  without noise (latency, antenna height, gravity, frames), deterministic and vectorised over samples and
  boats (or replay windows);
- a noise process (``gnss.GnssNoise``, ``um7.Um7Noise``) that owns its random state (Gauss-Markov states,
  gyro bias random walk, the RNG): ``step()`` draws the next sample's errors (a live twin, tick by tick),
  ``run(n)`` the next n at once (a batch record).

``Model.measure(truth)`` is the batch composition of both; the live twin composes them per tick, keeping one
noise process per sensor, so live noise has the batch statistics. ``Model.measure_chunks(truth, ticks)`` gives
the same measurements a block of truth ticks at a time, bit for bit (:func:`positioned_generators`), so a long
trial never holds all its measurements.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Literal

import numpy as np

from boat_twin.errors import InputError

__all__ = ["RATE_TOLERANCE", "GaussMarkov", "decimation_step", "gauss_markov", "positioned_generators"]

DrawKind = Literal["normal", "uniform"]
"""What a block of draws is: standard normal (``Generator.standard_normal``) or uniform on [0, 1)
(``Generator.random``)."""
SKIP_PIECE_VALUES = 1 << 16
"""Values drawn (and discarded) at a time while skipping a block in :func:`positioned_generators`."""

RATE_TOLERANCE = 1e-6
"""Relative tolerance when checking that a sensor rate divides the truth output rate."""


def decimation_step(t_s: np.ndarray, rate_hz: float, where: str) -> int:
    """Keep every k-th truth sample for a sensor at ``rate_hz``; k must be a whole number >= 1.

    Raises InputError naming ``where`` if the rate exceeds the truth rate or does not divide it.
    """
    if t_s.size < 2:
        return 1
    dt_s = float(np.median(np.diff(t_s)))
    truth_rate_hz = 1.0 / dt_s
    ratio = truth_rate_hz / rate_hz
    step = round(ratio)
    if step < 1 or abs(ratio - step) > RATE_TOLERANCE * ratio:
        raise InputError(
            f"{where}: {rate_hz:g} Hz must divide the {truth_rate_hz:g} Hz truth output rate "
            f"(one sample in every whole number of truth samples)"
        )
    return step


def positioned_generators(rng: np.random.Generator, blocks: Sequence[tuple[DrawKind, int]]
                          ) -> list[np.random.Generator]:
    """One generator per block of ``blocks`` (kind, number of values), the blocks being drawn one after the
    other from ``rng``: generator i starts where block i starts in ``rng``'s stream, and ``rng`` is left after
    the last block.

    A record's noise drawn kind by kind (all position errors, then all velocity errors, ...) can then be drawn
    chunk by chunk with the same values: numpy's Generator fills arrays value after value, so drawing n values
    in pieces gives the same values as drawing them at once. Skipping a block draws it in pieces of
    :data:`SKIP_PIECE_VALUES` (memory bounded, about 10 ns per value).
    """
    generators = []
    for kind, count in blocks:
        copy = np.random.Generator(type(rng.bit_generator)())
        copy.bit_generator.state = rng.bit_generator.state
        generators.append(copy)
        draw = rng.standard_normal if kind == "normal" else rng.random
        for start in range(0, count, SKIP_PIECE_VALUES):
            draw(min(SKIP_PIECE_VALUES, count - start))
    return generators


class GaussMarkov:
    """First-order Gauss-Markov noise with its state: ``run(n)`` continues it by n samples (n = 1: one step).

    e[k] = a e[k-1] + sqrt(1 - a^2) stdev w[k], a = exp(-dt/tau), w standard normal from ``rng``; the first
    sample is drawn from the stationary distribution, later calls continue from the last sample.
    ``correlation_time_s`` 0 gives white noise (no memory).
    """

    def __init__(self, rng: np.random.Generator, dims: int, stdev: float | np.ndarray, dt_s: float,
                 correlation_time_s: float) -> None:
        self.rng = rng
        self.dims = dims
        self.stdev = stdev
        """Stationary stdev per column, in the noise's unit."""
        self.a = math.exp(-dt_s / correlation_time_s) if correlation_time_s > 0.0 else 0.0
        """Sample-to-sample correlation exp(-dt/tau); 0 for white noise."""
        self._unit: np.ndarray | None = None  # last sample / stdev, (dims,); None before the first

    def run(self, n: int) -> np.ndarray:
        """The next ``n`` samples, shape (n, dims); draws one standard normal (n, dims) block."""
        white = self.rng.standard_normal((n, self.dims))
        if self.a == 0.0 or n == 0:
            return white * self.stdev
        from scipy.signal import lfilter

        drive = white * math.sqrt(1.0 - self.a * self.a)
        if self._unit is None:
            drive[0] = white[0]
            unit = lfilter([1.0], [1.0, -self.a], drive, axis=0)
        else:
            unit, _ = lfilter([1.0], [1.0, -self.a], drive, axis=0, zi=self.a * self._unit[None, :])
        self._unit = unit[-1]
        return unit * self.stdev


def gauss_markov(rng: np.random.Generator, n: int, dims: int, stdev: float | np.ndarray, dt_s: float,
                 correlation_time_s: float) -> np.ndarray:
    """Zero-mean stationary noise, shape (n, dims), stdev ``stdev`` per column: a fresh :class:`GaussMarkov`
    run over ``n`` samples of ``dt_s``."""
    return GaussMarkov(rng, dims, stdev, dt_s, correlation_time_s).run(n)
