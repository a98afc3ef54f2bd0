"""Launch the xface_predictor node with the shipped parameters (a sourced ROS 2 Jazzy workspace).

    ros2 launch xface xface.launch.py                          # /xface_predictor
    ros2 launch xface xface.launch.py namespace:=left name:=dock_left lifecycle:=true

``params_file`` defaults to the installed config/xface.yaml, whose ``/**`` key applies under any
namespace and name. With ``lifecycle:=true`` the node starts unconfigured and waits for a
lifecycle manager (``<node>/change_state``). launch and launch_ros are not on PyPI: outside a
ROS installation this file is only compiled (tests/ros/test_packaging.py).
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition, UnlessCondition
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node


def predictor(*, lifecycle: bool) -> Node:
    """The node, plain or managed (``--lifecycle`` is the node's own option, not a ROS one)."""
    flag = LaunchConfiguration("lifecycle")
    return Node(
        package="xface",
        executable="xface-predictor",
        name=LaunchConfiguration("name"),
        namespace=LaunchConfiguration("namespace"),
        parameters=[LaunchConfiguration("params_file")],
        arguments=["--lifecycle"] if lifecycle else [],
        output="screen",
        condition=IfCondition(flag) if lifecycle else UnlessCondition(flag),
    )


def generate_launch_description() -> LaunchDescription:
    default_params = os.path.join(get_package_share_directory("xface"), "config", "xface.yaml")
    return LaunchDescription(
        [
            DeclareLaunchArgument("namespace", default_value="", description="node namespace"),
            DeclareLaunchArgument("name", default_value="xface_predictor", description="node name"),
            DeclareLaunchArgument("params_file", default_value=default_params),
            DeclareLaunchArgument(
                "lifecycle", default_value="false", description="start as a managed node"
            ),
            predictor(lifecycle=False),
            predictor(lifecycle=True),
        ]
    )
