"""Zigzag features → turning coefficients: Pashentsev (2025)'s network and nearest trajectory, reproduced, beside
the output-error fit (boat_twin.ident.manoeuvring) on the same hidden boats.

Needs scikit-learn (the ``bench`` extra, not a runtime dependency): ``.venv/bin/pip install scikit-learn``.
Run: .venv/bin/python benchmarks/bench_zigzag_inverse.py [--samples 600] [--large 10000] [--fit-boats 5] [--seed 0]
[--noise-draws 1] [--max-iterations 4000] [--large-nets 64 64x64]
Nothing is asserted: the script prints Markdown tables for docs/studies/identification.md and the command that
made them.

Training sets (the paper's recipe on this boat): every manoeuvring coefficient (m22, m33, a_v, a_r, Y_vv, N_rr
and x_c) drawn normally around the twin's with a standard deviation of 10 % (z clipped to ±3) and the steering
offset with 0.5° (the features record the outboards' actual angle, command + offset), one 20°/20°
zigzag at 6 m/s each (helm at the 10 Hz log rate), simulated as one ensemble (each boat its own coefficients in
one kernel run) and summarised by the 42 features (:mod:`boat_twin.ident.zigzag_features`); split 400/100/100
(train / verification / test) as the paper, and 80/10/10 % of ``--large`` (10^4; simulated for the length of
the noisy trial, :data:`TRIAL_S`, as the noisy set below is made from the same runs).
Measured (noisy) training features: each boat's simulated truth measured by the twin's own GNSS and UM7 models
(default noise, each boat its own seed; ``--noise-draws`` independent measurements of every training boat)
and put on a trial grid as a bag reader does (:func:`~boat_twin.twin.sea_trial.measured_trial`), then
summarised like a recorded trial (:func:`~boat_twin.ident.zigzag_features.measured_ensemble_features`): the
features carry the noise the sensors put into them, not a noise assumed per feature. Same splits; the
verification and test splits measured once.
Inverse maps, standardised features → coefficients: a scikit-learn MLP (tanh, L-BFGS; sizes and weight decay of
:data:`SMALL_GRID` / :data:`LARGE_GRID`, the one with the lowest verification error kept) trained with early
stopping on the verification split (:func:`train_mlp`), and the nearest training sample (1-NN in standardised
features; and the paper's criterion, below).
Evaluated as the paper does: the SD ratio per coefficient (its "Perf": SD of the prediction error / SD of the
coefficient; 1 = no better than predicting the mean), and the trajectory SD — the paper's Fig. 15: each 42-feature
vector min-max scaled over its own components, the SD of the difference between the target's and the candidate's
(the MLP's answer re-simulated; the nearest training sample, found by that same SD) — and by the parameter error.
Output-error fit: ``--fit-boats`` hidden boats of the small set's test split, one 20°/20° zigzag at 6 m/s of
120 s with the default sensor noise (written to a bag and read back), ``fit_manoeuvring`` from the twin's
coefficients, and from the answers for the measured features of that same trial of the 600-sample MLP trained on
noise-free features and of the largest set's MLP trained on measured features (is the network a useful starting
point?).
Speed: zigzags per second, one simulate() per boat against the ensemble, in the same run.
Sensitivity (the paper's Fig. 17, Statistica's analysis): each input of a trained MLP replaced by its mean (and,
apart, shuffled across the samples), the error over the error with all inputs, ranked; beside the ranks of
VAR1-14 the paper shows. And the features that do not vary over the noise-free set, with the actual rudder angle
and with the commanded one.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time
import warnings
from copy import deepcopy
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.errors import InputError
from boat_twin.ident.manoeuvring import apply_parameters, fit_manoeuvring
from boat_twin.ident.manoeuvring_trials import recorded
from boat_twin.ident.zigzag_features import (
    FEATURE_NAMES,
    ensemble_features,
    measured_ensemble_features,
    trial_features,
)
from boat_twin.twin.sea_trial import run_sea_trial
from boat_twin.vessel.params import MANOEUVRING_KEYS, VesselParams, derive_coefficients
from boat_twin.vessel.scenarios import Zigzag
from boat_twin.vessel.simulate import OUTPUT_RATE_HZ, simulate

try:
    from sklearn.exceptions import ConvergenceWarning
    from sklearn.neighbors import KNeighborsRegressor
    from sklearn.neural_network import MLPRegressor
    from sklearn.preprocessing import StandardScaler
    from threadpoolctl import threadpool_limits
except ImportError:
    print("this benchmark needs scikit-learn (setup.py's bench extra): .venv/bin/pip install scikit-learn",
          file=sys.stderr)
    raise SystemExit(2) from None

KEYS = MANOEUVRING_KEYS + ("lateral_centre_x_m", "steering_offset_rad")
"""The parameters perturbed and mapped back (the paper's 19 model parameters, on this model): the seven
coefficients and the outboards' steering offset, the eight the output-error fit identifies."""
COEFFICIENTS = len(KEYS) - 1
"""The first seven of :data:`KEYS` (the headline median errors are over these, as before the offset joined)."""
SPREAD = 0.10
"""Standard deviation of the perturbation, relative (Pashentsev 2025: normal, 10 %)."""
OFFSET_SD_RAD = math.radians(0.5)
"""Standard deviation of the steering offset, rad (its default is 0, so no relative spread: a linkage set
within about ±1°, as the hidden boats of :func:`~boat_twin.ident.manoeuvring_trials.draw_boat`). The actual
rudder angle the features record is the command plus this offset."""
PAPER_FIG17 = {  # VAR1..VAR14 = the first two events' seven values, in the order the paper stores them
    "rank": (2, 19, 29, 6, 33, 35, 26, 17, 8, 1, 13, 28, 42, 34),
    "ratio": (1.752967, 1.195139, 1.111512, 1.507133, 1.069128, 1.032849, 1.138822, 1.211143, 1.472674,
              1.85842, 1.277084, 1.115297, 1.0, 1.0631),
}
"""Pashentsev (2025) Fig. 17, the part the paper shows: Statistica's sensitivity of the best network to VAR1-14
(rank 1 = most relied on; ratio = error with the input ignored / baseline error 0.002233). The paper stores
each event's values as Tzig, Xzig, Yzig, Vzig, DKzig, Rulzig, Omzig, event after event (our order of
:data:`~boat_twin.ident.zigzag_features.VALUES`): VAR1-7 are the first equality, VAR8-14 the first extreme —
our reading, as the paper does not print the file's column order."""
SPEED_MPS = 6.0
DURATION_S = 75.0
"""Zigzag length for the features, s: the third extreme comes 32 s after the execute (10 s approach) on the
twin, up to ~55 s on the slowest-turning boats drawn."""
TRIAL_S = 120.0
"""Length of the noisy trial the output-error fit gets, s (six 20 s windows: the fit's minimum)."""
BATCH = 2000
"""Boats per ensemble run (bounds the record: 750 ticks × 2000 boats × 144 bytes ≈ 220 MB)."""
Grid = tuple[tuple[tuple[int, ...], float, int], ...]
SMALL_GRID: Grid = (((22,), 1e-3, 4000), ((44,), 1e-2, 4000))
"""MLPs (hidden layers, weight decay, iteration cap) tried on the small set, the best on its verification split
kept."""
LARGE_GRID: Grid = (((64,), 1e-4, 4000), ((64, 64), 1e-4, 4000))
"""MLPs tried on the large set (``--large-nets`` chooses among them, ``--max-iterations`` sets the caps), the best
on its verification split kept."""
CHECK_ITERATIONS = 100
"""L-BFGS iterations between two checks of the verification error (early stopping)."""
PATIENCE = 3
"""Checks in a row without a verification error :data:`IMPROVEMENT` below the best so far that stop a training."""
IMPROVEMENT = 0.01
"""Relative fall of the verification error that counts as progress."""
NOISE_SEED = 1_000_000
"""Seed of the first training boat's sensor noise (the hidden boats' trials use 7000 + j)."""
PAPER: dict[str, Any] = {"perf": (0.9957, 1.042, 1.127), "sd_net": 6.389e-3, "sd_nearest": 4.028e-3}
"""Pashentsev (2025), Fig. 10 (best network, train / verification / test "Perf") and eq. (3)."""


def zigzag(vessel: VesselParams, duration_s: float = DURATION_S) -> Zigzag:
    angle = math.radians(20.0)
    return Zigzag(vessel, angle, angle, speed_mps=SPEED_MPS, duration_s=duration_s, decision_rate_hz=OUTPUT_RATE_HZ)


def centre_of(base: VesselParams) -> np.ndarray:
    """(8,) the parameters (:data:`KEYS`) of ``base``."""
    coeff = derive_coefficients(base)
    return np.array([getattr(coeff, k) for k in MANOEUVRING_KEYS]
                    + [base.lateral_centre_x_m, base.steering_offset_rad])


def draw(base: VesselParams, n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, 8) parameters (:data:`KEYS`) drawn normally around ``base``'s: the coefficients with SD :data:`SPREAD`
    relative, the offset with SD :data:`OFFSET_SD_RAD` (z clipped to ±3)."""
    z = np.clip(rng.standard_normal((n, len(KEYS))), -3.0, 3.0)
    spread = np.array([SPREAD] * COEFFICIENTS + [0.0])
    shift = np.array([0.0] * COEFFICIENTS + [OFFSET_SD_RAD])
    return centre_of(base) * (1.0 + spread * z) + shift * z


def boat(base: VesselParams, values: np.ndarray) -> VesselParams:
    return replace(base, manoeuvring={k: float(v) for k, v in zip(MANOEUVRING_KEYS, values, strict=False)},
                   lateral_centre_x_m=float(values[COEFFICIENTS - 1]), steering_offset_rad=float(values[-1]))


def features_of(base: VesselParams, values: np.ndarray, duration_s: float = DURATION_S,
                actual_rudder: bool = True) -> np.ndarray:
    """(n, 42) noise-free zigzag features of the boats ``values`` (ensemble runs of :data:`BATCH`; the rudder the
    actual angle, or the command)."""
    out = []
    for lo in range(0, len(values), BATCH):
        boats = [boat(base, v) for v in values[lo:lo + BATCH]]
        out.append(ensemble_features(simulate(base, zigzag(base, duration_s), boats=boats), actual_rudder))
    return np.concatenate(out)


def clean_and_measured(config: TwinConfig, values: np.ndarray, draws: int, seed: int
                       ) -> tuple[np.ndarray, np.ndarray, float]:
    """Noise-free features (n, 42) and ``draws`` measured feature sets (draws, n, 42) of the boats ``values``,
    from one :data:`TRIAL_S` zigzag each (noise of boat i, draw k seeded ``seed + k·n + i``), and the seconds
    spent measuring."""
    clean, measured, measuring_s = [], [], 0.0
    base, n = config.vessel, len(values)
    for lo in range(0, n, BATCH):
        boats = [boat(base, v) for v in values[lo:lo + BATCH]]
        record = simulate(base, zigzag(base, TRIAL_S), boats=boats)
        clean.append(ensemble_features(record))
        start = time.perf_counter()
        seeds = seed + np.arange(lo, lo + len(boats))
        measured.append(np.stack([measured_ensemble_features(record, config, seeds + k * n) for k in range(draws)]))
        measuring_s += time.perf_counter() - start
    return np.concatenate(clean), np.concatenate(measured, axis=1), measuring_s


def paper_sd(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Pashentsev (2025) Fig. 15: SD of the difference of two 42-vectors, each min-max scaled over its own
    components (rows of ``a`` against rows or one row of ``b``)."""
    def scaled(v: np.ndarray) -> np.ndarray:
        lo, hi = v.min(axis=-1, keepdims=True), v.max(axis=-1, keepdims=True)
        return (v - lo) / (hi - lo)
    return np.std(scaled(a) - scaled(b), axis=-1)


@dataclass
class Split:
    train: np.ndarray
    verify: np.ndarray
    test: np.ndarray


def split(n: int, rng: np.random.Generator, verify: int, test: int) -> Split:
    order = rng.permutation(n)
    return Split(order[verify + test:], order[:verify], order[verify:verify + test])


def sd_ratio(predicted: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Per coefficient: SD of the prediction error / SD of the coefficient (the paper's "Perf")."""
    return np.std(predicted - truth, axis=0) / np.std(truth, axis=0)


def relative_error(predicted: np.ndarray, truth: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """Error relative to the value (x_c: relative to the centre's size, |x_c| = 1 m here); the offset's error
    absolute, rad."""
    scale = np.abs(truth).copy()
    scale[:, COEFFICIENTS - 1] = abs(centre[COEFFICIENTS - 1])
    scale[:, -1] = 1.0
    return (predicted - truth) / scale


@dataclass
class Trained:
    """One MLP trained with early stopping: the weights of its best verification error."""

    net: MLPRegressor
    hidden: tuple[int, ...]
    alpha: float
    cap: int
    verify_mse: float
    """Mean squared error on the verification split, standardised coefficients."""
    iterations: int
    """L-BFGS iterations to the kept weights."""
    ran: int
    """L-BFGS iterations run (the kept ones and those past them until the patience ran out)."""
    seconds: float


def train_mlp(x: np.ndarray, y: np.ndarray, verify_x: np.ndarray, verify_y: np.ndarray, hidden: tuple[int, ...],
              alpha: float, cap: int, seed: int) -> Trained:
    """An MLP trained by L-BFGS, :data:`CHECK_ITERATIONS` at a time, until :data:`PATIENCE` checks in a row bring
    no verification error :data:`IMPROVEMENT` below the best so far (or L-BFGS converges, or
    ``cap`` iterations); the weights of the lowest verification error are kept."""
    net = MLPRegressor(hidden_layer_sizes=hidden, activation="tanh", solver="lbfgs", alpha=alpha,
                       max_iter=CHECK_ITERATIONS, warm_start=True, random_state=seed)
    start = time.perf_counter()
    best: Trained | None = None
    ran, stale, reference = 0, 0, np.inf
    while ran < cap and stale < PATIENCE:
        # One BLAS thread: these matrices are small, and threads only contend on a shared 2-core machine.
        with warnings.catch_warnings(), threadpool_limits(1):
            warnings.simplefilter("ignore", ConvergenceWarning)
            net.fit(x, y)
        ran += net.n_iter_
        error = float(np.mean((net.predict(verify_x) - verify_y) ** 2))
        if best is None or error < best.verify_mse:
            best = Trained(deepcopy(net), hidden, alpha, cap, error, ran, ran, 0.0)
        stale = 0 if error < reference * (1.0 - IMPROVEMENT) else stale + 1
        reference = min(reference, error)
        print(f"  {hidden} alpha {alpha:g}: {ran} iterations, verification MSE {error:.4f}, "
              f"{time.perf_counter() - start:.0f} s", file=sys.stderr)
        if net.n_iter_ < CHECK_ITERATIONS:  # converged: more iterations change nothing
            break
    assert best is not None
    best.ran, best.seconds = ran, time.perf_counter() - start
    return best


class InverseMaps:
    """The two inverse maps trained on one set: MLP (the grid's best on the verification split) and 1-NN."""

    def __init__(self, x: np.ndarray, y: np.ndarray, s: Split, seed: int, grid: Grid,
                 train_x: np.ndarray | None = None, train_y: np.ndarray | None = None) -> None:
        """``train_x``/``train_y`` replace the training split (e.g. several noise draws of it)."""
        train_x = x[s.train] if train_x is None else train_x
        train_y = y[s.train] if train_y is None else train_y
        self.x_scale = StandardScaler().fit(train_x)
        self.y_scale = StandardScaler().fit(train_y)
        xs, ys = self.x_scale.transform(train_x), self.y_scale.transform(train_y)
        self.tried = [train_mlp(xs, ys, self.x_scale.transform(x[s.verify]), self.y_scale.transform(y[s.verify]),
                                hidden, alpha, cap, seed) for hidden, alpha, cap in grid]
        self.best = min(self.tried, key=lambda t: t.verify_mse)
        self.net, self.hidden, self.alpha = self.best.net, self.best.hidden, self.best.alpha
        self.train_s = sum(t.seconds for t in self.tried)
        self.nearest = KNeighborsRegressor(n_neighbors=1).fit(xs, train_y)
        self.low, self.high = train_y.min(axis=0), train_y.max(axis=0)

    def describe(self) -> str:
        return "; ".join(f"{t.hidden} alpha {t.alpha:g}: verification MSE {t.verify_mse:.4f} after {t.iterations} "
                         f"iterations (of {t.ran}{', the cap' if t.ran >= t.cap else ''}), {t.seconds:.1f} s"
                         for t in self.tried)

    def mlp(self, x: np.ndarray) -> np.ndarray:
        """The network's answer, clipped to the training set's range (an answer far outside, e.g. a negative
        drag coefficient, is no model to simulate or start a fit from)."""
        answer = self.y_scale.inverse_transform(self.net.predict(self.x_scale.transform(x)))
        return np.clip(answer, self.low, self.high)

    def knn(self, x: np.ndarray) -> np.ndarray:
        return self.nearest.predict(self.x_scale.transform(x))


@dataclass
class Study:
    """One set's inverse maps and their figures on its test split."""

    maps: InverseMaps
    perf_mlp: list[float]
    """The MLP's mean SD ratio on the training, verification and test splits."""
    ratio_mlp: np.ndarray
    ratio_knn: np.ndarray
    ratio_paper_nearest: np.ndarray
    err_mlp: np.ndarray
    err_knn: np.ndarray
    err_paper_nearest: np.ndarray
    sd_mlp: np.ndarray
    sd_near: np.ndarray
    ratio_clean_net: np.ndarray = field(default_factory=lambda: np.empty(0))
    """Measured sets: the MLP trained on the noise-free features, on the measured test split."""
    err_clean_net: np.ndarray = field(default_factory=lambda: np.empty(0))


def evaluate(maps: InverseMaps, x: np.ndarray, y: np.ndarray, centre: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The MLP's SD ratios (per coefficient) and relative errors (per sample and coefficient) on ``x``."""
    answer = maps.mlp(x)
    return sd_ratio(answer, y), relative_error(answer, y, centre)


def study(name: str, base: VesselParams, y: np.ndarray, x: np.ndarray, s: Split, seed: int,
          centre: np.ndarray, grid: Grid, target: np.ndarray | None = None, train_x: np.ndarray | None = None,
          train_y: np.ndarray | None = None) -> Study:
    """Train both maps on one set and evaluate them on its test split (SD ratios, errors, trajectory SD).
    ``target``: the noise-free features the re-simulated answers are compared with (default ``x``);
    ``train_x``/``train_y``: training rows other than ``x[s.train]`` (several noise draws)."""
    target = x if target is None else target
    maps = InverseMaps(x, y, s, seed, grid, train_x, train_y)
    test = s.test
    mlp, knn = maps.mlp(x[test]), maps.knn(x[test])
    perf = [float(np.mean(sd_ratio(maps.mlp(x[idx]), y[idx]))) for idx in (s.train, s.verify, test)]
    # Trajectory SD (paper): the MLP's answer re-simulated; the nearest training sample by the paper's own SD.
    resim = features_of(base, mlp)
    sd_mlp = paper_sd(resim, target[test])
    closest = np.array([int(np.argmin(paper_sd(x[s.train], x[i]))) for i in test])
    sd_near = paper_sd(target[s.train][closest], target[test])
    nearest_paper = y[s.train][closest]
    print(f"{name}: {maps.describe()}; {np.isnan(sd_mlp).sum()} re-simulated answers without all six events",
          file=sys.stderr)
    return Study(maps, perf, sd_ratio(mlp, y[test]), sd_ratio(knn, y[test]), sd_ratio(nearest_paper, y[test]),
                 relative_error(mlp, y[test], centre), relative_error(knn, y[test], centre),
                 relative_error(nearest_paper, y[test], centre), sd_mlp, sd_near)


def noisy_study(name: str, base: VesselParams, y: np.ndarray, measured: np.ndarray, clean: np.ndarray, s: Split,
                seed: int, centre: np.ndarray, grid: Grid, clean_maps: InverseMaps) -> Study:
    """:func:`study` on measured features (every draw of the training split; the first draw of the verification
    and test splits), and the MLP trained on noise-free features evaluated on the same measured test split."""
    train_x = measured[:, s.train].reshape(-1, measured.shape[-1])
    train_y = np.tile(y[s.train], (measured.shape[0], 1))
    r = study(name, base, y, measured[0], s, seed, centre, grid, target=clean, train_x=train_x, train_y=train_y)
    r.ratio_clean_net, r.err_clean_net = evaluate(clean_maps, measured[0][s.test], y[s.test], centre)
    return r


def sensitivity(maps: InverseMaps, x: np.ndarray, y: np.ndarray, rng: np.random.Generator
                ) -> tuple[np.ndarray, np.ndarray]:
    """Per input feature, the network's error (RMS over the standardised parameters) on ``x`` → ``y`` with that
    input ignored, over its error with all inputs: Statistica's sensitivity ratio (Pashentsev 2025 Fig. 17; the
    input replaced by its training mean, i.e. 0 standardised) and the permutation ratio (the input shuffled
    across the samples, which keeps its distribution). Rank 1 = the largest ratio."""
    xs, ys = maps.x_scale.transform(x), maps.y_scale.transform(y)

    def rms(inputs: np.ndarray) -> float:
        return float(np.sqrt(np.mean((maps.net.predict(inputs) - ys) ** 2)))

    baseline = rms(xs)
    mean_out, shuffled = np.empty(x.shape[1]), np.empty(x.shape[1])
    for j in range(x.shape[1]):
        ignored = xs.copy()
        ignored[:, j] = 0.0
        mean_out[j] = rms(ignored) / baseline
        ignored[:, j] = xs[rng.permutation(len(xs)), j]
        shuffled[j] = rms(ignored) / baseline
    return mean_out, shuffled


def ranks(ratio: np.ndarray) -> np.ndarray:
    """Rank of each ratio, 1 = the largest (Statistica's convention)."""
    out = np.empty(ratio.size, dtype=int)
    out[np.argsort(-ratio, kind="stable")] = np.arange(1, ratio.size + 1)
    return out


def constant_features(x: np.ndarray) -> list[str]:
    """Names of the features that do not vary over the rows of ``x`` (SD below 10⁻⁹ of their scale)."""
    sd = np.nanstd(x, axis=0)
    scale = np.maximum(np.nanmax(np.abs(x), axis=0), 1e-12)
    return [FEATURE_NAMES[j] for j in np.flatnonzero(sd <= 1e-9 * scale)]


def finite_rows(*arrays: np.ndarray) -> np.ndarray:
    """Rows (boats) with all six events in every feature array (the last axis the 42 features)."""
    return np.all([np.all(np.isfinite(a), axis=-1).reshape(-1, a.shape[-2]).all(axis=0) for a in arrays], axis=0)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=600)
    parser.add_argument("--large", type=int, default=10_000, help="second, larger training set (0: none)")
    parser.add_argument("--fit-boats", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--max-iterations", type=int, default=LARGE_GRID[0][2],
                        help="L-BFGS iteration cap of the large set's MLPs")
    parser.add_argument("--large-nets", nargs="+", default=["x".join(map(str, h)) for h, _, _ in LARGE_GRID],
                        help="hidden layers of the large set's MLPs to try, e.g. 64 64x64")
    parser.add_argument("--noise-draws", type=int, default=1,
                        help="independent sensor-noise measurements of each training boat")
    args = parser.parse_args()
    load_start = os.getloadavg()
    config = TwinConfig()
    base = config.vessel
    rng = np.random.default_rng(args.seed)
    centre = centre_of(base)
    noise_seed = NOISE_SEED * (1 + 2 * args.seed)

    # Speed: one simulate() per boat against one ensemble run, same boats.
    y = draw(base, args.samples, rng)
    features_of(base, y[:2])  # compile
    single_n = min(40, args.samples)
    start = time.perf_counter()
    for v in y[:single_n]:
        simulate(boat(base, v), zigzag(base))
    single_rate = single_n / (time.perf_counter() - start)
    start = time.perf_counter()
    simulate(base, zigzag(base), boats=[boat(base, v) for v in y])
    ensemble_rate = args.samples / (time.perf_counter() - start)
    start = time.perf_counter()
    x = features_of(base, y)
    small_s = time.perf_counter() - start
    constant = {"actual": constant_features(x),
                "commanded": constant_features(features_of(base, y, actual_rudder=False))}
    _, xm, small_measure_s = clean_and_measured(config, y, args.noise_draws, noise_seed)
    ok = finite_rows(x[None], xm)
    y, x, xm = y[ok], x[ok], xm[:, ok]
    dropped = int((~ok).sum())
    sixth = len(y) // 6  # the paper's 400/100/100 of 600
    small_split = split(len(y), rng, sixth, sixth)
    small = study(f"{len(y)} samples", base, y, x, small_split, args.seed, centre, SMALL_GRID)
    small_noisy = noisy_study(f"{len(y)} samples, measured", base, y, xm, x, small_split, args.seed, centre,
                              SMALL_GRID, small.maps)

    large = large_noisy = None
    if args.large:
        y_big = draw(base, args.large, rng)
        start = time.perf_counter()
        x_big, xm_big, large_measure_s = clean_and_measured(config, y_big, args.noise_draws, noise_seed + NOISE_SEED)
        large_s = time.perf_counter() - start
        ok_big = finite_rows(x_big[None], xm_big)
        y_big, x_big, xm_big = y_big[ok_big], x_big[ok_big], xm_big[:, ok_big]
        tenth = len(y_big) // 10
        large_grid = tuple((hidden, alpha, args.max_iterations) for hidden, alpha, _ in LARGE_GRID
                           if "x".join(map(str, hidden)) in args.large_nets)
        big_split = split(len(y_big), rng, tenth, tenth)
        large = study(f"{len(y_big)} samples", base, y_big, x_big, big_split, args.seed, centre, large_grid)
        large_noisy = noisy_study(f"{len(y_big)} samples, measured", base, y_big, xm_big, x_big, big_split,
                                  args.seed, centre, large_grid, large.maps)

    # Output-error fit on hidden boats of the small set's test split, one noisy 120 s zigzag each.
    nets: dict[str, InverseMaps] = {"600 noise-free": small.maps,
                                    "600 measured": small_noisy.maps}
    if large is not None and large_noisy is not None:
        nets[f"{args.large} noise-free"] = large.maps
        nets[f"{args.large} measured"] = large_noisy.maps
    starts = {"twin": "the twin's coefficients", "clean": "the answer of the MLP (600, noise-free features)",
              "noisy": f"the answer of the MLP ({args.large or 600}, measured features)"}
    start_net = {"clean": "600 noise-free", "noisy": f"{args.large or 600} measured"}
    net_err: dict[str, list[np.ndarray]] = {name: [] for name in nets}
    fits: dict[str, dict[str, list[Any]]] = {k: {"err": [], "s": [], "evals": [], "start": [], "failed": []}
                                             for k in starts}
    fit_sd = []
    test = small_split.test[:args.fit_boats]
    with tempfile.TemporaryDirectory(prefix="zigzag_inverse_") as tmp:
        for j, i in enumerate(test):
            true = apply_parameters(config, dict(zip(KEYS, y[i], strict=True)))
            sea = run_sea_trial(true, zigzag(true.vessel, TRIAL_S), 7000 + j)
            trial = recorded(sea, f"boat{j}", Path(tmp))
            measured = trial_features(trial).ravel()[None, :]
            guesses = {name: maps.mlp(measured)[0] for name, maps in nets.items()}
            for name, guess in guesses.items():
                net_err[name].append(relative_error(guess[None], y[i][None], centre)[0])
            line = []
            for key in starts:
                prior = centre if key == "twin" else guesses[start_net[key]]
                try:
                    fit = fit_manoeuvring([trial], apply_parameters(config, dict(zip(KEYS, prior, strict=True))))
                except InputError as err:  # a fit that ends nowhere is a result: counted, not a crash
                    fits[key]["failed"].append(f"boat {j}: {err}")
                    line.append(f"from {key} failed")
                    continue
                fitted = np.array([fit.values[k] for k in KEYS])
                fits[key]["err"].append(relative_error(fitted[None], y[i][None], centre)[0])
                fits[key]["start"].append(relative_error(prior[None], y[i][None], centre)[0])
                fits[key]["s"].append(fit.fit_time_s)
                fits[key]["evals"].append(fit.evaluations)
                if key == "twin":
                    fit_sd.append(float(paper_sd(features_of(base, fitted[None]), x[i])[0]))
                line.append(f"from {key} {fit.fit_time_s:.1f} s ({fit.evaluations} evaluations)")
            print(f"hidden boat {j}: " + ", ".join(line), file=sys.stderr)

    load_end = os.getloadavg()
    print(f"Command: .venv/bin/python benchmarks/bench_zigzag_inverse.py --samples {args.samples} --large "
          f"{args.large} --fit-boats {args.fit_boats} --seed {args.seed} --noise-draws "
          f"{args.noise_draws} --max-iterations {args.max_iterations} --large-nets {' '.join(args.large_nets)}\n")
    print(f"Load average (1/5/15 min) at the start {load_start[0]:.2f} / {load_start[1]:.2f} / {load_start[2]:.2f}, "
          f"at the end {load_end[0]:.2f} / {load_end[1]:.2f} / {load_end[2]:.2f} ({os.cpu_count()} cores)\n")
    print(f"Training-set generation (20°/20° zigzag at 6 m/s, {DURATION_S:g} s): one simulate() per boat "
          f"{single_rate:.0f} zigzags/s; one ensemble run {ensemble_rate:.0f} zigzags/s "
          f"({ensemble_rate / single_rate:.1f}×); with the features {args.samples / small_s:.0f}/s"
          + (f"; {args.large} zigzags of {TRIAL_S:g} s with noise-free and {args.noise_draws} × measured features "
             f"in {large_s:.1f} s (measuring {large_measure_s:.1f} s)" if large is not None else "")
          + f". Boats without all six events (dropped): {dropped} of {args.samples}"
          + (f", {args.large - len(y_big)} of {args.large}" if large is not None else ""))
    print("\nMLP training, L-BFGS with early stopping on the verification split (standardised coefficients' MSE):")
    for label, r in (("600", small), ("600 measured", small_noisy), (f"{args.large}", large),
                     (f"{args.large} measured", large_noisy)):
        if r is not None:
            print(f"- {label}: {r.maps.describe()}")
    med = lambda a: float(np.median(np.abs(np.asarray(a)[..., :COEFFICIENTS])))  # noqa: E731
    print("\n| method | training set | SD ratio (\"Perf\"), mean over coefficients | median parameter error "
          "| trajectory SD (median) |")
    print("| --- | --- | --- | --- | --- |")
    p = PAPER["perf"]
    print(f"| Pashentsev (2025) network, 42-22-19 MLP | 600 (400/100/100) | {p[0]:.3f} / {p[1]:.3f} / {p[2]:.3f} "
          f"(train / verify / test) | not reported | {PAPER['sd_net']:.3e} (one case) |")
    print(f"| Pashentsev (2025) nearest training trajectory | 600 | – | not reported | {PAPER['sd_nearest']:.3e} "
          "(one case) |")
    for label, r, rn in (("600", small, small_noisy), (f"{args.large}", large, large_noisy)):
        if r is None or rn is None:
            continue
        maps_r: InverseMaps = r.maps
        perf = r.perf_mlp
        print(f"| MLP {maps_r.hidden} (scikit-learn) | {label} | {perf[0]:.3f} / {perf[1]:.3f} / {perf[2]:.3f} | "
              f"{med(r.err_mlp):.2%} | {np.nanmedian(r.sd_mlp):.3e} |")
        print(f"| nearest training sample, paper's SD | {label} | test {np.mean(r.ratio_paper_nearest):.3f} | "
              f"{med(r.err_paper_nearest):.2%} | {np.median(r.sd_near):.3e} |")
        print(f"| nearest training sample, standardised features | {label} | test {np.mean(r.ratio_knn):.3f} | "
              f"{med(r.err_knn):.2%} | – |")
        print(f"| same MLP, on the measured features of the test split | {label} | test "
              f"{np.mean(rn.ratio_clean_net):.3f} | {med(rn.err_clean_net):.2%} | – |")
        maps_n: InverseMaps = rn.maps
        perf = rn.perf_mlp
        print(f"| MLP {maps_n.hidden} trained on measured features, on measured features | {label} | "
              f"{perf[0]:.3f} / {perf[1]:.3f} / {perf[2]:.3f} | {med(rn.err_mlp):.2%} | "
              f"{np.nanmedian(rn.sd_mlp):.3e} |")
        print(f"| nearest training sample, standardised measured features | {label} | test "
              f"{np.mean(rn.ratio_knn):.3f} | {med(rn.err_knn):.2%} | – |")
    n = len(test)
    if n:
        for name in nets:
            print(f"| MLP ({name}) on the measured features (bag) of {n} hidden boats | {name.split()[0]} | – | "
                  f"{med(net_err[name]):.2%} | – |")
        print(f"| output-error fit, one noisy 120 s zigzag, {n} hidden boats | none | – | "
              f"{med(fits['twin']['err']):.2%} | {np.median(fit_sd):.3e} |")
    print("\nPer coefficient (test split; SD ratio / median |error|; x_c error relative to |x_c| = 1 m, the "
          "offset's in degrees):\n")
    columns: list[tuple[str, np.ndarray | None, np.ndarray]] = [
        ("MLP 600", small.ratio_mlp, small.err_mlp),
        ("nearest 600 (standardised)", small.ratio_knn, small.err_knn)]
    if large is not None and large_noisy is not None:
        columns += [(f"MLP {args.large}", large.ratio_mlp, large.err_mlp),
                    (f"nearest {args.large}", large.ratio_knn, large.err_knn),
                    (f"MLP {args.large} noise-free-trained, measured test", large_noisy.ratio_clean_net,
                     large_noisy.err_clean_net),
                    (f"MLP {args.large} measured-trained, measured test", large_noisy.ratio_mlp,
                     large_noisy.err_mlp)]
    if n:
        columns += [(f"MLP {name}, hidden boats ({n})", None, np.array(net_err[name])) for name in nets]
        columns.append((f"output-error fit ({n} boats)", None, np.array(fits["twin"]["err"])))
    print("| coefficient |" + "".join(f" {c[0]} |" for c in columns))
    print("|" + " --- |" * (len(columns) + 1))
    def cell(c: int, key: str, ratio: np.ndarray | None, err: np.ndarray) -> str:
        size = float(np.median(np.abs(err[:, c])))
        shown = f"{math.degrees(size):.3f}°" if key == "steering_offset_rad" else f"{size:.1%}"
        return f" {shown} |" if ratio is None else f" {ratio[c]:.2f} / {shown} |"

    for c, key in enumerate(KEYS):
        print(f"| {key} |" + "".join(cell(c, key, ratio, err) for _, ratio, err in columns))
    print(f"\nConstant features over the {args.samples} noise-free zigzags: with the outboards' actual angle as the "
          f"rudder {len(constant['actual'])} ({', '.join(constant['actual']) or 'none'}); with the commanded angle "
          f"{len(constant['commanded'])} ({', '.join(constant['commanded'])})")
    sens_rng = np.random.default_rng(args.seed + 17)
    tables = [("MLP 600 noise-free, noise-free test split", small.maps, x[small_split.test], y[small_split.test])]
    if large_noisy is not None:
        tables.append((f"MLP {args.large} measured-trained, measured test split", large_noisy.maps,
                       xm_big[0][big_split.test], y_big[big_split.test]))
    results = [(label, *sensitivity(maps, xt, yt, sens_rng)) for label, maps, xt, yt in tables]
    print("\nSensitivity (Statistica's: the input replaced by its mean; error RMS over the standardised parameters "
          "/ baseline; rank 1 = relied on most) and the permutation ratio (input shuffled):\n")
    print("| feature | paper VAR | paper rank / ratio (Fig. 17) |" + "".join(
        f" {label}: rank / ratio / permutation ratio |" for label, _, _ in results))
    print("|" + " --- |" * (3 + len(results)))
    for j, name in enumerate(FEATURE_NAMES):
        paper = (f"{PAPER_FIG17['rank'][j]} / {PAPER_FIG17['ratio'][j]:.3f}" if j < len(PAPER_FIG17["rank"])
                 else "not shown")
        print(f"| {name} | VAR{j + 1} | {paper} |" + "".join(
            f" {ranks(mean_out)[j]} / {mean_out[j]:.3f} / {shuffled[j]:.3f} |" for _, mean_out, shuffled in results))
    shown = len(PAPER_FIG17["rank"])
    paper_order = np.argsort(np.argsort(PAPER_FIG17["rank"]))
    for label, mean_out, _ in results:
        ours = np.argsort(np.argsort(-mean_out[:shown]))
        rho = float(np.corrcoef(paper_order, ours)[0, 1])
        print(f"\nSpearman correlation of the ranks of VAR1-14 (paper vs {label}): {rho:+.2f}")
    if n:
        print()
        for key, label in starts.items():
            f = fits[key]
            print(f"- output-error fit from {label}: start error median {med(f['start']):.1%}; median "
                  f"{np.median(f['s']):.1f} s, {np.median(f['evals']):.0f} evaluations (range {min(f['evals'])}–"
                  f"{max(f['evals'])}), error {med(f['err']):.2%}; failed {len(f['failed'])}"
                  + "".join(f"\n  - {why}" for why in f["failed"]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
