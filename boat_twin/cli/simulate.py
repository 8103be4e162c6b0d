"""``boat-twin simulate``: run a scenario (or a command file / recorded trial's commands) into a ROS 2 bag.

The simulator is imported by the handler, so that ``--help`` answers at once."""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Iterable, Iterator
from contextlib import ExitStack, contextmanager, nullcontext
from pathlib import Path
from typing import TYPE_CHECKING, Any

from boat_twin.cli import verb_help
from boat_twin.cli.options import add_foxglove_options, announce_view, foxglove_address, twin_config_from_args
from boat_twin.errors import InputError
from boat_twin.files import prepare_output, refuse_input_as_output, to_json
from boat_twin.fleet.engine import LOCAL, SCHEDULER_HELP
from boat_twin.vessel.scenario_names import SCENARIO_NAMES

if TYPE_CHECKING:
    from boat_twin.config import TwinConfig
    from boat_twin.io.messages import Message
    from boat_twin.twin.live import LiveTwin
    from boat_twin.twin.sea_trial import CompactTrial
    from boat_twin.vessel.scenarios import CommandProfile, Scenario
    from boat_twin.vessel.truth import TruthSeries
    from boat_twin.view.simulation import SimulationView
    from boat_twin.view.stream import TwinView

SEED_MAX = 2**63 - 1
"""Largest --seed: the int64 range of a ROS 2 integer parameter (the simulator node's ``seed``)."""
PROGRESS_EVERY_S = 5.0
"""Wall time between two progress lines of a long simulation on stderr, s (a short run prints none)."""
PROGRESS_MESSAGES = 4096
"""Messages written between two looks at the clock."""


class Progress:
    """Progress lines on stderr of a long ``simulate`` (at most one per :data:`PROGRESS_EVERY_S` of wall time):
    ``simulate: reading c.csv: up to 1200 s``, ``simulate: simulated 1200 of 30000 s``, then ``simulate: writing
    o.mcap: 1200 of 30000 s``."""

    def __init__(self) -> None:
        self.duration_s: float | None = None
        """The simulated time of the whole run, s, once known."""
        self._next = time.monotonic() + PROGRESS_EVERY_S

    def report(self, what: str, t_s: float) -> None:
        """Say that ``what`` reached the simulated time ``t_s``, if the last line is :data:`PROGRESS_EVERY_S` old."""
        now = time.monotonic()
        if now >= self._next:
            self._next = now + PROGRESS_EVERY_S
            whole = f"of {self.duration_s:.0f} s" if self.duration_s is not None else "s"
            sys.stderr.write(f"simulate: {what} {t_s:.0f} {whole}\n")
            sys.stderr.flush()

    def reading(self, path: Path, t_s: float) -> None:
        """``progress`` of :func:`~boat_twin.vessel.scenarios.read_command_csv`."""
        self.report(f"reading {path}: up to", t_s)

    def simulated(self, t_s: float) -> None:
        """``progress`` of :func:`~boat_twin.twin.sea_trial.run_compact_trial`."""
        self.report("simulated", t_s)

    def writing(self, messages: Iterable[Any], out: Path) -> Iterator[Any]:
        """``messages`` (topic, stamp in ns, message), passed on, reported as written to ``out``."""
        first_ns = None
        for count, message in enumerate(messages):
            if count % PROGRESS_MESSAGES == 0:
                first_ns = message[1] if first_ns is None else first_ns
                self.report(f"writing {out}:", (message[1] - first_ns) * 1e-9)
            yield message


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``simulate`` verb."""
    p = subparsers.add_parser(
        "simulate",
        help=verb_help("simulate"),
        description="Simulate the boat through a scenario; write commands, GNSS, UM7 IMU and ground truth "
        "as a rosbag2 (MCAP by default). Units: SI (N, rad, m/s, s).",
    )
    p.add_argument("scenario", nargs="?", help=f"one of: {', '.join(SCENARIO_NAMES)} (omit with --commands)")
    p.add_argument("--commands", type=Path, metavar="FILE",
                   help="command profile: CSV 't,thrust_left_N,thrust_right_N,angle_left_rad,angle_right_rad' "
                   "(zero-order hold) or a recorded bag whose thruster topics are replayed")
    p.add_argument("--config", type=Path, metavar="FILE",
                   help="twin configuration YAML (sections vessel, environment, gnss, um7; e.g. config/boat.yaml)")
    p.add_argument("--model", type=Path, metavar="FILE",
                   help="identified model YAML overriding the vessel (resistance, mass): identify's model.yaml")
    p.add_argument("--current", type=float, nargs=2, metavar=("EAST", "NORTH"),
                   help="water current over ground, m/s (its east and north components)")
    p.add_argument("--duration", type=float, metavar="S", help="trial length, s (default: the scenario's own)")
    p.add_argument("--seed", type=int, default=0, metavar="N",
                   help="random seed, 0 to 2^63-1: the same seed gives the same bag (default 0)")
    p.add_argument("--no-noise", action="store_true", help="exact measurements (no noise, dropouts or bias)")
    p.add_argument("--out", type=Path, metavar="BAG", help="output bag: a directory, or a file ending in .mcap")
    p.add_argument("--storage", choices=("mcap", "sqlite3"), default="mcap", help="rosbag2 storage (default mcap)")
    p.add_argument("--plot", type=Path, metavar="PNG",
                   help="write the run's x-y track (to scale) and heading as a PNG; a turning circle or zigzag with "
                   "its IMO figures marked (advance, transfer, tactical diameter; executes, overshoots)")
    p.add_argument("--force", action="store_true", help="overwrite an existing output")
    p.add_argument("--json", action="store_true", help="machine-readable summary on stdout")
    p.add_argument("--mavlink", metavar="URL",
                   help="run live as a MAVLink surface boat (ArduPilot Rover streams and manual control), e.g. "
                   "udpout:127.0.0.1:14550 (a ground station on this machine) or udpin:127.0.0.1:14551; "
                   "without a scenario the ground station alone drives it until --duration or Ctrl-C")
    p.add_argument("--mavlink-speed", type=float, default=1.0, metavar="FACTOR",
                   help="simulated seconds per wall-clock second of a --mavlink run (default 1: real time; "
                   "0: as fast as possible); a --tlog run without --mavlink goes as fast as possible")
    p.add_argument("--tlog", type=Path, metavar="FILE",
                   help="record the MAVLink telemetry as a .tlog (MAVProxy format; with or without --mavlink)")
    p.add_argument("--mavlink-rate", action="append", default=[], metavar="GROUP=HZ",
                   help="telemetry stream rate, Hz, per ArduPilot group (EXT_STAT, POSITION, RC_CHAN, EXTRA1, "
                   "EXTRA2, EXTRA3, or ALL); default Rover's 1 Hz each. Identification from a .tlog needs 10 Hz "
                   "POSITION, RC_CHAN and EXTRA1")
    p.add_argument("--ensemble", type=int, metavar="N",
                   help="run N boats drawn around the config's vessel (each manoeuvring coefficient within ±30 %%, "
                   "boat i seeded by (--seed, i)) through the scenario, in chunks run as tasks (--scheduler): one "
                   "CSV of per-boat rows per chunk (drawn coefficients, track figures, a zigzag's 42 features) in "
                   "--out DIR, a summary of the chunks; the same seed gives the same rows whatever the chunking "
                   "and workers (docs/fleet.md)")
    p.add_argument("--chunk", type=int, default=0, metavar="BOATS",
                   help="with --ensemble: boats per task (default: as many as fill a 200 MB record, at most 2000)")
    p.add_argument("--scheduler", default=LOCAL, metavar="WHERE", help="with --ensemble: " + SCHEDULER_HELP)
    p.add_argument("--workers", type=int, metavar="N",
                   help="with --ensemble and --scheduler local: worker processes (default: one per core)")
    p.add_argument("--allow-remote", action="store_true",
                   help="allow a --mavlink or --foxglove address that is not loopback (exposes the twin to the "
                   "network)")
    add_foxglove_options(p, "the simulated boat's true track and hull and its GNSS fixes", allow_remote=False)
    p.set_defaults(handler=run)


def _scenario(args: argparse.Namespace, config: TwinConfig, progress: Progress | None = None) -> Scenario:
    import numpy as np

    from boat_twin.vessel.scenarios import MAX_DURATION_S, CommandProfile, make_scenario, read_command_csv

    if args.commands and args.scenario:
        raise InputError("give a scenario or --commands, not both")
    if args.commands:
        if args.commands.is_dir() or args.commands.suffix == ".mcap":
            from boat_twin.io.bags import read_trial

            trial = read_trial(args.commands)
            values = np.nan_to_num(trial.commands, nan=0.0)
            t_abs = trial.t_s + trial.metadata.start_time_s
            profile = CommandProfile(args.commands.name, t_abs, values, float(t_abs[-1]))
        else:
            profile = read_command_csv(args.commands, progress.reading if progress is not None else None)
        if args.duration is not None:
            return make_scenario_with_duration(profile, args.duration)
        if not profile.duration_s <= MAX_DURATION_S:
            raise InputError(f"{args.commands}: its commands run to {profile.duration_s:g} s, beyond "
                             f"{MAX_DURATION_S:g} s (7 days, the longest simulation); give --duration")
        return profile
    if not args.scenario:
        raise InputError(f"name a scenario ({', '.join(SCENARIO_NAMES)}) or give --commands FILE")
    return make_scenario(args.scenario, config.vessel, np.random.default_rng(args.seed), args.duration)


def make_scenario_with_duration(profile: CommandProfile, duration_s: float) -> CommandProfile:
    """The same command profile run for ``duration_s`` (the last row held)."""
    from boat_twin.vessel.scenarios import CommandProfile

    if not duration_s > 0.0:
        raise InputError(f"--duration must be a positive number of seconds, got {duration_s!r}")
    return CommandProfile(profile.name, profile.times_s, profile.values, duration_s, profile.initial_surge_mps)


def summarize(truth: TruthSeries) -> dict[str, float | None]:
    """Figures of a simulated trial's truth: duration, top speed, extreme yaw rate, and the final steady
    turning diameter 2·U/|r| (averaged over the last 20 s; None unless the boat ends in a turn)."""
    import numpy as np

    t_s = truth.t_s
    last = t_s >= t_s[-1] - 20.0
    u, v, r = truth.surge_mps[last], truth.sway_mps[last], truth.yaw_rate_radps[last]
    turning = bool(np.all(np.abs(r) > 0.02) and np.ptp(r) < 0.05 * np.mean(np.abs(r)))
    return {
        "duration_s": float(t_s[-1]),
        "max_surge_mps": float(np.max(truth.surge_mps)),
        "max_abs_yaw_rate_radps": float(np.max(np.abs(truth.yaw_rate_radps))),
        "final_turn_diameter_m": float(np.mean(2.0 * np.hypot(u, v) / np.abs(r))) if turning else None,
        "final_turn_speed_mps": float(np.mean(np.hypot(u, v))) if turning else None,
    }


def run(args: argparse.Namespace) -> int:
    """Handler of ``simulate``."""
    from boat_twin.twin.sea_trial import compact_trial_messages, run_compact_trial
    from boat_twin.validation import integer
    from boat_twin.vessel.manoeuvres import execute_time_s, manoeuvre_figures
    from boat_twin.vessel.params import describe
    from boat_twin.vessel.scenarios import scenario_warnings

    integer("--seed", args.seed, minimum=0, maximum=SEED_MAX)
    if args.duration is not None:  # every path: a scenario, --commands, --mavlink, --tlog, --ensemble
        from boat_twin.vessel.scenarios import MAX_DURATION_S

        if not (math.isfinite(args.duration) and 0.0 < args.duration <= MAX_DURATION_S):
            raise InputError(f"--duration must be a positive number of seconds up to {MAX_DURATION_S:g} (7 days), "
                             f"got {args.duration!r}")
    if args.ensemble is not None:
        return _run_ensemble(args)
    if args.out is not None and args.out.suffix.lower() in (".tlog", ".bin", ".csv"):
        raise InputError(f"--out {args.out}: writes a rosbag2 (a directory, or a .mcap file), which readers take "
                         f"for a {args.out.suffix} file by its name; for a MAVLink log use --tlog FILE")
    refuse_input_as_output(args.out, args.commands, args.config, args.model, args.tlog)
    refuse_input_as_output(args.tlog, args.commands, args.config, args.model)
    refuse_input_as_output(args.plot, args.commands, args.config, args.model, args.out, args.tlog)
    if args.plot is not None and args.plot.suffix.lower() != ".png":
        raise InputError(f"--plot {args.plot}: writes a PNG; give a file name ending in .png")
    if args.plot is not None and (args.mavlink is not None or args.tlog is not None):
        raise InputError("--plot applies to a batch simulation, not to --mavlink / --tlog")
    address = foxglove_address(args)
    view_mcap = view_mcap_path(args.out) if address is not None and args.out is not None else None
    refuse_input_as_output(view_mcap, args.commands, args.config, args.model)
    for output, kind in ((args.out, "bag"), (args.tlog, "tlog"), (args.plot, "file"), (view_mcap, "file")):
        if output is not None:
            prepare_output(output, args.force, kind)  # refused before the simulation, checked again when written
    config = twin_config_from_args(args)
    if args.mavlink is not None or args.tlog is not None:
        return _run_mavlink(args, config, address, view_mcap)
    progress = Progress()
    scenario = _scenario(args, config, progress)
    if args.out is None and args.plot is None and not args.json and address is None:
        raise InputError("nothing to do: give --out BAG (and/or --plot PNG, --json, --foxglove)")
    warnings = scenario_warnings(config.vessel, scenario)
    for warning in warnings:
        sys.stderr.write(f"warning: {warning}\n")
    progress.duration_s = scenario.duration_s
    trial = run_compact_trial(config, scenario, args.seed, noise=not args.no_noise, progress=progress.simulated)
    result = {"scenario": scenario.name, "seed": args.seed, **summarize(trial.truth),
              "vessel": describe(config.vessel), "warnings": warnings}
    figures = manoeuvre_figures(scenario, trial.truth, config.vessel.length_m)
    if figures is not None:
        result["manoeuvre"] = figures
    if args.out is not None:
        from boat_twin.io.bags import write_bag

        result["bag"] = str(args.out)
        result["messages"] = write_bag(args.out, progress.writing(compact_trial_messages(trial), args.out),
                                       args.storage, args.force)
    if args.plot is not None:
        from boat_twin.files import atomic_save_figure
        from boat_twin.plots import manoeuvre_figure

        title = f"simulate {scenario.name}, seed {args.seed}" + ("" if args.config is None else f", {args.config}")
        atomic_save_figure(args.plot, manoeuvre_figure(trial.truth, figures, execute_time_s(scenario), title))
        result["plot"] = str(args.plot)
    if address is not None:
        _show(args, address, view_mcap, trial)
        if view_mcap is not None:
            result["view"] = str(view_mcap)
    if args.json:
        print(to_json(result))
    else:
        print(f"simulated {scenario.name}: {result['duration_s']:.1f} s, top surge {result['max_surge_mps']:.2f} m/s",
              file=sys.stdout)
        if figures is not None:
            print("IMO figures (--json for all): " + ", ".join(
                f"{key} {value:.3g}" for key, value in figures.items()
                if isinstance(value, float) and key.endswith(("_L", "_deg", "_s")) and "limit" not in key))
        if args.out is not None:
            print(f"wrote {result['messages']} messages to {args.out}")
        if args.plot is not None:
            print(f"wrote {args.plot}")
        if "view" in result:
            print(f"wrote {result['view']}")
    return 0


def view_mcap_path(out: Path) -> Path:
    """Where ``--foxglove`` records the view beside the bag ``--out``: BAG.view.mcap (x.mcap: x.view.mcap)."""
    stem = out.stem if out.suffix.lower() == ".mcap" else out.name
    return out.with_name(f"{stem}.view.mcap")


@contextmanager
def _view(args: argparse.Namespace, address: tuple[str, int], view_mcap: Path | None, config: TwinConfig
          ) -> Iterator[TwinView]:
    """--foxglove's server on ``address`` for the boat of ``config``, recording to ``view_mcap`` (None: not
    recorded; the file swapped in whole when the run ends)."""
    from boat_twin.files import OutputClaim
    from boat_twin.view.stream import TwinView

    hull = (config.vessel.length_m, config.vessel.beam_m)
    with ExitStack() as stack:
        recorded = None
        if view_mcap is not None:
            claim = stack.enter_context(OutputClaim(view_mcap, force=args.force, kind="file"))
            recorded = claim.scratch / view_mcap.name
        view = TwinView(address, recorded, hull_m=hull)
        try:
            announce_view(view.url)
            yield view
        finally:
            view.close()
        if recorded is not None:
            claim.commit(recorded)


def _show(args: argparse.Namespace, address: tuple[str, int], view_mcap: Path | None, trial: CompactTrial) -> None:
    """--foxglove: the run replayed into the live view at --foxglove-speed (recorded to ``view_mcap``)."""
    from boat_twin.view.observer import Pacer
    from boat_twin.view.simulation import show_trial

    with _view(args, address, view_mcap, trial.config) as view:
        show_trial(view, trial, Pacer(args.foxglove_speed))


def _run_ensemble(args: argparse.Namespace) -> int:
    """``--ensemble N``: N drawn boats through the scenario in chunks (:func:`boat_twin.fleet.run_ensemble`)."""
    from boat_twin.fleet.batch import Progress
    from boat_twin.fleet.engine import open_client
    from boat_twin.fleet.ensemble import EnsembleSpec, ensemble_chunks, run_ensemble

    for flag, value in (("--commands", args.commands), ("--mavlink", args.mavlink), ("--tlog", args.tlog)):
        if value is not None:
            raise InputError(f"--ensemble runs a named scenario; {flag} does not apply")
    if not args.scenario:
        raise InputError(f"--ensemble: name a scenario ({', '.join(SCENARIO_NAMES)})")
    if args.out is None:
        raise InputError("--ensemble needs --out DIR for the chunk files and the summary")
    if args.out.exists() and not args.out.is_dir():
        raise InputError(f"{args.out}: --out must be a directory for an ensemble, and this is a file")
    refuse_input_as_output(args.out, args.config, args.model)
    spec = EnsembleSpec(args.scenario, args.ensemble, args.seed, args.duration, args.chunk,
                        twin_config_from_args(args))
    bar = None if args.json else Progress("ensemble chunks", len(ensemble_chunks(spec)))
    with open_client(args.scheduler, args.workers, quiet=args.json) as client:
        rows = run_ensemble(spec, args.out, client, force=args.force, progress=bar.update if bar else None)
    failed = [row for row in rows if row["status"] != "ok"]
    if args.json:
        print(to_json(rows))
    else:
        print(f"ensemble of {args.ensemble} {args.scenario} boats: {len(rows)} chunk(s), {len(failed)} failed; "
              f"summary {args.out / 'summary.csv'}")
    if failed:
        raise InputError(f"{len(failed)} of {len(rows)} chunk(s) failed (first: chunk {failed[0]['chunk']}: "
                         f"{failed[0]['error']})")
    return 0


def _run_mavlink(args: argparse.Namespace, config: TwinConfig, address: tuple[str, int] | None,
                 view_mcap: Path | None) -> int:
    """``--mavlink`` / ``--tlog``: the live twin as a MAVLink boat, paced by ``--mavlink-speed``; Ctrl-C ends it.
    ``address``: --foxglove, the boat shown live as it runs (recorded to ``view_mcap``)."""
    import math
    import signal
    import time

    from boat_twin.link.mavlink_boat import MavlinkBoat, parse_stream_rates, progress_to_stderr
    from boat_twin.twin.live import LiveTwin
    from boat_twin.vessel.simulate import OUTPUT_RATE_HZ
    from boat_twin.view.simulation import SimulationView

    if math.isnan(args.mavlink_speed) or args.mavlink_speed < 0.0:
        raise InputError(f"--mavlink-speed must be a non-negative factor, got {args.mavlink_speed!r}")
    scenario = _scenario(args, config) if (args.scenario or args.commands or args.mavlink is None) else None
    duration = scenario.duration_s if scenario is not None else args.duration
    if duration is not None and not duration > 0.0:
        raise InputError(f"--duration must be a positive number of seconds, got {duration!r}")
    twin = LiveTwin(config, seed=args.seed, noise=not args.no_noise, epoch_s=round(time.time(), 3))
    stopping: list[bool] = []
    shown = _view(args, address, view_mcap, config) if address is not None else nullcontext()
    with shown as view, MavlinkBoat(twin, args.mavlink, allow_remote=args.allow_remote, tlog=args.tlog,
                                    overwrite=args.force, scenario=scenario,
                                    rates_hz=parse_stream_rates(args.mavlink_rate)) as link:
        speed = args.mavlink_speed if args.mavlink is not None else 0.0
        where = args.mavlink or "no network"
        sys.stderr.write(f"MAVLink boat (system {link.system_id}) -> {where}, "
                         f"{'as fast as possible' if speed == 0 else f'{speed:g}x real time'}"
                         f"{'' if duration is not None else '; Ctrl-C to stop'}\n")
        previous = {}
        try:  # Ctrl-C or SIGTERM ends a live run cleanly (the .tlog and the bag are completed)
            for signum in (signal.SIGINT, signal.SIGTERM):
                previous[signum] = signal.signal(signum, lambda *_: stopping.append(True))
        except ValueError:  # not the main thread: no handler
            pass
        try:
            ticks = link.ticks(duration, speed, stop=lambda: bool(stopping), progress=progress_to_stderr)
            if view is not None:
                ticks = _shown(ticks, SimulationView(view, config), twin)
            if args.out is not None:
                from boat_twin.io.bags import write_bag

                count = write_bag(args.out, (m for tick in ticks for m in tick), args.storage, args.force)
            else:
                count = None
                for _ in ticks:
                    pass
        finally:
            for signum, handler in previous.items():
                signal.signal(signum, handler)
        progress_to_stderr(link.summary_line())
        result = {"scenario": scenario.name if scenario is not None else None, "seed": args.seed,
                  "mavlink": args.mavlink, "speed": speed,
                  "duration_s": max(twin.tick_index - 1, 0) / OUTPUT_RATE_HZ,
                  "tlog": str(args.tlog) if args.tlog else None, "link": link.stats.as_dict()}
    if count is not None:
        result.update(bag=str(args.out), messages=count)
    if view_mcap is not None:
        result["view"] = str(view_mcap)
    if args.json:
        print(to_json(result))
    else:
        name = scenario.name if scenario is not None else "ground-station control"
        print(f"streamed {name}: {result['duration_s']:.1f} s simulated, {link.stats.packets_sent} packets sent, "
              f"{link.stats.packets_logged} logged" + (f", {count} messages to {args.out}" if count else ""))
        if view_mcap is not None:
            print(f"wrote {view_mcap}")
    return 0


def _shown(ticks: Iterator[list[Message]], sim: SimulationView, twin: LiveTwin) -> Iterator[list[Message]]:
    """``ticks`` passed on, each shown in the view as it is run (its GNSS fixes, the boat's true pose)."""
    from boat_twin.vessel.simulate import OUTPUT_RATE_HZ

    for tick in ticks:
        sim.tick(tick, twin.time_s - 1.0 / OUTPUT_RATE_HZ, twin.state[0])
        yield tick
