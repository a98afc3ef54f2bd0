"""Launch the xface_predictor node with the shipped parameters (a sourced ROS 2 Jazzy workspace).

    ros2 launch xface xface.launch.py                          # /xface_predictor
    ros2 launch xface xface.launch.py namespace:=left name:=dock_left lifecycle:=true

``params_file`` defaults to the installed config/xface.yaml, whose ``/**`` key applies under any
namespace and name. The executable is the ``xface-predictor`` console script (on PATH in the
sourced workspace). launch and launch_ros are not on PyPI: outside a ROS installation this
file is only syntax-checked (tests/ros/test_packaging.py).
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, ExecuteProcess
from launch.conditions import IfCondition, UnlessCondition
from launch.substitutions import LaunchConfiguration


def generate_launch_description() -> LaunchDescription:
    default_params = os.path.join(get_package_share_directory("xface"), "config", "xface.yaml")
    namespace = LaunchConfiguration("namespace")
    name = LaunchConfiguration("name")
    params_file = LaunchConfiguration("params_file")
    ros_args = [
        "--ros-args", "-r", ["__ns:=/", namespace], "-r", ["__node:=", name],
        "--params-file", params_file,
    ]  # fmt: skip
    return LaunchDescription(
        [
            DeclareLaunchArgument("namespace", default_value="", description="node namespace"),
            DeclareLaunchArgument("name", default_value="xface_predictor", description="node name"),
            DeclareLaunchArgument("params_file", default_value=default_params),
            DeclareLaunchArgument(
                "lifecycle", default_value="false", description="start as a managed node"
            ),
            ExecuteProcess(
                cmd=["xface-predictor", *ros_args],
                output="screen",
                condition=UnlessCondition(LaunchConfiguration("lifecycle")),
            ),
            ExecuteProcess(
                cmd=["xface-predictor", "--lifecycle", *ros_args],
                output="screen",
                condition=IfCondition(LaunchConfiguration("lifecycle")),
            ),
        ]
    )
