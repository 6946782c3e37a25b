"""Launch pcrp_node with config/pcrp.yaml. Scaling out: start more nodes, each with its own
share of input_topics and a distinct name; they share the read-only model file."""
import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node


def generate_launch_description():
    params = os.path.join(get_package_share_directory("pcrp"), "config", "pcrp.yaml")
    return LaunchDescription([
        DeclareLaunchArgument("params_file", default_value=params),
        Node(package="pcrp", executable="pcrp_node", name="pcrp_node", output="screen",
             parameters=[LaunchConfiguration("params_file")]),
    ])
