"""boat_twin: digital twin of a small unmanned planing boat (library core; runs without ROS)."""

__version__ = "0.1.0"
