"""``boat-twin VERB --help`` answers without loading the libraries, and its texts are written for users."""

import argparse
import json
import subprocess
import sys

import pytest

from boat_twin.cli import VERBS, build_parser, main

HEAVY = ("numpy", "scipy", "matplotlib", "numba", "rosbags", "pymavlink", "pymap3d")
"""Libraries a --help must not import (each costs 0.1 to 1.5 s of CPU: benchmarks/bench_cli.py)."""

CABLE_VERBS = ("depth", "length", "convergence", "speed")

_PROBE = """
import contextlib, io, json, sys
from boat_twin.cli import main
texts = {}
for argv in json.loads(sys.argv[1]):
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.suppress(SystemExit):
        main([*argv, "--help"])
    texts[" ".join(argv) or "boat-twin"] = out.getvalue()
heavy = sorted({name.split(".")[0] for name in sys.modules} & set(json.loads(sys.argv[2])))
print(json.dumps({"heavy": heavy, "texts": texts}))
"""


@pytest.fixture(scope="module")
def helps() -> dict:
    """Every help text, printed in one fresh interpreter, and the heavy libraries it imported."""
    argvs = [[], *([verb] for verb in VERBS), *(["cable", sub] for sub in CABLE_VERBS)]
    done = subprocess.run([sys.executable, "-c", _PROBE, json.dumps(argvs), json.dumps(HEAVY)],
                          capture_output=True, text=True, check=True, timeout=120)
    return json.loads(done.stdout)


def test_help_of_every_verb_imports_no_library(helps: dict) -> None:
    assert helps["heavy"] == []
    assert all(text.startswith("usage: boat-twin") for text in helps["texts"].values())
    assert len(helps["texts"]) == 1 + len(VERBS) + len(CABLE_VERBS)


def test_help_texts_have_no_markup_or_developer_words(helps: dict) -> None:
    for where, text in helps["texts"].items():
        for word in ("``", ":func:", ":mod:", "seed boat", "docstring"):
            assert word not in text, f"{where} --help says {word!r}"
    top = helps["texts"]["boat-twin"]
    assert "Digital twin" in top and "Exit codes" in top


def test_cable_speed_does_not_offer_the_speed_it_solves_for(helps: dict) -> None:
    assert "--tow-speed" not in helps["texts"]["cable speed"]
    assert "--tow-speed" in helps["texts"]["cable depth"]


def test_a_verb_still_runs_after_its_lazy_imports(capsys) -> None:
    """The handler imports what the parser did not: a real run (the paper's table, no files) completes."""
    assert main(["identify", "--table", "dyda2021", "--order", "1", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["selected_order"] == 1


def _option_actions(parser: argparse.ArgumentParser, where: str):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _option_actions(sub, f"{where} {name}")
        elif action.option_strings and action.nargs != 0:
            yield where, action


def test_every_option_value_is_named_for_what_it_is() -> None:
    """One style across verbs: a file is FILE, a directory DIR, a bag BAG, seconds S, a count N; a closed set
    is shown as its choices. None falls back to argparse's upper-cased option name (--config CONFIG)."""
    unnamed = [f"{where} {action.option_strings[0]}" for verb in VERBS
               for where, action in _option_actions(build_parser(verb), "boat-twin")
               if action.metavar is None and action.choices is None]
    assert not unnamed, unnamed
    metavars = {(action.option_strings[0], action.metavar) for verb in VERBS
                for _, action in _option_actions(build_parser(verb), "") if isinstance(action.metavar, str)}
    for option in ("--config", "--model", "--calibration", "--case"):
        assert {m for o, m in metavars if o == option} == {"FILE"}, option
    assert {m for o, m in metavars if o == "--window"} == {"S"}
    assert {m for o, m in metavars if o == "--out"} <= {"DIR", "BAG"}
