"""False alarms of the diagnosis on clean trials: every scenario of the twin, command shapes of our own, other
boats with their own config, GNSS dropouts up to 30 %.

Run: .venv/bin/python benchmarks/bench_false_alarms.py [--seeds 3 | --trials 190] [--duration 180] [--workers 2]
[--families] [--json OUT.json [--resume]]
Nothing is asserted: the script prints a Markdown table and the exact command that produced it.

Each trial is clean: the true boat is the config the diagnosis is given (the default twin or another boat,
:data:`BOATS`, each diagnosed against its own config), simulated by the twin with its default sensor noise
(GNSS dropouts cycling through :data:`DROPOUTS` from trial to trial), written as a bag, read back and diagnosed
with the whole catalogue. The commands are every scenario of the twin (:data:`~boat_twin.vessel.scenarios.
SCENARIO_NAMES`, as ``boat-twin simulate NAME --seed N`` runs them: a zigzag's helm decides at 50 Hz, between
the 10 Hz log's samples) and :data:`SHAPES`, command profiles written here. A trial *alarms* when its verdict
names an effect, when it is reported ``ambiguous`` or when it is ``unexplained``: the diagnosis of a clean trial
must say none of these. The rate is printed with its Wilson 95 % interval and its exact one-sided 95 % upper
bound (Clopper-Pearson; with no alarm in n trials 1 − 0.05^(1/n) ≈ 3/n, the rule of three): the target is at
most 2 %, which needs ≥ 149 alarm-free trials by the exact bound and ≥ 189 by Wilson's.

The twin's ``crash-stop`` (a 10 s approach, 30 s full astern: 40 s, too short for the 6 windows a diagnosis
needs) is run as :func:`crash_stops`: stops repeated, each ending about when the boat is dead in the water (as
the IMO stopping test does). Stretched to 180 s instead, the twin's one stop backs at full astern for 170 s, at
12 m/s (its resistance model is symmetric in the surge): that is :func:`astern_run`, a shape of its own. The
model is directionally unstable astern, so each window's replay is compared only up to its predictability
horizon, a second or two there (docs/studies/diagnosis.md, "A long run astern"); the table's last line says which trials
were compared less than in full.

Each trial is independent (its own seed), so ``--workers N`` runs them in N processes, each on one thread
(the table does not depend on N); ``--resume`` skips the trials an earlier run saved in ``--json``.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import json
import math
import multiprocessing
import shlex
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from boat_twin.config import TwinConfig, load_twin_config
from boat_twin.diagnose.pipeline import diagnose_trial
from boat_twin.files import atomic_write_text
from boat_twin.io.bags import read_trial, write_bag
from boat_twin.io.messages import actuator_order
from boat_twin.threads import use_one_thread
from boat_twin.twin.sea_trial import run_sea_trial, trial_messages
from boat_twin.vessel.params import VesselParams
from boat_twin.vessel.scenarios import SCENARIO_NAMES, CommandProfile, Scenario, make_scenario, steady_speed_mps

BOATS: dict[str, dict[str, float]] = {
    "default": {},
    "light-strong": {"mass_kg": 900.0, "engine_power_W": 40_000.0, "bollard_thrust_N": 2_400.0},
    "heavy-slow-steering": {"mass_kg": 1_700.0, "radius_of_gyration_yaw_m": 1.9, "steering_rate_radps": 0.1},
}
"""Boats (changes of the default VesselParams), each the true boat and the model of its own trials."""
FAMILIES = ("skid_steer_catamaran", "single_screw_rudder", "twin_outboards")
"""The boat files of config/boats (issue 36's families), with ``--families``: each the true boat and the model."""
BOAT_FILES = Path(__file__).resolve().parents[1] / "config" / "boats"
DROPOUTS = (0.0, 0.1, 0.2, 0.3)
"""Probability that a GNSS fix is lost, cycled through the trials."""
MAX_SCENARIO_S = 300.0
"""A twin scenario longer than this runs only this long (s): the thrust steps' 930 s hold the same steps."""


def _profile(name: str, duration_s: float, times_s: np.ndarray, rows: np.ndarray, surge_mps: float
             ) -> CommandProfile:
    return CommandProfile(name, times_s, rows, duration_s, surge_mps)


def _rows(thrust_N: np.ndarray, steering_rad: np.ndarray, difference_N: np.ndarray | None = None) -> np.ndarray:
    """(n, 4) commands: per-engine thrust (± half a difference) and both outboards at one angle."""
    diff = np.zeros_like(thrust_N) if difference_N is None else difference_N
    return np.column_stack([thrust_N + diff / 2, thrust_N - diff / 2, steering_rad, steering_rad])


def sine_steering(params: VesselParams, rng: np.random.Generator, duration_s: float) -> CommandProfile:
    """Steering a sine of 8-15° and a 12-25 s period at a constant cruise thrust (updated at 10 Hz)."""
    t = np.arange(0.0, duration_s, 0.1)
    amplitude, period = math.radians(rng.uniform(8.0, 15.0)), rng.uniform(12.0, 25.0)
    thrust = rng.uniform(0.25, 0.45) * params.bollard_thrust_N
    rows = _rows(np.full(t.size, thrust), amplitude * np.sin(2 * math.pi * t / period))
    return _profile("sine-steering", duration_s, t, rows, steady_speed_mps(params, 2 * thrust))


def slalom_steps(params: VesselParams, rng: np.random.Generator, duration_s: float) -> CommandProfile:
    """Steering ±10° every 7 s while the thrust steps between two levels every 30 s."""
    t = np.arange(0.0, duration_s, 7.0)
    low, high = rng.uniform(0.15, 0.25), rng.uniform(0.35, 0.5)
    thrust = params.bollard_thrust_N * np.where((t // 30.0) % 2 == 0, low, high)
    steering = math.radians(10.0) * np.where(np.arange(t.size) % 2 == 0, 1.0, -1.0)
    return _profile("slalom-steps", duration_s, t, _rows(thrust, steering), steady_speed_mps(params, 2 * thrust[0]))


def thrust_ramp(params: VesselParams, rng: np.random.Generator, duration_s: float) -> CommandProfile:
    """The thrust ramped up and down between 10 % and 50 % of the bollard thrust (a triangle, 10 Hz), straight."""
    t = np.arange(0.0, duration_s, 0.1)
    period = rng.uniform(80.0, 140.0)
    share = 0.1 + 0.4 * (1.0 - np.abs(2.0 * ((t / period) % 1.0) - 1.0))
    thrust = share * params.bollard_thrust_N
    return _profile("thrust-ramp", duration_s, t, _rows(thrust, np.zeros(t.size)),
                    steady_speed_mps(params, 2 * thrust[0]))


def steering_steps(params: VesselParams, rng: np.random.Generator, duration_s: float) -> CommandProfile:
    """Random steering steps within ±20°, each held 3-12 s, at a constant thrust with a random differential."""
    times = np.cumsum(np.concatenate([[0.0], rng.uniform(3.0, 12.0, 200)]))
    times = times[times < duration_s]
    thrust = rng.uniform(0.25, 0.45) * params.bollard_thrust_N
    steering = np.radians(rng.uniform(-20.0, 20.0, times.size))
    difference = rng.uniform(-0.1, 0.1, times.size) * params.bollard_thrust_N
    return _profile("steering-steps", duration_s, times, _rows(np.full(times.size, thrust), steering, difference),
                    steady_speed_mps(params, 2 * thrust))


def stop_and_go(params: VesselParams, rng: np.random.Generator, duration_s: float) -> CommandProfile:
    """Cruise 40 s, idle (0 N) 20 s, in turn, with a gentle 5° turn while cruising every other time."""
    t = np.arange(0.0, duration_s, 20.0)
    phase = np.arange(t.size) % 3
    thrust = np.where(phase == 2, 0.0, rng.uniform(0.3, 0.45) * params.bollard_thrust_N)
    steering = np.where((np.arange(t.size) // 3) % 2 == 1, math.radians(5.0), 0.0) * (phase != 2)
    return _profile("stop-and-go", duration_s, t, _rows(thrust, steering), steady_speed_mps(params, 2 * thrust[0]))


def chirp_steering(params: VesselParams, rng: np.random.Generator, duration_s: float) -> CommandProfile:
    """Steering a chirp of ±6° whose period falls from 40 s to 6 s, at a random cruise thrust (10 Hz)."""
    t = np.arange(0.0, duration_s, 0.1)
    phase = 2 * math.pi * (t / 40.0 + (1 / 6.0 - 1 / 40.0) * t**2 / (2 * duration_s))
    thrust = rng.uniform(0.2, 0.5) * params.bollard_thrust_N
    rows = _rows(np.full(t.size, thrust), math.radians(6.0) * np.sin(phase))
    return _profile("chirp-steering", duration_s, t, rows, steady_speed_mps(params, 2 * thrust))


def crash_stops(params: VesselParams, rng: np.random.Generator, duration_s: float) -> CommandProfile:
    """The twin's ``crash-stop`` repeated: at its approach thrust (the thrust that holds the boat's turn speed)
    for 25-35 s, then full astern on both outboards (the engine's astern share of the bollard thrust) for 3-5 s,
    about until the boat is dead in the water (3.5 s from 6 m/s on the default boat)."""
    made = make_scenario("crash-stop", params, rng)
    approach, astern = made.values[0], made.values[-1]
    times: list[float] = []
    rows = []
    t = 0.0
    while t < duration_s:
        times += [t, t + rng.uniform(25.0, 35.0)]
        rows += [approach, astern]
        t = times[-1] + rng.uniform(3.0, 5.0)
    return _profile("crash-stops", duration_s, np.array(times), np.array(rows), made.initial_surge_mps)


def astern_run(params: VesselParams, rng: np.random.Generator, duration_s: float) -> CommandProfile:
    """The twin's ``crash-stop`` held: at its approach thrust for 5-15 s, then full astern to the end (170 s at
    about 12 m/s astern on the default boat; docs/studies/diagnosis.md, "A long run astern")."""
    made = make_scenario("crash-stop", params, rng)
    times = np.array([0.0, rng.uniform(5.0, 15.0)])
    return _profile("astern-run", duration_s, times, np.array([made.values[0], made.values[-1]]),
                    made.initial_surge_mps)


SHAPES: dict[str, Callable[[VesselParams, np.random.Generator, float], CommandProfile]] = {
    "sine-steering": sine_steering, "slalom-steps": slalom_steps, "thrust-ramp": thrust_ramp,
    "steering-steps": steering_steps, "stop-and-go": stop_and_go, "chirp-steering": chirp_steering,
    "crash-stops": crash_stops, "astern-run": astern_run,
}
"""Command shapes of this benchmark's own (not the twin's scenarios)."""
TWIN_SCENARIOS = tuple(name for name in SCENARIO_NAMES if name != "crash-stop")
"""The twin's scenarios run as they are: all but ``crash-stop``, run as :func:`crash_stops` (module docstring)."""


def plan(seeds: int, families: bool = False) -> list[tuple[str, str, int, float]]:
    """(commands, boat, seed, dropout) of every trial: every command shape on every boat (with ``families`` the
    boat files' too), ``seeds`` seeds each, the dropout cycling through :data:`DROPOUTS`."""
    boats = (*BOATS, *FAMILIES) if families else tuple(BOATS)
    trials = [(c, b) for c in (*TWIN_SCENARIOS, *SHAPES) for b in boats for _ in range(seeds)]
    return [(c, b, 1000 + i, DROPOUTS[i % len(DROPOUTS)]) for i, (c, b) in enumerate(trials)]


def scenario(commands: str, params: VesselParams, seed: int, duration_s: float) -> Scenario:
    """The twin's scenario ``commands`` as ``boat-twin simulate`` makes it (at least ``duration_s``, at most
    :data:`MAX_SCENARIO_S`: a diagnosis needs 6 windows of 20 s), or one of :data:`SHAPES` of ``duration_s``."""
    rng = np.random.default_rng(seed)
    if commands in SHAPES:
        return SHAPES[commands](params, rng, duration_s)
    made = make_scenario(commands, params, rng)
    length = min(max(made.duration_s, duration_s), MAX_SCENARIO_S)
    return replace(made, duration_s=length)  # type: ignore[type-var]


def run_trial(commands: str, boat: str, seed: int, dropout: float, duration_s: float, folder: Path
              ) -> dict[str, Any]:
    """Simulate, write, read and diagnose one clean trial; its outcome."""
    if boat in FAMILIES:
        base = load_twin_config(BOAT_FILES / f"{boat}.yaml", None, None)
        config = replace(base, gnss=replace(base.gnss, dropout_probability=dropout))
    else:
        base = TwinConfig()
        config = replace(base, vessel=replace(base.vessel, **BOATS[boat]),
                         gnss=replace(base.gnss, dropout_probability=dropout))
    bag = folder / f"{commands}-{boat}-{seed}.mcap"
    write_bag(bag, trial_messages(run_sea_trial(config, scenario(commands, config.vessel, seed, duration_s), seed),
                                  truth=False), force=True)
    trial = read_trial(bag, order=actuator_order(config.vessel.propulsion))
    model = replace(config, gnss=base.gnss)  # the model of the boat; the dropouts are the sea's
    start = time.process_time()
    result = diagnose_trial(trial, model).result
    cpu = time.process_time() - start
    bag.unlink()
    named = [v["effect"] for v in result["verdict"]]
    ambiguous = list(result["ambiguous"]["effects"]) if result["ambiguous"] else []
    return {"commands": commands, "boat": boat, "seed": seed, "dropout": dropout, "named": named,
            "ambiguous": ambiguous, "unexplained": bool(result["unexplained"]), "signature": result["signature"],
            "windows": result["windows"]["count"], "compared": result["windows"]["compared_fraction"], "cpu_s": cpu,
            "alarm": bool(named or ambiguous or result["unexplained"])}


def run_planned(item: tuple[str, str, int, float], duration_s: float) -> dict[str, Any]:
    """:func:`run_trial` of one :func:`plan` item in its own temporary folder (a worker process's task)."""
    with tempfile.TemporaryDirectory() as folder:
        return run_trial(*item, duration_s, Path(folder))


def _one_thread_worker() -> None:
    use_one_thread()  # (not NUMBA_NUM_THREADS in os.environ: numba refuses it once its threads run)


def exact_upper(k: int, n: int) -> float:
    """One-sided 95 % upper bound of a rate k/n (Clopper-Pearson): with k = 0, 1 − 0.05^(1/n) ≈ 3/n."""
    from scipy.stats import beta

    return 1.0 if k >= n else float(beta.ppf(0.95, k + 1, n - k))


def wilson(k: int, n: int) -> tuple[float, float]:
    """Wilson 95 % interval of a rate k/n."""
    if n == 0:
        return 0.0, 1.0
    z, p = 1.96, k / n
    centre, half = (p + z * z / (2 * n)), z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return max(0.0, (centre - half) / (1 + z * z / n)), min(1.0, (centre + half) / (1 + z * z / n))


def table(outcomes: list[dict[str, Any]]) -> str:
    """Markdown: per command shape and overall, trials, named, ambiguous, unexplained, alarms."""
    def row(label: str, items: list[dict[str, Any]]) -> str:
        n = len(items)
        named = sum(bool(o["named"]) for o in items)
        ambiguous = sum(bool(o["ambiguous"]) for o in items)
        unexplained = sum(o["unexplained"] for o in items)
        alarms = sum(o["alarm"] for o in items)
        share = 100 * alarms / max(n, 1)
        return f"| {label} | {n} | {named} | {ambiguous} | {unexplained} | {alarms} ({share:.0f}%) |"
    lines = ["| commands | trials | named | ambiguous | unexplained | alarms |",
             "| --- | --- | --- | --- | --- | --- |"]
    for commands in dict.fromkeys(o["commands"] for o in outcomes):
        lines.append(row(commands, [o for o in outcomes if o["commands"] == commands]))
    for boat in dict.fromkeys(o["boat"] for o in outcomes):
        lines.append(row(f"boat: {boat}", [o for o in outcomes if o["boat"] == boat]))
    for dropout in sorted({o["dropout"] for o in outcomes}):
        lines.append(row(f"GNSS dropouts {100 * dropout:.0f} %", [o for o in outcomes if o["dropout"] == dropout]))
    lines.append(row("**all**", outcomes))
    alarms = sum(o["alarm"] for o in outcomes)
    low, high = wilson(alarms, len(outcomes))
    cpu = np.array([o["cpu_s"] for o in outcomes])
    lines += ["", f"false-alarm rate {alarms}/{len(outcomes)} = {100 * alarms / max(len(outcomes), 1):.1f} % "
              f"(Wilson 95 %: {100 * low:.1f}-{100 * high:.1f} %; exact one-sided 95 % upper bound "
              f"{100 * exact_upper(alarms, len(outcomes)):.1f} %; target ≤ 2 %); diagnosis CPU per trial median "
              f"{np.median(cpu):.1f} s, max {cpu.max():.1f} s"]
    short = [o for o in outcomes if o.get("compared", 1.0) < 1.0]  # runs saved before the horizon have none
    lines.append(f"windows' time compared (predictability horizon, docs/diagnosis.md): all of it in "
                 f"{len(outcomes) - len(short)} trials; less in {len(short)}"
                 + (": " + ", ".join(f"{o['commands']} {o['boat']} seed {o['seed']} {100 * o['compared']:.0f} %"
                                     for o in short) if short else ""))
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=3, help="trials per command shape and boat (default 3)")
    parser.add_argument("--trials", type=int,
                        help="at least this many trials: the fewest --seeds that give them (overrides --seeds)")
    parser.add_argument("--duration", type=float, default=180.0, help="length of a SHAPES trial, s (default 180)")
    parser.add_argument("--workers", type=int, default=1, help="worker processes, one thread each (default 1)")
    parser.add_argument("--json", type=Path, help="save every trial's outcome here (rewritten after each trial)")
    parser.add_argument("--resume", action="store_true", help="skip the trials already saved in --json")
    parser.add_argument("--tables-from", type=Path, help="print the table of a saved --json run and exit")
    parser.add_argument("--families", action="store_true",
                        help="also the boat files of config/boats (skid-steer, single screw + rudder, outboards)")
    args = parser.parse_args()
    if args.tables_from:
        print(table(json.loads(args.tables_from.read_text())))
        return 0
    seeds = args.seeds
    if args.trials:
        seeds = -(-args.trials // len(plan(1, args.families)))
    print("command: " + " ".join(shlex.quote(a) for a in [".venv/bin/python", *sys.argv]), flush=True)
    outcomes: list[dict[str, Any]] = []
    planned = plan(seeds, args.families)
    if args.resume and args.json and args.json.exists():  # only the saved trials this plan holds
        keys = {item[:3] for item in planned}
        outcomes = [o for o in json.loads(args.json.read_text()) if (o["commands"], o["boat"], o["seed"]) in keys]
    done = {(o["commands"], o["boat"], o["seed"]) for o in outcomes}
    todo = [item for item in planned if item[:3] not in done]
    print(f"{len(todo)} trials to run ({len(outcomes)} saved), {args.workers} worker(s)", flush=True)
    context = multiprocessing.get_context("spawn")
    with concurrent.futures.ProcessPoolExecutor(args.workers, mp_context=context,
                                                initializer=_one_thread_worker) as pool:
        futures = [pool.submit(run_planned, item, args.duration) for item in todo]
        for future in concurrent.futures.as_completed(futures):
            outcome = future.result()
            outcomes.append(outcome)
            print(f"{outcome['commands']:15s} {outcome['boat']:20s} seed {outcome['seed']} dropout "
                  f"{outcome['dropout']:.1f}: named {outcome['named']} ambiguous {outcome['ambiguous']} unexplained "
                  f"{outcome['unexplained']} "
                  f"{[(s['signal'], round(s['misfit'], 2), round(s['heldout_r2'], 2)) for s in outcome['signature']]}"
                  f" ({outcome['cpu_s']:.1f} s CPU)", flush=True)
            if args.json:
                atomic_write_text(args.json, json.dumps(outcomes, indent=1))
    order = {item[:3]: i for i, item in enumerate(planned)}
    outcomes.sort(key=lambda o: order.get((o["commands"], o["boat"], o["seed"]), len(order)))
    print()
    print(table(outcomes))
    return 0


if __name__ == "__main__":
    sys.exit(main())
