"""ament_python package boat_twin; also installs with plain pip (the no-ROS face)."""

from glob import glob

from setuptools import find_packages, setup

PACKAGE = "boat_twin"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(include=[PACKAGE, f"{PACKAGE}.*"]),
    package_data={PACKAGE: ["data/*.csv", "data/*.yaml"]},
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/launch", glob("launch/*.launch.py")),
        (f"share/{PACKAGE}/config", glob("config/*.yaml")),
        (f"share/{PACKAGE}/config/cable", glob("config/cable/*.yaml")),
        (f"share/{PACKAGE}/config/mavlink", glob("config/mavlink/*.yaml")),
        (f"share/{PACKAGE}/config/ros", glob("config/ros/*.yaml")),
    ],
    python_requires=">=3.10",
    install_requires=[
        "numpy>=1.26",
        "scipy>=1.11",
        "PyYAML>=6.0",
        "rosbags>=0.10.4",
        "mcap>=1.1",
        "pymavlink>=2.4.40",
        "pymap3d>=3.0",
        "matplotlib>=3.6",
        "numba>=0.59",
        "zstandard>=0.21",
        "threadpoolctl>=3.1",
    ],
    extras_require={
        # ROS 2 Jazzy's core as PyPI wheels (CPython 3.11), for a machine without a ROS install; on a Jazzy
        # install the same packages come from the distribution (package.xml) and this extra is not used.
        "ros": [
            "ros-jazzy-rclpy",
            "ros-jazzy-rmw-fastrtps-cpp",
            "ros-jazzy-std-msgs",
            "ros-jazzy-geometry-msgs",
            "ros-jazzy-sensor-msgs",
            "ros-jazzy-nav-msgs",
            "ros-jazzy-diagnostic-msgs",
            "ros-jazzy-std-srvs",
        ],
        "test": [
            "pytest>=7",
            "pytest-xdist>=3.6",  # --no-loadscope-reorder
            "pytest-timeout>=2.1",  # a test that hangs fails with its stack instead of stalling the run
            "mcap-ros2-support>=0.5",
            "catkin_pkg>=1.0",
            "hypothesis>=6",
            "ruff>=0.5",
            "mypy>=1.8",
            "types-PyYAML",
            "MoorPy>=1.0",
            "websockets>=13",  # test_view.py: a Foxglove WebSocket client (the sync client's recv timeout)
            "protobuf>=4.21",  # test_view.py: decodes the view's messages with their advertised schemas
        ],
        # Fleets (boat_twin.fleet: --each batches and --ensemble runs on a Dask cluster; docs/fleet.md). Without it
        # they run in the calling process.
        "fleet": [
            "dask>=2024.1",
            "distributed>=2024.1",
        ],
        # The twin seen in Foxglove (boat_twin.view: --foxglove on follow and simulate, the nodes' foxglove
        # parameter; docs/live-twin.md). Without it those options are refused in one line.
        "view": [
            "foxglove-sdk>=0.30",
        ],
        # Benchmarks only (benchmarks/bench_zigzag_inverse.py: the neural-network inverse map of Pashentsev 2025).
        "bench": [
            "scikit-learn>=1.3",
        ],
    },
    zip_safe=True,
    maintainer="boat_twin developers",
    maintainer_email="boat-twin@example.org",
    description="Digital twin of a small unmanned planing boat (simulator, identification, towed cable).",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "boat-twin = boat_twin.cli:main",
            "simulator = boat_twin.nodes:simulator_main",
            "identifier = boat_twin.nodes:identifier_main",
            "cable = boat_twin.nodes:cable_main",
            "player = boat_twin.nodes:player_main",
            "shadow = boat_twin.nodes:shadow_main",
            "bag_player = boat_twin.nodes:bag_player_main",
        ],
    },
)
