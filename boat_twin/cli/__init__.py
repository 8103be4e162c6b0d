"""``boat-twin``: simulate, identify and diagnose a small planing boat; towed-cable configuration.

Each verb lives in its own module of this package: a front end that parses flags, calls the library's public
API and prints or writes what it returns. A verb module (listed in :data:`VERBS`) provides
``register(subparsers)``, which adds its parser and sets ``handler`` (a function ``(args) -> int``) with
``set_defaults``. Bad input raises :class:`boat_twin.errors.InputError`; ``main`` turns it into one line on
stderr and exit code 2, without a traceback.
"""

from __future__ import annotations

import argparse
import gc
import importlib
import os
import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager

from boat_twin import __version__, progress_line
from boat_twin.errors import InputError, PrintedStops
from boat_twin.threads import one_blas_thread, one_blas_thread_environment

VERBS: dict[str, tuple[str, str]] = {
    "simulate": ("boat_twin.cli.simulate", "simulate a sea trial and write it as a ROS 2 bag"),
    "identify": ("boat_twin.cli.identify",
                 "identify the thrust-speed model (resistance curve, effective mass) from a trial or a table"),
    "diagnose": ("boat_twin.cli.diagnose", "find what the model gets wrong on a trial (or a steady-state table)"),
    "follow": ("boat_twin.cli.follow",
               "replay a trial through the live twin: innovations, online adaptation, rolling diagnosis"),
    "convert": ("boat_twin.cli.convert",
                "convert a MAVLink log (.tlog, .BIN) into a rosbag2 with the package's topics"),
    "cable": ("boat_twin.cli.cable",
              "towed cable: vehicle depth, cable length, convergence (Babanin & Melkonyan 2025)"),
    "demo": ("boat_twin.cli.demo", "a tour on the shipped sample trial: regenerate, read back, plot, identify"),
}
"""Verb → (module that registers it, one-line help), in the order ``--help`` lists them. Only the verb being run
is imported (with its library): ``--help`` and ``--version`` answer at once."""

DESCRIPTION = ("Digital twin of a small planing boat: simulate sea trials into ROS 2 bags, identify its "
               "thrust-speed model from a recorded trial, diagnose what the model gets wrong, solve a towed "
               "cable, convert MAVLink logs. SI units.")
"""What ``boat-twin --help`` says first."""
EPILOG = ("'boat-twin VERB --help' shows a verb's options. Exit codes: 0 done, 2 bad input (one line on stderr "
          "naming the file or option), 130 interrupted (Ctrl-C), 143 terminated (SIGTERM). Reference: docs/ in "
          "the repository.")
"""What ``boat-twin --help`` says last: how to go on, and the exit-code contract."""


def verb_help(verb: str) -> str:
    """The one-line help of ``verb`` (what its module's ``register`` passes to ``add_parser``)."""
    return VERBS[verb][1]


class _Parser(argparse.ArgumentParser):
    """argparse with exit code 2 and one line for usage errors (argparse's own convention too)."""

    def error(self, message: str) -> None:  # type: ignore[override]
        sys.stderr.write(f"{self.prog}: error: {message}\n")
        raise SystemExit(2)


def build_parser(verb: str | None = None) -> argparse.ArgumentParser:
    """The parser: ``verb`` fully registered (its module imported), the other verbs listed with their help."""
    parser = _Parser(prog="boat-twin", description=DESCRIPTION, epilog=EPILOG)
    parser.add_argument("--version", action="version", version=f"boat-twin {__version__}")
    subparsers = parser.add_subparsers(dest="verb", required=True, parser_class=_Parser)
    for name, (module, help_text) in VERBS.items():
        if name == verb:
            importlib.import_module(module).register(subparsers)
        else:
            subparsers.add_parser(name, help=help_text)
    return parser


RESIGNAL_DELAY_S = 0.05
"""Delay before a signal lost in a callback is sent again, s (a callback such as llvmlite's returns within it)."""


class Terminated(BaseException):
    """SIGTERM during a run: unwinds like Ctrl-C, so that outputs being written are dropped and old ones kept."""


def _terminate(signum: int, frame: object) -> None:
    raise Terminated


def _raise_lost_signal(unraisable: sys.UnraisableHookArgs) -> None:
    """``sys.unraisablehook`` for a run: Ctrl-C or SIGTERM landing in a callback Python cannot raise from (e.g.
    llvmlite's cache notification while numba compiles) would be printed as "Exception ignored ... Traceback" and
    lost; the signal is sent again instead, from a timer thread a moment later (raised here, inside the hook, it
    would be ignored in turn), to be acted on once the callback has returned."""
    if isinstance(unraisable.exc_value, KeyboardInterrupt | Terminated):
        signum = signal.SIGINT if isinstance(unraisable.exc_value, KeyboardInterrupt) else signal.SIGTERM
        threading.Timer(RESIGNAL_DELAY_S, os.kill, (os.getpid(), signum)).start()
    else:
        sys.__unraisablehook__(unraisable)


def _drop_unraisable(unraisable: sys.UnraisableHookArgs) -> None:
    """``sys.unraisablehook`` once a run has been stopped by Ctrl-C or SIGTERM: an object the signal left half
    built fails in its destructor when it is freed (llvmlite's, interrupted while numba compiled: "Exception
    ignored in ObjectRef.__del__ ... Traceback ... AttributeError" after "boat-twin: terminated"); the run's exit
    status already says it was stopped, and a traceback would say it crashed."""


def _say_stopped(stop: BaseException) -> int:
    """The one line and the exit status of a run stopped by Ctrl-C (130) or SIGTERM (143)."""
    interrupted = isinstance(stop, KeyboardInterrupt)
    progress_line.end()
    sys.stderr.write("boat-twin: interrupted\n" if interrupted else "boat-twin: terminated\n")
    return 130 if interrupted else 143


_console = {"process": False}
"""Whether this interpreter is the ``boat-twin`` console process (:func:`main` called without arguments)."""


def settle_imports() -> None:
    """In the ``boat-twin`` process only (not a test or a notebook calling :func:`main`): put what is alive now —
    above all the modules a verb has just imported, ~150,000 objects with scipy, numba and matplotlib — out of
    the cyclic garbage collector's sight (``gc.freeze``). Every full collection later in the run walked them again:
    0.2-0.4 s of CPU of a 10-minute trial's ``diagnose`` (issue 37). They live as long as the process anyway."""
    if _console["process"]:
        gc.freeze()


@contextmanager
def settled_imports() -> Iterator[None]:
    """A verb's imports in the block, then :func:`settle_imports`; in the ``boat-twin`` process the collector
    stays off while they run (they leave little garbage, and each full collection walked every module so far)."""
    off = _console["process"] and gc.isenabled()
    if off:
        gc.disable()
    try:
        yield
    finally:
        settle_imports()
        if off:
            gc.enable()


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``boat-twin`` console script. Exit codes: 0 done, 2 bad input (one line on stderr),
    130 Ctrl-C, 143 SIGTERM (an output being written is dropped; an old one stays as it was)."""
    process = argv is None  # the console script: this process ends when main returns
    _console["process"] = process
    if process:
        one_blas_thread_environment()
    argv = sys.argv[1:] if argv is None else argv
    verb = next((a for a in argv if not a.startswith("-")), None)
    try:
        previous = signal.signal(signal.SIGTERM, _terminate)
    except ValueError:  # not the main thread: no handler
        previous = None
    previous_hook, sys.unraisablehook = sys.unraisablehook, _raise_lost_signal
    printed = PrintedStops((KeyboardInterrupt, Terminated))
    previous_excepthook, sys.excepthook = sys.excepthook, printed
    stopped: int | None = None  # the exit status of a run stopped by a signal
    try:
        args = build_parser(verb).parse_args(argv)
        with one_blas_thread():
            return int(args.handler(args))
    except InputError as err:
        progress_line.end()
        sys.stderr.write(f"boat-twin {verb}: error: {err}\n")
        return 2
    except (KeyboardInterrupt, Terminated) as stop:
        sys.unraisablehook = _drop_unraisable  # before the unwound frames are freed
        stopped = _say_stopped(stop)
        return stopped
    except Exception as err:
        from boat_twin.files import is_write_failure, write_failure

        if printed.stops:  # a C extension printed the stop and raised its own error (numba's import)
            sys.unraisablehook = _drop_unraisable
            stopped = _say_stopped(printed.stops[-1])
            return stopped
        if not is_write_failure(err):
            raise
        where = f"{err.filename}: " if isinstance(err, OSError) and err.filename else ""
        progress_line.end()
        sys.stderr.write(f"boat-twin {verb}: error: {where}cannot write ({write_failure(err)})\n")
        return 2
    finally:
        if process and previous is not None:
            # The run is over, its outputs complete: a SIGTERM or Ctrl-C from now on cannot be acted on by Python
            # (the interpreter shuts down, restoring the default handlers) and would kill the process by the
            # signal after its work is done; the process exits with the run's own status instead.
            signal.signal(signal.SIGTERM, signal.SIG_IGN)
            signal.signal(signal.SIGINT, signal.SIG_IGN)
        elif previous is not None:
            signal.signal(signal.SIGTERM, previous)
        if not (process and stopped):  # a stopped process keeps dropping them until it has ended
            sys.unraisablehook = previous_hook
        sys.excepthook = previous_excepthook
        if process and stopped:
            _end_stopped_process(stopped)
        settle_imports()  # the interpreter's teardown collects what is left, not every object of the run again


def _end_stopped_process(status: int) -> None:
    """End a stopped console process at once with ``status``: its outputs were dropped or kept as they unwound,
    and the interpreter's own teardown (collecting every object of the run) took 4-6 s after a 2-hour trial was
    read, the stop said on stderr but the process still there (issue 37: stopped within 1 s)."""
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status)
