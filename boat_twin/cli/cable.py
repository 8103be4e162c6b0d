"""``boat-twin cable``: towed-cable configuration (depth | length | convergence | speed) from a case file.

The cable library is imported by the handlers, so that ``--help`` answers at once."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from boat_twin.cli import verb_help
from boat_twin.files import atomic_save_figure, ensure_out_dir, prepare_output, to_json

if TYPE_CHECKING:
    from boat_twin.cable.case import CableCase
    from boat_twin.cable.problems import CableSolution

DEFAULT_OUT = Path("out/cable")


def _progress(message: str) -> None:
    sys.stderr.write(f"boat-twin cable: {message}\n")
    sys.stderr.flush()


def _case(args: argparse.Namespace) -> CableCase:
    from boat_twin.cable.case import load_case, with_overrides

    case = load_case(args.case)
    return with_overrides(case, tow_speed_mps=getattr(args, "tow_speed", None), segment_length_m=args.segment_length)


def _check_plot(args: argparse.Namespace, name: str) -> None:
    """With --plot, refuse ``--out/name`` before any work if it may not be written (exists without --force, or is
    not a file): :func:`_save` checks again when it writes."""
    path = Path(args.out) / name
    if args.plot and (path.exists() or path.is_symlink()):
        prepare_output(path, args.force)


def _save(args: argparse.Namespace, name: str, figure: object) -> Path:
    path = ensure_out_dir(Path(args.out)) / name
    prepare_output(path, args.force)
    atomic_save_figure(path, figure)
    return path


def _report(args: argparse.Namespace, case: CableCase, solution: CableSolution) -> int:
    if args.plot:
        from boat_twin.cable.plot import shape_figure

        path = _save(args, f"cable_{solution.problem}.png", shape_figure(case, solution))
        _progress(f"wrote {path}")
    if args.json:
        print(to_json({"case": case.source, **solution.to_dict()}))
        return 0
    b = solution.body
    print(f"case                {case.source} ({case.cable.drag.to_dict()['model']} drag, "
          f"{solution.link_length_m.size} links of {solution.segment_length_m:g} m)")
    print(f"tow speed           {solution.tow_speed_mps:.3f} m/s (flow at the vehicle {b.flow_mps:.3f} m/s)")
    print(f"cable length        {solution.length_m:.3f} m")
    print(f"vehicle depth       {solution.vehicle_depth_m:.3f} m")
    print(f"vehicle offset      {solution.vehicle_offset_m:.3f} m astern of the tow point")
    print(f"attack angle        {math.degrees(b.alpha_rad):.3f} deg")
    print(f"top tension         {solution.top_tension_N:.1f} N at "
          f"{math.degrees(solution.top_angle_rad):.2f} deg below horizontal "
          f"(aft {solution.top_aft_N:.1f} N, down {solution.top_down_N:.1f} N)")
    return 0


def _depth(args: argparse.Namespace) -> int:
    from boat_twin.cable.problems import solve_depth

    case = _case(args)
    _check_plot(args, "cable_depth.png")
    return _report(args, case, solve_depth(case, args.length))


def _length(args: argparse.Namespace) -> int:
    from boat_twin.cable.problems import solve_length

    case = _case(args)
    _check_plot(args, "cable_length.png")
    return _report(args, case, solve_length(case, args.depth))


def _convergence(args: argparse.Namespace) -> int:
    from boat_twin.cable.convergence import PAPER_SEGMENTS_M, convergence_study

    case = _case(args)
    _check_plot(args, "cable_convergence.png")
    study = convergence_study(case, args.segments or PAPER_SEGMENTS_M, args.tolerance, progress=_progress)
    if args.plot:
        from boat_twin.cable.plot import convergence_figure

        _progress(f"wrote {_save(args, 'cable_convergence.png', convergence_figure(study))}")
    if args.json:
        print(to_json(study.to_dict()))
        return 0
    print(f"case {case.source}: {study.drag_model} drag; continuous reference (ODE): "
          f"L = {study.reference_length_m:.4f} m, depth = {study.reference_depth_m:.4f} m")
    print(f"{'l (m)':>8} {'links':>6} {'depth (m)':>11} {'err (m)':>10} {'order':>6} "
          f"{'length (m)':>11} {'err (m)':>10} {'order':>6}")

    def fmt(order: float | None) -> str:
        return f"{order:6.3f}" if order is not None else f"{'-':>6}"

    for r in study.rows:
        print(f"{r.segment_length_m:8.4g} {r.links:6d} {r.vehicle_depth_m:11.4f} {r.depth_error_m:10.4f} "
              f"{fmt(r.depth_order)} {r.length_m:11.4f} {r.length_error_m:10.4f} {fmt(r.length_order)}")
    if study.segment_for_tolerance_m is None:
        print("observed order undefined (errors vanish or change sign): no estimate of l for the tolerance")
    else:
        assert study.check_depth_error_m is not None  # set whenever the order is defined
        print(f"observed order {study.depth_order:.3f}; l for {study.tolerance:.2%} depth accuracy: "
              f"{study.segment_for_tolerance_m:.4g} m (checked: error {study.check_depth_error_m:.4f} m = "
              f"{abs(study.check_depth_error_m) / study.reference_depth_m:.4%})")
    return 0


def _speed(args: argparse.Namespace) -> int:
    from boat_twin.cable.problems import tow_speed_for_depth

    case = _case(args)
    _progress("searching the tow speed ...")
    speed = tow_speed_for_depth(case, args.depth, args.length)
    length = case.cable.length_m if args.length is None else args.length
    if args.json:
        print(to_json({"case": case.source, "tow_speed_mps": speed, "vehicle_depth_m": args.depth,
                       "length_m": length, "segment_length_m": case.cable.segment_length_m}))
    else:
        print(f"tow speed {speed:.4f} m/s holds the vehicle at {args.depth:g} m on {length:g} m of cable "
              f"(links of {case.cable.segment_length_m:g} m)")
    return 0


def _common(parser: argparse.ArgumentParser, outputs: bool = True) -> None:
    """The options every sub-verb takes; ``outputs=False`` (``speed``: no plot, and the tow speed is the answer,
    not an input): without --tow-speed, --plot, --out and --force."""
    parser.add_argument("--case", type=Path, required=True, metavar="FILE", help="case YAML file (see config/cable/)")
    if outputs:
        parser.add_argument("--tow-speed", type=float, metavar="MPS", help="tow speed, m/s (default: the case's)")
    parser.add_argument("--segment-length", type=float, metavar="M",
                        help="length l of the rigid links the cable is cut into, m (default: the case's)")
    parser.add_argument("--json", action="store_true", help="machine-readable result on stdout")
    if outputs:
        parser.add_argument("--plot", action="store_true", help="write a PNG into --out")
        parser.add_argument("--out", type=Path, default=DEFAULT_OUT, metavar="DIR",
                            help=f"output directory (default {DEFAULT_OUT})")
        parser.add_argument("--force", action="store_true", help="overwrite an existing PNG")


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``cable`` and its sub-verbs to the ``boat-twin`` parser."""
    cable = subparsers.add_parser(
        "cable", help=verb_help("cable"),
        description="Towed underwater vehicle on a flexible cable in a depth-varying current. SI units: "
                    "lengths and depths in m, speeds in m/s, forces in N, angles printed in degrees.")
    verbs = cable.add_subparsers(dest="cable_verb", required=True)
    p = verbs.add_parser("depth", help="problem 1: vehicle depth and cable shape for a cable length",
                         description="Problem 1: given the cable length (m), find the vehicle depth (m), its "
                                     "offset astern (m), the attack angle, the shape and the tensions (N).")
    _common(p)
    p.add_argument("--length", type=float, metavar="M", help="cable length paid out, m (default: the case's)")
    p.set_defaults(handler=_depth)
    p = verbs.add_parser("length", help="problem 2: cable length that puts the vehicle at a depth",
                         description="Problem 2: given the vehicle depth (m), find the cable length (m), "
                                     "shape and tensions (N); the length is cut inside the last link.")
    _common(p)
    p.add_argument("--depth", type=float, metavar="M",
                   help="vehicle depth, m (default: the case file's target_depth_m)")
    p.set_defaults(handler=_length)
    p = verbs.add_parser("convergence", help="how the link model nears the continuous cable as the links shrink",
                         description="Errors of problems 1 and 2 against the continuous cable (ODE) for each "
                                     "link length l (m), observed order, and the l for a depth accuracy.")
    _common(p)
    p.add_argument("--segments", type=float, nargs="+", metavar="M",
                   help="link lengths l, m, decreasing (default: the paper's Fig. 5: 5 2.5 1.25 0.625)")
    p.add_argument("--tolerance", type=float, default=1e-3, metavar="FRACTION",
                   help="relative depth accuracy for the l estimate (default 0.001 = 0.1%%)")
    p.set_defaults(handler=_convergence)
    p = verbs.add_parser("speed", help="tow speed that holds the vehicle at a depth on a given length",
                         description="Find the tow speed (m/s) at which the cable length (m) holds the "
                                     "vehicle at the given depth (m).")
    _common(p, outputs=False)
    p.add_argument("--depth", type=float, required=True, metavar="M", help="vehicle depth, m")
    p.add_argument("--length", type=float, metavar="M", help="cable length, m (default: the case's)")
    p.set_defaults(handler=_speed)
