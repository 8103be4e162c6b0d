"""The package's layers, lowest first: a module imports only from its own layer or below (function-level imports
included). The order is the architecture of the README's developer section."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1] / "boat_twin"
LAYERS = (
    ("errors", "units", "signal_noise", "files", "validation", "lazy", "data", "threads"),  # util: no domain knowledge
    ("cable",),  # towed body + cable (the vessel's tow load uses it)
    ("vessel",),  # params, resistance, dynamics, environment, scenarios
    ("sensors",),  # observation models: truth -> measurements
    ("config",),  # the twin's configuration: vessel + environment + sensors (+ tow)
    ("io",),  # formats: ROS 2 messages, bags, MAVLink logs -> Trial
    ("twin",),  # the twin run batch (sea trial) or tick by tick (live)
    ("ident", "diagnose", "plots"),  # analyses of trials
    ("link",),  # the twin as a live MAVLink boat
    ("fleet",),  # many trials and large ensembles as tasks on Dask (or one after another)
    ("nodes", "cli"),  # front ends: ROS 2 nodes, the boat-twin command
)


def layer_of(module: str) -> int:
    top = module.split(".")[1] if module.count(".") else ""
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


def test_every_module_imports_only_its_layer_or_below() -> None:
    wrong = []
    for path in sorted(ROOT.rglob("*.py")):
        relative = path.relative_to(ROOT.parent).with_suffix("")
        module = ".".join(relative.parts)
        if module in ("boat_twin.__init__",):
            continue
        own = layer_of(module)
        wrong += [f"{module} -> {target}" for target in imports_of(path) if layer_of(target) > own]
    assert not wrong, "imports that run back up:\n" + "\n".join(wrong)


def test_every_package_names_its_public_api() -> None:
    for init in sorted(ROOT.glob("*/__init__.py")):
        if init.parent.name in ("nodes", "cli", "data"):
            continue  # front ends and the data package: entry points, not a library API
        tree = ast.parse(init.read_text())
        names = [t.id for n in tree.body if isinstance(n, ast.Assign) for t in n.targets if isinstance(t, ast.Name)]
        assert "__all__" in names, f"{init.parent.name}/__init__.py has no __all__"
