"""Launch the boat twin: the simulator, the thrust-speed identifier and the towed-cable service.

    ros2 launch boat_twin twin.launch.py [namespace:=boat1] [seed:=0] [noise:=true] [config_file:=/path/boat.yaml]
                                         [mavlink_url:=udpout:127.0.0.1:14550]
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node


def generate_launch_description() -> LaunchDescription:
    """Nodes of the twin in one namespace, the twin configuration from config/boat.yaml by default."""
    share = get_package_share_directory("boat_twin")
    namespace = LaunchConfiguration("namespace")
    common = {"namespace": namespace, "output": "screen"}
    return LaunchDescription([
        DeclareLaunchArgument("namespace", default_value="", description="namespace of every topic"),
        DeclareLaunchArgument("seed", default_value="0", description="seed of the sensor noise"),
        DeclareLaunchArgument("noise", default_value="true", description="false: exact measurements"),
        DeclareLaunchArgument("config_file", default_value=os.path.join(share, "config", "boat.yaml"),
                              description="twin configuration YAML (vessel, environment, gnss, um7)"),
        DeclareLaunchArgument("mavlink_url", default_value="",
                              description="serve the twin to a ground station over MAVLink (empty: off)"),
        DeclareLaunchArgument("cable_case", default_value=os.path.join(share, "config", "cable", "default.yaml"),
                              description="towed-cable case YAML for the cable service"),
        Node(package="boat_twin", executable="simulator", name="simulator", **common,
             parameters=[{"config_file": LaunchConfiguration("config_file"),
                          "seed": LaunchConfiguration("seed"), "noise": LaunchConfiguration("noise"),
                          "mavlink_url": LaunchConfiguration("mavlink_url")}]),
        Node(package="boat_twin", executable="identifier", name="identifier", **common),
        Node(package="boat_twin", executable="cable", name="cable", **common,
             parameters=[{"case_file": LaunchConfiguration("cable_case")}]),
    ])
