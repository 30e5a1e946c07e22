"""Start table_sim with a parameter file, a namespace and a recording path.

    ros2 launch screwgear_ros table_sim.launch.py
    ros2 launch screwgear_ros table_sim.launch.py namespace:=axis_c record:=/tmp/run1 \
        params_file:=/path/to/my_table.yaml

Launch arguments: ``params_file`` (default: the installed config/paper.yaml, the paper's
worked example), ``namespace`` (default: none; every topic of the node is relative but
/clock and /diagnostics), ``record`` (a rosbag2 directory to record the run to; empty:
no recording). Ctrl-C closes the recording properly.

A ``params_file`` that is not there ends the launch before anything starts, and table_sim
exiting with an error (a ``record`` directory that is not empty, a parameter it refuses)
ends it with table_sim's last error line as the reason: ``ros2 launch`` returns non-zero
either way.
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue

from launch import LaunchDescription
from screwgear_ros.ros import launch_support as support

PACKAGE = 'screwgear_ros'


def _params_file(context):
    support.require_params_file(LaunchConfiguration('params_file').perform(context))
    return []


def generate_launch_description():
    share = get_package_share_directory(PACKAGE)
    node = Node(
        package=PACKAGE, executable='table_sim', name='table_sim',
        namespace=LaunchConfiguration('namespace'),
        parameters=[LaunchConfiguration('params_file'),
                    {'record': ParameterValue(LaunchConfiguration('record'),
                                              value_type=str)}],
        output='screen', emulate_tty=True)
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
        # before the node: launch_ros only warns about a missing file and starts it
        OpaqueFunction(function=_params_file),
        *support.watched(node),
        node,
    ])
