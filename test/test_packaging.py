"""ROS packaging checked with real tools: catkin_pkg parses package.xml; every entry point resolves."""

import ast
import importlib
import importlib.util
import re
import signal
import sys
import types
from importlib.metadata import entry_points
from pathlib import Path

import pytest
from catkin_pkg.package import parse_package

ROOT = Path(__file__).resolve().parents[1]


def test_package_xml_is_a_valid_format_3_ament_python_package() -> None:
    package = parse_package(str(ROOT / "package.xml"))
    package.validate()
    assert package.name == "boat_twin" and package.package_format == 3
    assert package.get_build_type() == "ament_python"
    exec_deps = {d.name for d in package.exec_depends}
    assert {"python3-numpy", "python3-scipy", "python3-rosbags-pip", "python3-pymavlink-pip",
            "mcap-ros2-support"} <= exec_deps


def _imported_top_level(paths) -> set[str]:
    names: set[str] = set()
    for path in paths:
        tree = ast.parse(path.read_text())
        names |= {a.name.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
        names |= {(n.module or "").split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    return names


def test_package_xml_names_every_ros_package_the_nodes_and_launch_files_import() -> None:
    """What rosdep installs is what the code imports: every ROS package of nodes/ and launch/, and tf2_msgs,
    which the simulator uses when present (rclpy and every message package, never rosidl_runtime_py)."""
    exec_deps = {d.name for d in parse_package(str(ROOT / "package.xml")).exec_depends}
    code = [*(ROOT / "boat_twin" / "nodes").glob("*.py"), *(ROOT / "launch").glob("*.launch.py")]
    python_keys = {"numpy": "python3-numpy", "scipy": "python3-scipy", "yaml": "python3-yaml"}
    imported = _imported_top_level(code) - {"boat_twin", "__future__"} - set(sys.stdlib_module_names)
    imported = {python_keys.get(name, name) for name in imported}
    assert imported <= exec_deps, imported - exec_deps
    assert "tf2_msgs" in exec_deps and "rosidl_runtime_py" not in exec_deps | imported


def test_ament_resource_marker_and_setup_cfg_script_dir() -> None:
    assert (ROOT / "resource" / "boat_twin").is_file()
    assert "$base/lib/boat_twin" in (ROOT / "setup.cfg").read_text()


def _console_scripts() -> dict[str, str]:
    return {ep.name: ep.value for ep in entry_points(group="console_scripts") if ep.value.startswith("boat_twin.")}


def test_every_entry_point_resolves_to_a_callable() -> None:
    scripts = _console_scripts()
    assert {"boat-twin", "simulator", "identifier", "cable"} <= set(scripts)
    for name, target in scripts.items():
        module_name, attr = target.split(":")
        assert callable(getattr(importlib.import_module(module_name), attr)), name


def test_node_scripts_without_rclpy_say_so_in_one_line(monkeypatch, capsys) -> None:
    import boat_twin.nodes as nodes

    real_find_spec = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "rclpy" else
                        real_find_spec(name, *a))
    assert nodes.simulator_main() == 2
    assert capsys.readouterr().err.startswith("simulator: error: rclpy is not installed")


def test_a_signal_during_start_up_that_a_c_extension_printed_ends_the_node_quietly(monkeypatch, capsys) -> None:
    """Ctrl-C while numba's C extension loaded: it printed the early stop ("Traceback ... _EarlyStop", through
    sys.excepthook) and raised "ImportError: numba._devicearray failed to import"; the simulator exited 1 with
    both tracebacks (test_node_start, once in six runs of the suite). Now exit 0, nothing printed."""
    import boat_twin.nodes as nodes

    def loading() -> int:  # what numba's _dispatcher module does when its import is stopped
        try:
            signal.raise_signal(signal.SIGINT)  # the handler _run installed raises the early stop here
        except BaseException:
            sys.excepthook(*sys.exc_info())  # PyErr_Print
        raise ImportError("numba._devicearray failed to import")

    monkeypatch.setitem(sys.modules, "boat_twin.nodes.loading", types.SimpleNamespace(main=loading))
    assert nodes._run("loading") == 0
    assert capsys.readouterr().err == ""
    monkeypatch.setitem(sys.modules, "boat_twin.nodes.loading", types.SimpleNamespace(main=lambda: int("x")))
    with pytest.raises(ValueError):  # an error of its own, with no signal, is not taken for a stop
        nodes._run("loading")


def test_only_the_nodes_import_rclpy() -> None:
    for path in (ROOT / "boat_twin").rglob("*.py"):
        if "nodes" in path.parts:
            continue
        tree = ast.parse(path.read_text())
        names = {a.name.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
        names |= {(n.module or "").split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
        assert "rclpy" not in names, path


def _launch_table(name: str) -> dict:
    """The literal ``name = {...}`` of twin.launch.py (read without ROS 2's launch packages)."""
    tree = ast.parse((ROOT / "launch" / "twin.launch.py").read_text())
    (value,) = [n.value for n in tree.body if isinstance(n, ast.Assign) and getattr(n.targets[0], "id", "") == name]
    return ast.literal_eval(value)


def test_launch_file_parses_and_names_installed_executables() -> None:
    assert set(_launch_table("PARAMETERS")) <= set(_console_scripts())


@pytest.mark.skipif(importlib.util.find_spec("launch_ros") is None,
                    reason="launch_ros is not on PyPI: runs on a full ROS 2 install only")
def test_launch_description_builds() -> None:
    spec = importlib.util.spec_from_file_location("twin_launch", ROOT / "launch" / "twin.launch.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.generate_launch_description().entities


SHARED_PARAMETERS = {"conventions.frame_prefix(self)": "frame_prefix", "Diagnostics(self)": "hardware_id"}
"""Parameters that boat_twin.nodes.conventions and .diagnostics declare for the node that calls them."""


def test_launch_parameters_are_declared_by_their_nodes() -> None:
    """Every parameter twin.launch.py passes to a node is one the node declares (a typo would be ignored), set by
    a declared launch argument."""
    arguments = _launch_table("ARGUMENTS")
    for executable, table in _launch_table("PARAMETERS").items():
        source = (ROOT / "boat_twin" / "nodes" / f"{executable}.py").read_text()
        declared = set(re.findall(r'parameters\.\w+\(\s*self,\s*"([a-z_]+)"', source)) | {"use_sim_time"}
        declared |= {name for call, name in SHARED_PARAMETERS.items() if call in source}
        assert table and set(table) <= declared, (executable, set(table) - declared)
        assert set(table.values()) <= set(arguments), (executable, set(table.values()) - set(arguments))


def test_launch_passes_only_the_arguments_given_so_the_nodes_keep_their_defaults(monkeypatch) -> None:
    """An empty launch argument is not passed (the node's own default holds); one given is, as a substitution
    that launch_ros types. ROS 2's launch packages are stood in for by recorders: only the selection is tested."""

    class Recorded:
        def __init__(self, *args, **kwargs) -> None:
            self.args, self.kwargs = args, kwargs

    class Configuration(Recorded):
        def perform(self, context: dict) -> str:
            return context.get(self.args[0], "")

    stubs = {"launch": {"LaunchContext": dict, "LaunchDescription": Recorded},
             "launch.actions": {"DeclareLaunchArgument": Recorded, "OpaqueFunction": Recorded},
             "launch.substitutions": {"LaunchConfiguration": Configuration}, "launch_ros.actions": {"Node": Recorded}}
    for name, attributes in stubs.items():
        module = types.ModuleType(name)
        vars(module).update(attributes)
        monkeypatch.setitem(sys.modules, name, module)
    spec = importlib.util.spec_from_file_location("twin_launch_stubbed", ROOT / "launch" / "twin.launch.py")
    launch = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(launch)
    defaults = {name: default for name, (default, _) in launch.ARGUMENTS.items()}
    nodes = {n.kwargs["executable"]: n.kwargs["parameters"][0] for n in launch.nodes(defaults)}
    assert {k: {p: v.args[0] for p, v in d.items()} for k, d in nodes.items()} == {
        "simulator": {}, "identifier": {}, "cable": {"follow_gnss_vel": "follow_gnss_vel"}}
    nodes = {n.kwargs["executable"]: n.kwargs["parameters"][0]
             for n in launch.nodes({**defaults, "seed": "7", "sim_time": "true"})}
    assert set(nodes["simulator"]) == {"seed", "publish_clock"} and set(nodes["identifier"]) == {"use_sim_time"}
    description = launch.generate_launch_description()
    declared = [e.args[0] for e in description.args[0] if isinstance(e, Recorded) and e.args and isinstance(
        e.args[0], str)]
    assert declared == list(launch.ARGUMENTS)
