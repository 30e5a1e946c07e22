"""Start table_sim with a parameter file, a namespace and a recording path.

    ros2 launch screwgear_ros table_sim.launch.py
    ros2 launch screwgear_ros table_sim.launch.py namespace:=axis_c record:=/tmp/run1 \
        params_file:=/path/to/my_table.yaml

Launch arguments: ``params_file`` (default: the installed config/paper.yaml, the paper's
worked example), ``namespace`` (default: none; every topic of the node is relative but
/clock and /diagnostics), ``record`` (a rosbag2 directory to record the run to; empty:
no recording). Ctrl-C closes the recording properly.
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue

from launch import LaunchDescription

PACKAGE = 'screwgear_ros'


def generate_launch_description():
    share = get_package_share_directory(PACKAGE)
    return LaunchDescription([
        DeclareLaunchArgument(
            'params_file', default_value=os.path.join(share, 'config', 'paper.yaml'),
            description='ROS 2 parameter file of the table (keys under /**)'),
        DeclareLaunchArgument(
            'namespace', default_value='',
            description='namespace of the node and its relative topics'),
        DeclareLaunchArgument(
            'record', default_value='',
            description='rosbag2 directory to record the run to (must not exist); empty: off'),
        Node(
            package=PACKAGE, executable='table_sim', name='table_sim',
            namespace=LaunchConfiguration('namespace'),
            parameters=[LaunchConfiguration('params_file'),
                        {'record': ParameterValue(LaunchConfiguration('record'),
                                                  value_type=str)}],
            output='screen', emulate_tty=True),
    ])
