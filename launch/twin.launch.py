"""Launch the boat twin: the simulator, the thrust-speed identifier and the towed-cable service.

    ros2 launch boat_twin twin.launch.py [namespace:=boat1] [seed:=0] [noise:=true] [config_file:=/path/boat.yaml]
        [sim_time:=true real_time_factor:=10.0] [command_timeout_s:=1.0] [frame_prefix:=boat1/]
        [publish_truth_tf:=true] [hardware_id:=boat1] [order:=5] [memory_s:=3600.0] [model_path:=/path/model.yaml]
        [cable_case:=/path/case.yaml] [follow_gnss_vel:=true]
        [mavlink_url:=udpout:127.0.0.1:14550] [mavlink_allow_remote:=false]

sim_time:=true: the simulator publishes /clock (running real_time_factor times faster than the wall clock) and
the identifier and the cable node run on it (use_sim_time), as with Gazebo.
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

ARGUMENTS = {
    "namespace": ("", "namespace of every topic"),
    "seed": ("0", "seed of the sensor noise"),
    "noise": ("true", "false: exact measurements"),
    "sim_time": ("false", "true: the simulator publishes /clock and the other nodes use it"),
    "real_time_factor": ("1.0", "simulated seconds per wall second with sim_time"),
    "command_timeout_s": ("1.0", "thrust goes to zero this long after the last thruster command, s"),
    "frame_prefix": ("", "prepended to every frame id (several boats: boat1/)"),
    "publish_truth_tf": ("true", "publish the true map -> base_link on tf (false: a localization stack owns it)"),
    "hardware_id": ("", "hardware_id of the nodes' /diagnostics (empty: the namespace)"),
    "mavlink_url": ("", "serve the twin to a ground station over MAVLink (empty: off)"),
    "mavlink_allow_remote": ("false", "allow a MAVLink peer that is not on this machine"),
    "order": ("5", "order N of the identified resistance Fc(v) (needs N + 2 steady points)"),
    "memory_s": ("3600.0", "forgetting time constant of the identifier, s"),
    "model_path": ("", "where ~/save writes the model (empty: $ROS_HOME/boat_twin/identified_model.yaml)"),
    "follow_gnss_vel": ("true", "the cable's tow speed follows the boat's gnss/vel"),
}


def generate_launch_description() -> LaunchDescription:
    """Nodes of the twin in one namespace, the twin configuration from config/boat.yaml by default."""
    share = get_package_share_directory("boat_twin")
    arg = LaunchConfiguration
    common = {"namespace": arg("namespace"), "output": "screen"}
    declared = [DeclareLaunchArgument(name, default_value=default, description=text)
                for name, (default, text) in ARGUMENTS.items()]
    declared += [
        DeclareLaunchArgument("config_file", default_value=os.path.join(share, "config", "boat.yaml"),
                              description="twin configuration YAML (vessel, environment, gnss, um7)"),
        DeclareLaunchArgument("cable_case", default_value=os.path.join(share, "config", "cable", "default.yaml"),
                              description="towed-cable case YAML for the cable service"),
    ]
    return LaunchDescription([
        *declared,
        Node(package="boat_twin", executable="simulator", name="simulator", **common,
             parameters=[{"config_file": arg("config_file"), "seed": arg("seed"), "noise": arg("noise"),
                          "publish_clock": arg("sim_time"), "real_time_factor": arg("real_time_factor"),
                          "command_timeout_s": arg("command_timeout_s"), "frame_prefix": arg("frame_prefix"),
                          "publish_truth_tf": arg("publish_truth_tf"), "hardware_id": arg("hardware_id"),
                          "mavlink_url": arg("mavlink_url"), "mavlink_allow_remote": arg("mavlink_allow_remote")}]),
        Node(package="boat_twin", executable="identifier", name="identifier", **common,
             parameters=[{"use_sim_time": arg("sim_time"), "order": arg("order"), "memory_s": arg("memory_s"),
                          "model_path": arg("model_path"), "hardware_id": arg("hardware_id")}]),
        Node(package="boat_twin", executable="cable", name="cable", **common,
             parameters=[{"use_sim_time": arg("sim_time"), "case_file": arg("cable_case"),
                          "follow_gnss_vel": arg("follow_gnss_vel"), "frame_prefix": arg("frame_prefix"),
                          "hardware_id": arg("hardware_id")}]),
    ])
