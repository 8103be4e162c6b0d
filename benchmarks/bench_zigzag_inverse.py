"""Zigzag features → turning coefficients: Pashentsev (2025)'s network and nearest trajectory, reproduced, beside
the output-error fit (boat_twin.ident.manoeuvring) on the same hidden boats.

Needs scikit-learn (the ``bench`` extra, not a runtime dependency): ``.venv/bin/pip install scikit-learn``.
Run: .venv/bin/python benchmarks/bench_zigzag_inverse.py [--samples 600] [--large 10000] [--fit-boats 5] [--seed 0]
Nothing is asserted: the script prints Markdown tables for docs/identification.md and the command that made them.

Training sets (the paper's recipe on this boat): every manoeuvring coefficient (m22, m33, a_v, a_r, Y_vv, N_rr
and x_c) drawn normally around the twin's with a standard deviation of 10 % (z clipped to ±3), one 20°/20°
zigzag at 6 m/s each (helm at the 10 Hz log rate), simulated as one ensemble (each boat its own coefficients in
one kernel run) and summarised by the 42 features (:mod:`boat_twin.ident.zigzag_features`); split 400/100/100
(train / verification / test) as the paper, and 80/10/10 % of ``--large`` (10^4).
Inverse maps, standardised features → coefficients: a scikit-learn MLP (one hidden layer of 22 as the paper's
best net, or two of 64; the size and weight decay chosen on the verification set) and the nearest training
sample (1-NN in standardised features; and the paper's criterion, below). MLPs by L-BFGS, tanh.
Evaluated as the paper does: the SD ratio per coefficient (its "Perf": SD of the prediction error / SD of the
coefficient; 1 = no better than predicting the mean), and the trajectory SD — the paper's Fig. 15: each 42-feature
vector min-max scaled over its own components, the SD of the difference between the target's and the candidate's
(the MLP's answer re-simulated; the nearest training sample, found by that same SD) — and by the parameter error.
Output-error fit: ``--fit-boats`` hidden boats of the small set's test split, one 20°/20° zigzag at 6 m/s of
120 s with the default sensor noise (written to a bag and read back), ``fit_manoeuvring`` from the twin's
coefficients and from the MLP's answer for the measured features of that same trial (is the network a useful
starting point?).
Speed: zigzags per second, one simulate() per boat against the ensemble, in the same run.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.ident.manoeuvring import apply_parameters, fit_manoeuvring
from boat_twin.ident.manoeuvring_trials import recorded
from boat_twin.ident.zigzag_features import ensemble_features, trial_features
from boat_twin.twin.sea_trial import run_sea_trial
from boat_twin.vessel.params import MANOEUVRING_KEYS, VesselParams, derive_coefficients
from boat_twin.vessel.scenarios import Zigzag
from boat_twin.vessel.simulate import OUTPUT_RATE_HZ, simulate

try:
    from sklearn.neighbors import KNeighborsRegressor
    from sklearn.neural_network import MLPRegressor
    from sklearn.preprocessing import StandardScaler
except ImportError:
    print("this benchmark needs scikit-learn (setup.py's bench extra): .venv/bin/pip install scikit-learn",
          file=sys.stderr)
    raise SystemExit(2) from None

KEYS = MANOEUVRING_KEYS + ("lateral_centre_x_m",)
"""The coefficients perturbed and mapped back (the paper's 19 model parameters, on this model)."""
SPREAD = 0.10
"""Standard deviation of the perturbation, relative (Pashentsev 2025: normal, 10 %)."""
SPEED_MPS = 6.0
DURATION_S = 75.0
"""Zigzag length for the features, s: the third extreme comes 32 s after the execute (10 s approach) on the
twin, up to ~55 s on the slowest-turning boats drawn."""
TRIAL_S = 120.0
"""Length of the noisy trial the output-error fit gets, s (six 20 s windows: the fit's minimum)."""
BATCH = 2000
"""Boats per ensemble run (bounds the record: 750 ticks × 2000 boats × 144 bytes ≈ 220 MB)."""
Grid = tuple[tuple[tuple[int, ...], float, int], ...]
SMALL_GRID: Grid = (((22,), 1e-3, 2000), ((44,), 1e-2, 2000))
"""MLPs (hidden layers, weight decay, L-BFGS iterations) tried on the small set, the best on its verification
split kept."""
LARGE_GRID: Grid = (((64,), 1e-3, 400),)
"""MLP trained on the large set (one, iterations capped: L-BFGS on 8000 samples is minutes on a shared machine)."""
PAPER = {"perf": (0.9957, 1.042, 1.127), "sd_net": 6.389e-3, "sd_nearest": 4.028e-3}
"""Pashentsev (2025), Fig. 10 (best network, train / verification / test "Perf") and eq. (3)."""


def zigzag(vessel: VesselParams, duration_s: float = DURATION_S) -> Zigzag:
    angle = math.radians(20.0)
    return Zigzag(vessel, angle, angle, speed_mps=SPEED_MPS, duration_s=duration_s, decision_rate_hz=OUTPUT_RATE_HZ)


def draw(base: VesselParams, n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, 7) coefficients (:data:`KEYS`) drawn normally around ``base``'s, SD :data:`SPREAD` relative."""
    coeff = derive_coefficients(base)
    centre = np.array([getattr(coeff, k) for k in MANOEUVRING_KEYS] + [base.lateral_centre_x_m])
    return centre * (1.0 + SPREAD * np.clip(rng.standard_normal((n, len(KEYS))), -3.0, 3.0))


def boat(base: VesselParams, values: np.ndarray) -> VesselParams:
    return replace(base, manoeuvring={k: float(v) for k, v in zip(MANOEUVRING_KEYS, values, strict=False)},
                   lateral_centre_x_m=float(values[-1]))


def features_of(base: VesselParams, values: np.ndarray) -> np.ndarray:
    """(n, 42) noise-free zigzag features of the boats ``values`` (ensemble runs of :data:`BATCH`)."""
    out = []
    for lo in range(0, len(values), BATCH):
        boats = [boat(base, v) for v in values[lo:lo + BATCH]]
        out.append(ensemble_features(simulate(base, zigzag(base), boats=boats)))
    return np.concatenate(out)


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
    """Error relative to the value (x_c: relative to the centre's size, |x_c| = 1 m here)."""
    scale = np.abs(truth).copy()
    scale[:, -1] = abs(centre[-1])
    return (predicted - truth) / scale


class InverseMaps:
    """The two inverse maps trained on one set: MLP (chosen on the verification split) and 1-NN."""

    def __init__(self, x: np.ndarray, y: np.ndarray, s: Split, seed: int,
                 grid: Grid) -> None:
        self.x_scale = StandardScaler().fit(x[s.train])
        self.y_scale = StandardScaler().fit(y[s.train])
        xs, ys = self.x_scale.transform(x), self.y_scale.transform(y)
        best = None
        start = time.perf_counter()
        for hidden, alpha, iterations in grid:
            net = MLPRegressor(hidden_layer_sizes=hidden, activation="tanh", solver="lbfgs", alpha=alpha,
                               max_iter=iterations, random_state=seed).fit(xs[s.train], ys[s.train])
            error = float(np.mean((net.predict(xs[s.verify]) - ys[s.verify]) ** 2))
            if best is None or error < best[0]:
                best = (error, net, hidden, alpha)
        assert best is not None
        _, self.net, self.hidden, self.alpha = best
        self.train_s = time.perf_counter() - start
        self.nearest = KNeighborsRegressor(n_neighbors=1).fit(xs[s.train], y[s.train])
        self.low, self.high = y[s.train].min(axis=0), y[s.train].max(axis=0)

    def mlp(self, x: np.ndarray) -> np.ndarray:
        """The network's answer, clipped to the training set's range (an answer far outside, e.g. a negative
        drag coefficient, is no model to simulate or start a fit from)."""
        answer = self.y_scale.inverse_transform(self.net.predict(self.x_scale.transform(x)))
        return np.clip(answer, self.low, self.high)

    def knn(self, x: np.ndarray) -> np.ndarray:
        return self.nearest.predict(self.x_scale.transform(x))


def study(name: str, base: VesselParams, y: np.ndarray, x: np.ndarray, s: Split, seed: int,
          centre: np.ndarray, grid: Grid) -> dict[str, object]:
    """Train both maps on one set and evaluate them on its test split (SD ratios, errors, trajectory SD)."""
    maps = InverseMaps(x, y, s, seed, grid)
    test = s.test
    mlp, knn = maps.mlp(x[test]), maps.knn(x[test])
    perf = [float(np.mean(sd_ratio(maps.mlp(x[idx]), y[idx]))) for idx in (s.train, s.verify, test)]
    # Trajectory SD (paper): the MLP's answer re-simulated; the nearest training sample by the paper's own SD.
    resim = features_of(base, mlp)
    sd_mlp = paper_sd(resim, x[test])
    closest = np.array([int(np.argmin(paper_sd(x[s.train], x[i]))) for i in test])
    sd_near = paper_sd(x[s.train][closest], x[test])
    nearest_paper = y[s.train][closest]
    print(f"{name}: MLP {maps.hidden} alpha {maps.alpha:g} trained in {maps.train_s:.1f} s; "
          f"{np.isnan(sd_mlp).sum()} re-simulated answers without all six events", file=sys.stderr)
    return {
        "maps": maps,
        "perf_mlp": perf,
        "ratio_mlp": sd_ratio(mlp, y[test]), "ratio_knn": sd_ratio(knn, y[test]),
        "ratio_paper_nearest": sd_ratio(nearest_paper, y[test]),
        "err_mlp": relative_error(mlp, y[test], centre), "err_knn": relative_error(knn, y[test], centre),
        "err_paper_nearest": relative_error(nearest_paper, y[test], centre),
        "sd_mlp": sd_mlp, "sd_near": sd_near,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=600)
    parser.add_argument("--large", type=int, default=10_000, help="second, larger training set (0: none)")
    parser.add_argument("--fit-boats", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    config = TwinConfig()
    base = config.vessel
    rng = np.random.default_rng(args.seed)
    coeff = derive_coefficients(base)
    centre = np.array([getattr(coeff, k) for k in MANOEUVRING_KEYS] + [base.lateral_centre_x_m])

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
    ok = np.all(np.isfinite(x), axis=1)
    y, x = y[ok], x[ok]
    dropped = int((~ok).sum())
    sixth = len(y) // 6  # the paper's 400/100/100 of 600
    small_split = split(len(y), rng, sixth, sixth)
    small = study(f"{len(y)} samples", base, y, x, small_split, args.seed, centre, SMALL_GRID)

    large = None
    if args.large:
        y_big = draw(base, args.large, rng)
        start = time.perf_counter()
        x_big = features_of(base, y_big)
        large_s = time.perf_counter() - start
        ok_big = np.all(np.isfinite(x_big), axis=1)
        y_big, x_big = y_big[ok_big], x_big[ok_big]
        tenth = len(y_big) // 10
        large = study(f"{len(y_big)} samples", base, y_big, x_big, split(len(y_big), rng, tenth, tenth),
                      args.seed, centre, LARGE_GRID)

    # Output-error fit on hidden boats of the small set's test split, one noisy 120 s zigzag each.
    maps: InverseMaps = small["maps"]  # type: ignore[assignment]
    fit_err, fit_s, warm_err, warm_s, evals, warm_evals, net_err, fit_sd = [], [], [], [], [], [], [], []
    start_err = []
    test = small_split.test[:args.fit_boats]
    with tempfile.TemporaryDirectory(prefix="zigzag_inverse_") as tmp:
        for j, i in enumerate(test):
            true = apply_parameters(config, dict(zip(KEYS, y[i], strict=True)))
            sea = run_sea_trial(true, zigzag(true.vessel, TRIAL_S), 7000 + j)
            trial = recorded(sea, f"boat{j}", Path(tmp))
            measured = trial_features(trial).ravel()[None, :]
            guess = maps.mlp(measured)[0]
            net_err.append(relative_error(guess[None], y[i][None], centre)[0])
            fit = fit_manoeuvring([trial], config)
            fitted = np.array([fit.values[k] for k in KEYS])
            fit_err.append(relative_error(fitted[None], y[i][None], centre)[0])
            fit_s.append(fit.fit_time_s)
            evals.append(fit.evaluations)
            fit_sd.append(float(paper_sd(features_of(base, fitted[None]), x[i])[0]))
            warm = fit_manoeuvring([trial], apply_parameters(config, dict(zip(KEYS, guess, strict=True))))
            warmed = np.array([warm.values[k] for k in KEYS])
            warm_err.append(relative_error(warmed[None], y[i][None], centre)[0])
            warm_s.append(warm.fit_time_s)
            warm_evals.append(warm.evaluations)
            start_err.append(np.abs(relative_error(centre[None], y[i][None], centre)[0]))
            print(f"hidden boat {j}: fit {fit.fit_time_s:.1f} s ({fit.evaluations} evaluations), from the MLP's "
                  f"answer {warm.fit_time_s:.1f} s ({warm.evaluations})", file=sys.stderr)

    print(f"Command: .venv/bin/python benchmarks/bench_zigzag_inverse.py --samples {args.samples} --large "
          f"{args.large} --fit-boats {args.fit_boats} --seed {args.seed}\n")
    print(f"Training-set generation (20°/20° zigzag at 6 m/s, {DURATION_S:g} s): one simulate() per boat "
          f"{single_rate:.0f} zigzags/s; one ensemble run {ensemble_rate:.0f} zigzags/s "
          f"({ensemble_rate / single_rate:.1f}×); with the features {len(y) / small_s:.0f}/s"
          + (f"; {args.large} zigzags with features in {large_s:.1f} s" if large is not None else "")
          + f". Boats without all six events in {DURATION_S:g} s (dropped): {dropped} of {args.samples}"
          + (f", {args.large - len(y_big)} of {args.large}" if large is not None else ""))
    med = lambda a: float(np.median(np.abs(np.asarray(a))))  # noqa: E731
    print("\n| method | training set | SD ratio (\"Perf\"), mean over coefficients | median parameter error "
          "| trajectory SD (median) |")
    print("| --- | --- | --- | --- | --- |")
    p = PAPER["perf"]
    print(f"| Pashentsev (2025) network, 42-22-19 MLP | 600 (400/100/100) | {p[0]:.3f} / {p[1]:.3f} / {p[2]:.3f} "
          f"(train / verify / test) | not reported | {PAPER['sd_net']:.3e} (one case) |")
    print(f"| Pashentsev (2025) nearest training trajectory | 600 | – | not reported | {PAPER['sd_nearest']:.3e} "
          "(one case) |")
    for label, r in (("600", small), (f"{args.large}", large)):
        if r is None:
            continue
        maps_r: InverseMaps = r["maps"]  # type: ignore[assignment]
        perf = r["perf_mlp"]
        print(f"| MLP {maps_r.hidden} (scikit-learn) | {label} | {perf[0]:.3f} / {perf[1]:.3f} / {perf[2]:.3f} | "
              f"{med(r['err_mlp']):.2%} | {np.nanmedian(r['sd_mlp']):.3e} |")
        print(f"| nearest training sample, paper's SD | {label} | test {np.mean(r['ratio_paper_nearest']):.3f} | "
              f"{med(r['err_paper_nearest']):.2%} | {np.median(r['sd_near']):.3e} |")
        print(f"| nearest training sample, standardised features | {label} | test {np.mean(r['ratio_knn']):.3f} | "
              f"{med(r['err_knn']):.2%} | – |")
    n = len(fit_err)
    if n:
        print(f"| MLP (600) on the measured features (noise) of {n} hidden boats | 600 | – | {med(net_err):.2%} | – |")
        print(f"| output-error fit, one noisy 120 s zigzag, {n} hidden boats | none | – | {med(fit_err):.2%} | "
              f"{np.median(fit_sd):.3e} |")
    print("\nPer coefficient (test split; SD ratio / median |error|; x_c error relative to |x_c| = 1 m):\n")
    header = "| coefficient | MLP 600 | nearest 600 (standardised) |"
    if large is not None:
        header += f" MLP {args.large} | nearest {args.large} |"
    if n:
        header += f" MLP 600, measured ({n} boats) | output-error fit ({n} boats) |"
    print(header)
    print("|" + " --- |" * (header.count("|") - 1))
    for c, key in enumerate(KEYS):
        row = f"| {key} | {small['ratio_mlp'][c]:.2f} / {med(small['err_mlp'][:, c]):.1%} | "  # type: ignore[index]
        row += f"{small['ratio_knn'][c]:.2f} / {med(small['err_knn'][:, c]):.1%} |"  # type: ignore[index]
        if large is not None:
            row += (f" {large['ratio_mlp'][c]:.2f} / {med(large['err_mlp'][:, c]):.1%} |"  # type: ignore[index]
                    f" {large['ratio_knn'][c]:.2f} / {med(large['err_knn'][:, c]):.1%} |")  # type: ignore[index]
        if n:
            row += (f" {med(np.array(net_err)[:, c]):.1%} | {med(np.array(fit_err)[:, c]):.1%} |")
        print(row)
    if n:
        print(f"\nOutput-error fit from the twin's coefficients (start error median {med(start_err):.1%}): median "
              f"{np.median(fit_s):.1f} s, {np.median(evals):.0f} evaluations, error {med(fit_err):.2%}; from the "
              f"MLP's answer (start error {med(net_err):.1%}): {np.median(warm_s):.1f} s, "
              f"{np.median(warm_evals):.0f} evaluations, error {med(warm_err):.2%}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
