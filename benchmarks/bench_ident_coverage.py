"""Coverage of the output-error identification's 95 % intervals, and its accuracy, on hidden trials that an
independent integrator made (scipy's adaptive RK45, not the twin's kernel).

Each trial draws a boat (effective mass 15-2,000 kg log-uniform; a top speed 1.5-12 m/s; a resistance shape:
linear + quadratic, a plateau between displacement and planing, or linear + cubic, scaled so the largest thrust
holds the top speed), a command pattern (a staircase up and down, or random holds of 0.5-6 surge time constants,
sometimes with a reversing stretch), GNSS speed over ground (the norm of the velocity with white noise 0.02-0.10 m/s
and a Gauss-Markov part on each axis, as a receiver's Doppler velocity) and a wave force (AR(1), 2 % of the largest
thrust). Printed per trial: true and identified mass with its 95 % interval,
the selected model, the re-simulation error against the true model's own re-simulation error (the same
commands, no knowledge of the waves) and the baseline's;
then the coverage of the mass and resistance intervals (target 90-98 %), the median mass error (target 5 %).

With ``--each-basis`` every resistance basis is fitted alone on every trial instead (no cross-validation) and the
coverage is printed per basis, from the cluster-robust covariance alone and with the spread to the next richer
basis added (what the identification reports).

Run: ``.venv/bin/python benchmarks/bench_ident_coverage.py [--trials 20] [--seed 0] [--each-basis]``.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from boat_twin.ident.output_error import (
    SPLINE_SIZES,
    ResistanceBasis,
    SurgeFit,
    SurgeRecord,
    fit_surge,
    identify_surge,
    predict,
    spline_basis,
    split_segments,
)

DT_S = 0.1
"""Sample period of the hidden trials (a 10 Hz GNSS), s."""


@dataclass(frozen=True)
class HiddenBoat:
    """A boat the identification does not know: effective mass and a resistance curve (odd in u)."""

    mass_kg: float
    shape: str
    scale: float
    top_speed_mps: float

    def resistance_N(self, u: np.ndarray | float) -> np.ndarray:
        """Fc(u), N."""
        a = np.abs(np.asarray(u, dtype=float)) / self.top_speed_mps
        if self.shape == "quadratic":
            core = 0.3 * a + 0.7 * a**2
        elif self.shape == "plateau":  # a hump flattened into a plateau near 40 % of top speed
            core = 0.25 * a + 0.35 * (np.tanh((a - 0.35) / 0.08) + np.tanh(0.35 / 0.08)) + 0.4 * a**2
        else:
            core = 0.5 * a + 0.5 * a**3
        return np.sign(u) * self.scale * core


def draw_boat(rng: np.random.Generator) -> HiddenBoat:
    """A random boat: mass, shape, top speed; the resistance scaled so that 1.0 holds the top speed."""
    shape = str(rng.choice(["quadratic", "plateau", "cubic"]))
    mass = float(np.exp(rng.uniform(np.log(15.0), np.log(2000.0))))
    top = float(rng.uniform(1.5, 12.0))
    unscaled = HiddenBoat(mass, shape, 1.0, top)
    bollard = 2.0 * 9.81 * mass * rng.uniform(0.15, 0.35)  # total thrust 15-35 % of the boat's weight
    return HiddenBoat(mass, shape, bollard / float(unscaled.resistance_N(top)), top)


def commands(boat: HiddenBoat, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Sample times and the surge thrust held at each (N): a staircase up and down or random holds."""
    top_force = float(boat.resistance_N(boat.top_speed_mps))
    slope = float(boat.resistance_N(0.5 * boat.top_speed_mps) / (0.5 * boat.top_speed_mps))
    tau = boat.mass_kg / slope
    if rng.random() < 0.5:
        levels = np.concatenate([np.linspace(0.1, 1.0, 6), np.linspace(0.8, 0.0, 5)]) * top_force
        holds = np.full(levels.size, np.clip(6.0 * tau, 5.0, 120.0))
    else:
        n = 30
        levels = rng.uniform(0.05, 1.0, n) * top_force
        if rng.random() < 0.5:
            levels[n // 2] = -0.3 * top_force  # reversing
        holds = np.clip(rng.uniform(0.5, 6.0, n) * tau, 5.0, 90.0)
    edges = np.concatenate([[0.0], np.cumsum(holds)])
    t = np.arange(0.0, edges[-1], DT_S)
    return t, levels[np.searchsorted(edges, t, side="right") - 1]


def integrate(boat: HiddenBoat, t: np.ndarray, force_N: np.ndarray) -> np.ndarray:
    """Speed at every sample of m·du/dt = F − Fc(u) from rest, F held per sample (RK45, tight tolerances)."""
    u = np.empty(t.size)
    state = 0.0
    for k in range(t.size):
        u[k] = state
        sol = solve_ivp(lambda _, x, f=force_N[k]: [(f - float(boat.resistance_N(x[0]))) / boat.mass_kg],
                        (0.0, DT_S), [state], rtol=1e-8, atol=1e-10)
        state = float(sol.y[0, -1])
    return u


def hidden_trial(boat: HiddenBoat, rng: np.random.Generator) -> tuple[SurgeRecord, np.ndarray]:
    """The measured record and the speed the true model gives without the waves (its re-simulation)."""
    t, thrust = commands(boat, rng)
    wave = np.zeros(t.size)
    for k in range(1, t.size):  # AR(1) wave force, correlation time 3 s
        wave[k] = wave[k - 1] * np.exp(-DT_S / 3.0) + rng.normal(0.0, 1.0) * np.sqrt(1 - np.exp(-2 * DT_S / 3.0))
    wave *= 0.02 * float(np.max(thrust))
    u = integrate(boat, t, thrust + wave)
    white = rng.uniform(0.02, 0.10)
    markov = np.zeros((t.size, 2))
    for k in range(1, t.size):  # Gauss-Markov GNSS error per axis, 0.02 m/s, correlation time 5 s
        markov[k] = markov[k - 1] * np.exp(-DT_S / 5.0) + 0.02 * np.sqrt(1 - np.exp(-2 * DT_S / 5.0)) * rng.normal(
            size=2)
    error = markov + rng.normal(0.0, white, (t.size, 2))
    measured = np.hypot(u + error[:, 0], error[:, 1])  # speed over ground: the norm of a noisy 2-D velocity
    return SurgeRecord(t, thrust, measured), integrate(boat, t, thrust)


def held(fit: SurgeFit, boat: HiddenBoat, speeds: np.ndarray) -> tuple[bool, list[bool]]:
    """Whether the mass interval and the resistance intervals at ``speeds`` hold the truth."""
    lo, hi = fit.mass_ci95_kg
    clo, chi = fit.resistance_ci95_N(speeds)
    truth = boat.resistance_N(speeds)
    return bool(lo <= boat.mass_kg <= hi), list((clo <= truth) & (truth <= chi))


def each_basis(trials: int, rng: np.random.Generator) -> None:
    """Coverage per basis, fitted alone, with and without the spread to the next richer basis."""
    sizes = (0, *SPLINE_SIZES)
    counts = {k: np.zeros(4, dtype=int) for k in sizes[:-1]}  # mass alone, mass with spread, the same for Fc
    for _ in range(trials):
        boat = draw_boat(rng)
        record, truth = hidden_trial(boat, rng)
        speeds = np.linspace(0.2, 0.9, 4) * float(np.max(np.abs(truth)))
        fits = [fit_surge([record], ResistanceBasis() if k == 0 else spline_basis(record.speed_mps, k))
                for k in sizes]
        for k, fit, richer in zip(sizes[:-1], fits[:-1], fits[1:], strict=True):
            alone = held(fit, boat, speeds)
            fit.reference = richer
            spread = held(fit, boat, speeds)
            counts[k] += (alone[0], spread[0], sum(alone[1]), sum(spread[1]))
    print(f"{'basis':>9} {'mass alone':>10} {'+ spread':>8} {'Fc alone':>9} {'+ spread':>8}  ({trials} trials, "
          f"Fc at 4 speeds each)")
    for k, (m, ms, r, rs) in counts.items():
        name = "baseline" if k == 0 else f"spline-{k}"
        print(f"{name:>9} {m / trials:10.0%} {ms / trials:8.0%} {r / (4 * trials):9.0%} {rs / (4 * trials):8.0%}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--each-basis", action="store_true", help="coverage of every basis fitted alone")
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    if args.each_basis:
        each_basis(args.trials, rng)
        return
    held_mass, held_curve, errors, ratios, base_ratios, seconds = [], [], [], [], [], []
    print(f"{'trial':>5} {'shape':>9} {'mass kg':>8} {'estimate [95% CI]':>26} {'model':>9} "
          f"{'resim/truth':>11} {'baseline/truth':>14}")
    for i in range(args.trials):
        boat = draw_boat(rng)
        record, truth = hidden_trial(boat, rng)
        start = time.perf_counter()
        result = identify_surge([record])
        seconds.append(time.perf_counter() - start)
        fit = result.selected
        lo, hi = fit.mass_ci95_kg
        held_mass.append(lo <= boat.mass_kg <= hi)
        errors.append(fit.mass_kg / boat.mass_kg - 1.0)
        speeds = np.linspace(0.2, 0.9, 4) * float(np.max(np.abs(truth)))
        clo, chi = fit.resistance_ci95_N(speeds)
        held_curve += list((clo <= boat.resistance_N(speeds)) & (boat.resistance_N(speeds) <= chi))
        segment = split_segments([record])[0]
        noise_only = float(np.sqrt(np.mean((np.abs(truth) - record.speed_mps) ** 2)))  # the true model's
        resim = float(np.sqrt(np.mean((predict(fit, record, segment) - record.speed_mps) ** 2)))
        base = float(np.sqrt(np.mean((predict(result.baseline, record, segment) - record.speed_mps) ** 2)))
        ratios.append(resim / noise_only)
        base_ratios.append(base / noise_only)
        print(f"{i:5d} {boat.shape:>9} {boat.mass_kg:8.1f} {fit.mass_kg:8.1f} [{lo:7.1f}, {hi:7.1f}] "
              f"{fit.basis.name:>9} {ratios[-1]:11.3f} {base_ratios[-1]:14.3f}")
    print(f"mass 95% interval coverage: {np.mean(held_mass):.0%} ({sum(held_mass)}/{len(held_mass)}; target 90-98 %)")
    print(f"resistance 95% interval coverage (4 speeds per trial): {np.mean(held_curve):.0%} "
          f"({sum(held_curve)}/{len(held_curve)})")
    print(f"median |mass error| {np.median(np.abs(errors)):.1%} (target 5 %); max {np.max(np.abs(errors)):.1%}")
    print(f"re-simulation RMSE / the true model's re-simulation RMSE: median {np.median(ratios):.3f}, max "
          f"{np.max(ratios):.3f} (target 1.1); baseline's: median {np.median(base_ratios):.3f}")
    never_worse = all(r <= b * 1.001 for r, b in zip(ratios, base_ratios, strict=True))
    print(f"selected never worse than the baseline: {never_worse}")
    print(f"identification time per trial: median {np.median(seconds):.1f} s, max {np.max(seconds):.1f} s")


if __name__ == "__main__":
    main()
