"""Launch the boat twin: the simulator, the thrust-speed identifier and the towed-cable service.

    ros2 launch boat_twin twin.launch.py [namespace:=boat1] [seed:=0] [noise:=true] [config_file:=/path/boat.yaml]
        [sim_time:=true real_time_factor:=10.0] [command_timeout_s:=1.0] [frame_prefix:=boat1/]
        [publish_truth_tf:=false] [hardware_id:=boat1] [order:=5] [memory_s:=3600.0] [model_path:=/path/model.yaml]
        [cable_case:=/path/case.yaml] [follow_gnss_vel:=true]
        [mavlink_url:=udpout:127.0.0.1:14550] [mavlink_allow_remote:=false]

An argument left empty is not passed: the node keeps its own default (its parameter's description says it), so
the defaults live in one place, the nodes. sim_time:=true: the simulator publishes /clock (running
real_time_factor times faster than the wall clock) and the identifier and the cable node run on it
(use_sim_time), as with Gazebo. The one default the launch sets itself: the cable follows the boat's speed.
"""

from launch import LaunchContext, LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

ARGUMENTS = {
    "namespace": ("", "namespace of every topic"),
    "config_file": ("", "twin configuration YAML: vessel, environment, gnss, um7 (empty: the built-in boat, "
                        "config/boat.yaml)"),
    "seed": ("", "seed of the sensor noise (empty: the simulator's, 0)"),
    "noise": ("", "false: exact measurements (empty: the simulator's, true)"),
    "sim_time": ("", "true: the simulator publishes /clock and the other nodes use it (empty: false)"),
    "real_time_factor": ("", "simulated seconds per wall second with sim_time (empty: the simulator's, 1.0)"),
    "command_timeout_s": ("", "thrust to zero this long after the last thruster command, s (empty: the "
                              "simulator's, 1.0)"),
    "frame_prefix": ("", "prepended to every frame id, e.g. boat1/ (empty: none)"),
    "publish_truth_tf": ("", "false: no true map -> base_link on tf, a localization stack owns it (empty: true)"),
    "hardware_id": ("", "hardware_id of the nodes' /diagnostics (empty: the namespace)"),
    "mavlink_url": ("", "serve the twin to a ground station over MAVLink (empty: off)"),
    "mavlink_allow_remote": ("", "true: allow a MAVLink peer that is not on this machine (empty: false)"),
    "order": ("", "order N of the identified resistance Fc(v), needs N + 2 steady points (empty: the "
                  "identifier's)"),
    "memory_s": ("", "forgetting time constant of the identifier, s (empty: the identifier's, 3600)"),
    "model_path": ("", "where ~/save writes the model (empty: $ROS_HOME/boat_twin/identified_model.yaml)"),
    "cable_case": ("", "towed-cable case YAML for the cable service (empty: config/cable/default.yaml)"),
    "follow_gnss_vel": ("true", "the cable's tow speed follows the boat's gnss/vel"),
}
"""Launch argument → (default, description); empty: the node's own default."""

PARAMETERS = {
    "simulator": {"config_file": "config_file", "seed": "seed", "noise": "noise", "publish_clock": "sim_time",
                  "real_time_factor": "real_time_factor", "mavlink_url": "mavlink_url",
                  "mavlink_allow_remote": "mavlink_allow_remote", "command_timeout_s": "command_timeout_s",
                  "frame_prefix": "frame_prefix", "publish_truth_tf": "publish_truth_tf", "hardware_id": "hardware_id"},
    "identifier": {"use_sim_time": "sim_time", "order": "order", "memory_s": "memory_s", "model_path": "model_path",
                   "hardware_id": "hardware_id"},
    "cable": {"use_sim_time": "sim_time", "case_file": "cable_case", "follow_gnss_vel": "follow_gnss_vel",
              "frame_prefix": "frame_prefix", "hardware_id": "hardware_id"},
}
"""Node (executable) → its parameter → the launch argument that sets it."""


def nodes(context: LaunchContext) -> list[Node]:
    """The nodes, each given the parameters whose launch argument is not empty."""
    given = {name for name in ARGUMENTS if LaunchConfiguration(name).perform(context) != ""}
    return [Node(package="boat_twin", executable=executable, name=executable, output="screen",
                 namespace=LaunchConfiguration("namespace"),
                 parameters=[{key: LaunchConfiguration(name) for key, name in table.items() if name in given}])
            for executable, table in PARAMETERS.items()]


def generate_launch_description() -> LaunchDescription:
    """Nodes of the twin in one namespace."""
    declared = [DeclareLaunchArgument(name, default_value=default, description=text)
                for name, (default, text) in ARGUMENTS.items()]
    return LaunchDescription([*declared, OpaqueFunction(function=nodes)])
