"""``boat-twin``: the command line. Each verb lives in its own module of this package and registers itself here.

The verbs are front ends: they parse flags, call the library's public API and print or write what it returns.

A verb module provides ``register(subparsers)``, which adds its parser and sets ``handler`` (a function
``(args) -> int``) with ``set_defaults``. Bad input raises :class:`boat_twin.errors.InputError`; ``main``
turns it into one line on stderr and exit code 2, without a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from boat_twin import __version__
from boat_twin.errors import InputError

VERB_MODULES = (
    "boat_twin.cli.simulate",
    "boat_twin.cli.identify",
    "boat_twin.cli.diagnose",
    "boat_twin.cli.convert",
    "boat_twin.cli.cable",
    "boat_twin.cli.demo",
)
"""Modules that register verbs, in the order ``--help`` lists them."""


class _Parser(argparse.ArgumentParser):
    """argparse with exit code 2 and one line for usage errors (argparse's own convention too)."""

    def error(self, message: str) -> None:  # type: ignore[override]
        sys.stderr.write(f"{self.prog}: error: {message}\n")
        raise SystemExit(2)


def build_parser() -> argparse.ArgumentParser:
    """The full parser with every available verb."""
    parser = _Parser(prog="boat-twin", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"boat-twin {__version__}")
    subparsers = parser.add_subparsers(dest="verb", required=True, parser_class=_Parser)
    for name in VERB_MODULES:
        importlib.import_module(name).register(subparsers)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``boat-twin`` console script."""
    args = build_parser().parse_args(argv)
    try:
        return int(args.handler(args))
    except InputError as err:
        sys.stderr.write(f"boat-twin {args.verb}: error: {err}\n")
        return 2
    except KeyboardInterrupt:
        sys.stderr.write("boat-twin: interrupted\n")
        return 130
