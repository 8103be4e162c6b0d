"""The package's layers, lowest first: a module imports only from its own layer or below (function-level imports
included), and the sibling packages of one layer (identification, diagnosis, plots) not from each other. The order
is the architecture of docs/architecture.md."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "boat_twin"
LAYERS = (
    ("errors", "units", "frames", "signal_noise", "files", "validation", "lazy", "data",
    "threads", "progress_line", "rows", "folded_lsq", "drawn_line"),  # util: no domain knowledge
    ("cable",),  # towed body + cable (the vessel's tow load uses it)
    ("vessel",),  # params, resistance, dynamics, environment, scenarios
    ("sensors",),  # observation models: truth -> measurements
    ("config", "model_error"),  # the twin's configuration: vessel + environment + sensors (+ tow, model error)
    ("io",),  # formats: ROS 2 messages, bags, MAVLink logs -> Trial
    ("twin",),  # the twin run batch (sea trial) or tick by tick (live)
    ("ident", "diagnose", "plots"),  # analyses of trials: siblings over one core (SIBLINGS)
    ("shadow",),  # the live twin following a boat: uses identification (adaptation) and the diagnosis catalogue
    ("link",),  # the twin as a live MAVLink boat
    ("view",),  # the twin seen in Foxglove: live WebSocket and MCAP channels of what the shadow twin finds
    ("fleet",),  # many trials and large ensembles as tasks on Dask (or one after another)
    ("nodes", "cli"),  # front ends: ROS 2 nodes, the boat-twin command
)

SIBLINGS = frozenset({"ident", "diagnose", "plots"})
"""Packages of one layer that never import each other: identification and diagnosis both build on the twin's
windowed replay (twin/replay.py) and the paper's tables (data/), not on one another."""


def top_of(module: str) -> str:
    return module.split(".")[1] if module.count(".") else ""


def layer_of(module: str) -> int:
    top = top_of(module)
    for index, names in enumerate(LAYERS):
        if top in names:
            return index
    raise AssertionError(f"boat_twin.{top} is in no layer: add it to LAYERS (and the README)")


def imports_of(path: Path) -> set[str]:
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("boat_twin."):
            found.add(node.module)
        elif isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name.startswith("boat_twin.")}
    return found


def wrong_import(module: str, target: str) -> str | None:
    """Why ``module`` must not import ``target`` (None: it may)."""
    if layer_of(target) > layer_of(module):
        return "runs back up"
    own, other = top_of(module), top_of(target)
    if own != other and {own, other} <= SIBLINGS:
        return "crosses to a sibling"
    return None


def test_every_module_imports_only_its_layer_or_below() -> None:
    wrong = []
    for path in sorted(ROOT.rglob("*.py")):
        relative = path.relative_to(ROOT.parent).with_suffix("")
        module = ".".join(relative.parts)
        if module in ("boat_twin.__init__",):
            continue
        wrong += [f"{module} -> {target}: {why}" for target in sorted(imports_of(path))
                  if (why := wrong_import(module, target))]
    assert not wrong, "imports against the layers:\n" + "\n".join(wrong)


@pytest.mark.parametrize(("module", "target"), [
    ("boat_twin.ident.manoeuvring", "boat_twin.diagnose.search"),
    ("boat_twin.diagnose.pipeline", "boat_twin.ident.paper"),
    ("boat_twin.plots", "boat_twin.ident.report"),
    ("boat_twin.twin.replay", "boat_twin.ident.steady"),
])
def test_the_rule_refuses_siblings_both_ways_and_upward_imports(module: str, target: str) -> None:
    assert wrong_import(module, target) is not None


@pytest.mark.parametrize(("module", "target"), [
    ("boat_twin.ident.manoeuvring", "boat_twin.twin.replay"),
    ("boat_twin.diagnose.pipeline", "boat_twin.data.dyda2021"),
    ("boat_twin.ident.report", "boat_twin.ident.paper"),
    ("boat_twin.cli.diagnose", "boat_twin.ident"),
])
def test_the_rule_allows_the_own_package_and_below(module: str, target: str) -> None:
    assert wrong_import(module, target) is None


def test_every_package_names_its_public_api() -> None:
    for init in sorted(ROOT.glob("*/__init__.py")):
        if init.parent.name in ("nodes", "cli", "data"):
            continue  # front ends and the data package: entry points, not a library API
        tree = ast.parse(init.read_text())
        names = [t.id for n in tree.body if isinstance(n, ast.Assign) for t in n.targets if isinstance(t, ast.Name)]
        assert "__all__" in names, f"{init.parent.name}/__init__.py has no __all__"
