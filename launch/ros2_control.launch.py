"""table_sim driven by ros2_control's stock topic hardware interface, with no plugin of ours.

    ros2 launch screwgear_ros ros2_control.launch.py
    ros2 topic pub -r 100 /effort_controller/commands std_msgs/msg/Float64MultiArray \
        "{data: [20.0]}"       # signed drive torque at the active pinion, N·m

Before it starts anything it checks every package it runs something from (its
processes and their executables, the URDF's hardware plugin, the controllers of
config/ros2_control.yaml, at the versions package.xml asks for) and fails with one
message naming all that are missing and how to install them.

Then it starts table_sim (config/paper.yaml by default) in ``namespace`` (default: the
namespace the shipped URDF's ``<ros2_control>`` block points at, /screwgear; another one
points the block there), so the node's joint_states never collides with
joint_state_broadcaster's /joint_states; robot_state_publisher with that URDF (it
publishes /robot_description, where the Jazzy controller manager takes the URDF from,
and /tf from /joint_states); ros2_control_node with config/ros2_control.yaml; spawners
for joint_state_broadcaster and effort_controller. ``params_file`` and ``record`` are
passed to table_sim.launch.py. A process that exits with an error ends the launch,
non-zero, with its last error line as the reason.
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch.actions import DeclareLaunchArgument, IncludeLaunchDescription, OpaqueFunction
from launch.launch_description_sources import PythonLaunchDescriptionSource
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from launch import LaunchDescription
from screwgear_ros.ros import launch_support as support

PACKAGE = 'screwgear_ros'
LAUNCH = 'ros2_control.launch.py'
CONTROLLERS = ('joint_state_broadcaster', 'effort_controller')
#: The (package, executable) of each process this file starts besides table_sim.
STATE_PUBLISHER = ('robot_state_publisher', 'robot_state_publisher')
CONTROL_NODE = ('controller_manager', 'ros2_control_node')
SPAWNER = ('controller_manager', 'spawner')


def _files(share):
    return {name: os.path.join(share, *name.split('/')) for name in (
        'urdf/screwgear_table.urdf', 'config/ros2_control.yaml', 'package.xml')}


def _check(context, share):
    files = _files(share)
    needs = support.ros2_control_needs(
        (STATE_PUBLISHER, CONTROL_NODE, SPAWNER),
        support.read(files['urdf/screwgear_table.urdf']),
        support.read(files['config/ros2_control.yaml']), support.read(files['package.xml']))
    support.require(LAUNCH, needs, share)
    support.normalized_namespace(LaunchConfiguration('namespace').perform(context))
    return []


def _controlled(context, share):
    files = _files(share)
    description = support.in_namespace(support.read(files['urdf/screwgear_table.urdf']),
                                       LaunchConfiguration('namespace').perform(context))
    nodes = [
        Node(package=STATE_PUBLISHER[0], executable=STATE_PUBLISHER[1],
             parameters=[{'robot_description': description}], output='screen'),
        Node(package=CONTROL_NODE[0], executable=CONTROL_NODE[1],
             parameters=[files['config/ros2_control.yaml']], output='screen'),
        *(Node(package=SPAWNER[0], executable=SPAWNER[1],
               arguments=[name, '--controller-manager', '/controller_manager'],
               output='screen')
          for name in CONTROLLERS),
    ]
    # one that exits with an error ends the launch (table_sim's watch is in its file)
    return [action for node in nodes for action in (*support.watched(node), node)]


def generate_launch_description():
    share = get_package_share_directory(PACKAGE)
    shipped = support.urdf_namespace(support.read(_files(share)['urdf/screwgear_table.urdf']))
    return LaunchDescription([
        DeclareLaunchArgument(
            'namespace', default_value=shipped,
            description='namespace of table_sim; the URDF\'s ros2_control block is pointed '
                        'at its topics there (not /: that is the broadcaster\'s)'),
        DeclareLaunchArgument(
            'params_file', default_value=os.path.join(share, 'config', 'paper.yaml'),
            description='ROS 2 parameter file of the table'),
        DeclareLaunchArgument(
            'record', default_value='',
            description='rosbag2 directory table_sim records to; empty: off'),
        # first: nothing below is visited (nothing starts) when a package is missing
        OpaqueFunction(function=_check, args=[share]),
        IncludeLaunchDescription(
            PythonLaunchDescriptionSource(os.path.join(share, 'launch', 'table_sim.launch.py')),
            launch_arguments={'namespace': LaunchConfiguration('namespace'),
                              'params_file': LaunchConfiguration('params_file'),
                              'record': LaunchConfiguration('record')}.items()),
        OpaqueFunction(function=_controlled, args=[share]),
    ])
