"""The table as a URDF, with a ``<ros2_control>`` block for ros2_control's stock topic
hardware interface. Plain text; imports no rclpy.

:func:`robot_description` writes it from the parameters (geometry, inertias, limits:
:mod:`screwgear_ros.view.layout`) and the two topics of the node the hardware interface
talks to. The node publishes it for itself on ``robot_description``; the shipped
``urdf/screwgear_table.urdf`` is :func:`shipped_description` (the defaults, the node in
namespace :data:`PLANT_NAMESPACE`), regenerated with::

    python -m screwgear_ros.view.urdf > urdf/screwgear_table.urdf

Joints are ``continuous`` (URDF's revolute joint without position limits: a rotary
table turns for ever). Only ``joint_names[COMMANDED_JOINT]`` (pinion 1) has a command
interface, ``effort``, whose value the node reads as the signed drive torque at the
active pinion (:mod:`screwgear_ros.sim.commands`); every joint has position, velocity and
effort state interfaces, the three arrays joint_states always fills.
"""

from __future__ import annotations

import sys
import xml.etree.ElementTree as ET

from ..interface import Input, topic_names
from ..params.table import SimSettings, TableParams
from ..sim.commands import COMMAND_INTERFACE, COMMANDED_JOINT, load_limit
from .layout import BASE_LINK, FACE_WIDTH, MARK_FROM, MARK_TO, PALETTE, Wheel, wheels

ROBOT_NAME = 'screwgear_table'
#: ros2_control's stock JointState topic system (package joint_state_topic_hardware_interface;
#: its older name topic_based_ros2_control/TopicBasedSystem loads as an alias).
PLUGIN = 'joint_state_topic_hardware_interface/JointStateTopicSystem'
#: Namespace of table_sim that the shipped URDF's ros2_control block points at, so the
#: node's joint_states does not collide with joint_state_broadcaster's /joint_states.
PLANT_NAMESPACE = '/screwgear'
#: The plugin publishes a command only when its state and command differ by more than
#: this; -1 publishes every controller-manager cycle (an effort state never equals its
#: command here: joint_states' effort includes the preload).
TRIGGER_THRESHOLD = -1
STATE_INTERFACES = ('position', 'velocity', 'effort')


def _num(value: float) -> str:
    return f'{value:.9g}'


def _xyz(*values: float) -> str:
    return ' '.join(_num(v) for v in values)


def _sub(parent: ET.Element, tag: str, **attrib: str) -> ET.Element:
    return ET.SubElement(parent, tag, attrib)


def _link(robot: ET.Element, wheel: Wheel, material: str) -> None:
    link = _sub(robot, 'link', name=wheel.link)
    visual = _sub(link, 'visual', name='disc')
    _sub(_sub(visual, 'geometry'), 'cylinder', radius=_num(wheel.radius),
         length=_num(FACE_WIDTH))
    _sub(visual, 'material', name=material)
    mark = _sub(link, 'visual', name='mark')
    length = (MARK_TO - MARK_FROM) * wheel.radius
    _sub(mark, 'origin', xyz=_xyz((MARK_FROM + MARK_TO) / 2 * wheel.radius, 0.0,
                                  FACE_WIDTH / 2), rpy='0 0 0')
    _sub(_sub(mark, 'geometry'), 'box', size=_xyz(length, 0.15 * length, 0.004))
    _sub(mark, 'material', name='mark')
    inertial = _sub(link, 'inertial')
    _sub(inertial, 'origin', xyz='0 0 0', rpy='0 0 0')
    _sub(inertial, 'mass', value=_num(wheel.mass))
    across = wheel.mass * (3.0 * wheel.radius ** 2 + FACE_WIDTH ** 2) / 12.0
    _sub(inertial, 'inertia', ixx=_num(across), ixy='0', ixz='0', iyy=_num(across), iyz='0',
         izz=_num(wheel.inertia))


def _joint(robot: ET.Element, wheel: Wheel, effort_limit: float, dt: float) -> None:
    joint = _sub(robot, 'joint', name=wheel.joint, type='continuous')
    _sub(joint, 'parent', link=BASE_LINK)
    _sub(joint, 'child', link=wheel.link)
    _sub(joint, 'origin', xyz=_xyz(*wheel.centre, 0.0), rpy='0 0 0')
    _sub(joint, 'axis', xyz=_xyz(0.0, 0.0, wheel.turn))
    _sub(joint, 'limit', effort=_num(effort_limit), velocity=_num(wheel.speed_limit(dt)))


def _ros2_control(robot: ET.Element, gears: tuple[Wheel, ...], max_torque: float,
                  commands_topic: str, states_topic: str) -> None:
    block = _sub(robot, 'ros2_control', name=ROBOT_NAME, type='system')
    hardware = _sub(block, 'hardware')
    ET.SubElement(hardware, 'plugin').text = PLUGIN
    for name, value in (('joint_commands_topic', commands_topic),
                        ('joint_states_topic', states_topic),
                        ('trigger_joint_command_threshold', str(TRIGGER_THRESHOLD))):
        _sub(hardware, 'param', name=name).text = value
    for wheel in gears:
        joint = _sub(block, 'joint', name=wheel.joint)
        if wheel.index == COMMANDED_JOINT:
            command = _sub(joint, 'command_interface', name=COMMAND_INTERFACE)
            _sub(command, 'param', name='min').text = _num(-max_torque)
            _sub(command, 'param', name='max').text = _num(max_torque)
        for interface in STATE_INTERFACES:
            _sub(joint, 'state_interface', name=interface)


def robot_description(params: TableParams, settings: SimSettings, commands_topic: str,
                      states_topic: str) -> str:
    """The URDF of a table with ``params``; its ros2_control block talks to a node whose
    joint_commands and joint_states topics are these (fully resolved) names."""
    gears = wheels(params, settings.joint_names)
    robot = ET.Element('robot', name=ROBOT_NAME)
    # The module's first path: every recorded robot_description carries this text.
    robot.append(ET.Comment(' written by screwgear_ros.ros.urdf: geometry, inertias and '
                            'limits from the table parameters '))
    for name, rgba in PALETTE.items():
        if name in ('table', 'pinion', 'mark'):
            _sub(_sub(robot, 'material', name=name), 'color', rgba=_xyz(*rgba))
    _sub(robot, 'link', name=BASE_LINK)
    table_load = load_limit(params.max_torque, params.radius_pinion_1, params.radius_table)
    for wheel in gears:
        _link(robot, wheel, 'table' if wheel.is_table else 'pinion')
        _joint(robot, wheel, table_load if wheel.is_table else params.max_torque, settings.dt)
    _ros2_control(robot, gears, params.max_torque, commands_topic, states_topic)
    ET.indent(robot, space='  ')
    return '<?xml version="1.0"?>\n' + ET.tostring(robot, encoding='unicode') + '\n'


def shipped_description() -> str:
    """``urdf/screwgear_table.urdf``: the defaults, table_sim in PLANT_NAMESPACE."""
    names = topic_names(PLANT_NAMESPACE)
    return robot_description(TableParams(), SimSettings(), names[Input.JOINT_COMMANDS],
                             names['joint_states'])


def main() -> None:
    sys.stdout.write(shipped_description())


if __name__ == '__main__':
    main()


__all__ = [
    'PLANT_NAMESPACE',
    'PLUGIN',
    'ROBOT_NAME',
    'STATE_INTERFACES',
    'TRIGGER_THRESHOLD',
    'robot_description',
    'shipped_description',
]
