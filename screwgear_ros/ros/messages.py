"""The node's topics and message types (declared once here), and the messages that are
not serialized once per tick by :mod:`screwgear_ros.ros.cdr`: inputs as recorded, the
active path, the URDF, diagnostics. Fresh objects: a recorder serializes them later on
its own thread, so a message handed over must never change afterwards.
"""

from __future__ import annotations

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Empty, Float64, Float64MultiArray, Int8, String
from visualization_msgs.msg import MarkerArray

from ..commands import JointCommand

MESH_NAMES = ['mesh_1', 'mesh_3']

#: The message class of each input topic of :data:`screwgear_ros.commands.INPUT_TOPICS`.
INPUT_TYPES = {'cmd_torque': Float64, 'cmd_direction': Int8, 'cmd_effort': Float64MultiArray,
               'load_torque': Float64, 'joint_commands': JointState}
#: The node's outputs: key → (topic, relative unless absolute, message class).
OUTPUT_TYPES = {
    'joint_states': ('joint_states', JointState),
    'mesh_state': ('mesh_state', JointState),
    'transmission_error': ('transmission_error', Float64),
    'active_path': ('active_path', Int8),
    'clock': ('/clock', Clock),
    'diagnostics': ('/diagnostics', DiagnosticArray),
    'robot_description': ('robot_description', String),
    'table_markers': ('table_markers', MarkerArray),
}
#: Outputs published (and recorded) transient local: a late subscriber gets the last one
#: (a viewer opened while the table stands, in lockstep or halted, still sees it).
LATCHED_OUTPUTS = frozenset({'active_path', 'robot_description', 'table_markers'})
#: What the recording holds besides outputs and inputs, under the node's private namespace.
PRIVATE_TYPES = {'run_parameters': String, 'reset': Empty}


def type_name(cls: type) -> str:
    """'sensor_msgs/msg/JointState' for sensor_msgs.msg.JointState."""
    return f'{cls.__module__.split(".")[0]}/msg/{cls.__name__}'


def input_message(topic: str, value: object, time_ns: int = 0) -> object:
    """The message of a command on input ``topic`` whose value
    (:func:`screwgear_ros.commands.command_value`) is ``value``; a JointState is
    stamped ``time_ns``."""
    if topic == 'joint_commands':
        if not isinstance(value, JointCommand):
            raise TypeError(f'joint_commands: not a JointCommand: {value!r}')
        msg = JointState(name=list(value.name), position=list(value.position),
                         velocity=list(value.velocity), effort=list(value.effort))
        msg.header.stamp = stamp(time_ns)
        return msg
    data = [float(v) for v in value] if topic == 'cmd_effort' else value
    return INPUT_TYPES[topic](data=data)


def stamp(time_ns: int) -> Time:
    """builtin_interfaces/Time of a simulation time in integer nanoseconds."""
    sec, nanosec = divmod(time_ns, 1_000_000_000)
    return Time(sec=sec, nanosec=nanosec)


def active_path(path: int) -> Int8:
    return Int8(data=path)


def robot_description(urdf: str) -> String:
    return String(data=urdf)


def diagnostics(name: str, hardware_id: str, level: int, message: str,
                values: list[tuple[str, str]], time_ns: int) -> DiagnosticArray:
    """A DiagnosticArray with the node's one status."""
    status = DiagnosticStatus(level=bytes([level]), name=name, message=message,
                              hardware_id=hardware_id,
                              values=[KeyValue(key=k, value=v) for k, v in values])
    msg = DiagnosticArray(status=[status])
    msg.header.stamp = stamp(time_ns)
    return msg


__all__ = ['MESH_NAMES', 'INPUT_TYPES', 'OUTPUT_TYPES', 'LATCHED_OUTPUTS',
           'PRIVATE_TYPES',
           'type_name', 'input_message', 'stamp', 'active_path', 'robot_description',
           'diagnostics']
