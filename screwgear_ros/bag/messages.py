"""The CDR bytes of the messages a run records besides its per-tick outputs, with no ROS
message package: the inputs as recorded, the setpoint, a reset, the run's parameters,
the active path, the URDF and the node's diagnostics.

Each message is spelt out as a :class:`~screwgear_ros.bag.cdr.Shape` (its fields in the
order of the message definition) and written by :func:`encode`, the serializer of the
per-tick templates; tests decode every encoding with rclpy's own deserializer and
compare it with rclpy's serialization of the same message.

Messages of a fixed size below a multiple of four bytes (an Int8, an Empty) are padded
with zeros to one, as rclpy (rmw_fastrtps) hands them over: the bytes past the CDR
are read by no decoder, and a recording keeps the length it always had.

Examples
--------
>>> from screwgear_ros.bag.messages import float64, string
>>> float64(1.5).hex()
'00010000000000000000f83f'
>>> string('ab')
b'\\x00\\x01\\x00\\x00\\x03\\x00\\x00\\x00ab\\x00'
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from ..interface import Input
from ..sim.commands import JointCommand
from .cdr import Shape, template_of


def encode(msg: Shape) -> bytes:
    """The CDR bytes of ``msg``."""
    return template_of(msg).bytes


def _fixed(msg: Shape) -> bytes:
    """A message of fixed size, padded with zeros to a multiple of four bytes."""
    data = encode(msg)
    return data + bytes(-len(data) % 4)


def time(time_ns: int = 0) -> Shape:
    """builtin_interfaces/Time of a simulation time in integer nanoseconds."""
    sec, nanosec = divmod(int(time_ns), 1_000_000_000)
    return Shape('builtin_interfaces/msg/Time', {'sec': ('int32', sec),
                                                 'nanosec': ('uint32', nanosec)})


def header(frame_id: str = '', time_ns: int = 0) -> Shape:
    """std_msgs/Header."""
    return Shape('std_msgs/msg/Header', {'stamp': ('builtin_interfaces/Time', time(time_ns)),
                                         'frame_id': ('string', frame_id)})


def float64(value: float) -> bytes:
    """std_msgs/Float64 (the setpoint, cmd_torque, load_torque)."""
    return encode(Shape('std_msgs/msg/Float64', {'data': ('double', float(value))}))


def int8(value: int) -> bytes:
    """std_msgs/Int8 (the active path, cmd_direction)."""
    return _fixed(Shape('std_msgs/msg/Int8', {'data': ('int8', int(value))}))


def string(text: str) -> bytes:
    """std_msgs/String (the run's parameters, the URDF)."""
    return encode(Shape('std_msgs/msg/String', {'data': ('string', text)}))


def empty() -> bytes:
    """std_msgs/Empty (a reset): rosidl writes one placeholder byte for a message with
    no fields."""
    return _fixed(Shape('std_msgs/msg/Empty',
                        {'structure_needs_at_least_one_member': ('uint8', 0)}))


def float64_multi_array(values: Sequence[float]) -> bytes:
    """std_msgs/Float64MultiArray with the default layout (no dimensions)."""
    layout = Shape('std_msgs/msg/MultiArrayLayout', {
        'dim': ('sequence<std_msgs/MultiArrayDimension>', []), 'data_offset': ('uint32', 0)})
    return encode(Shape('std_msgs/msg/Float64MultiArray', {
        'layout': ('std_msgs/MultiArrayLayout', layout),
        'data': ('sequence<double>', [float(v) for v in values])}))


def joint_state(command: JointCommand, time_ns: int = 0) -> bytes:
    """sensor_msgs/JointState of a joint command, stamped ``time_ns`` (frame_id '')."""
    return encode(Shape('sensor_msgs/msg/JointState', {
        'header': ('std_msgs/Header', header('', time_ns)),
        'name': ('sequence<string>', list(command.name)),
        **{key: ('sequence<double>', [float(v) for v in getattr(command, key)])
           for key in ('position', 'velocity', 'effort')}}))


def diagnostics(name: str, hardware_id: str, level: int, message: str,
                values: Sequence[tuple[str, str]], time_ns: int) -> bytes:
    """diagnostic_msgs/DiagnosticArray with one status, stamped ``time_ns``."""
    status = Shape('diagnostic_msgs/msg/DiagnosticStatus', {
        'level': ('octet', bytes([level])), 'name': ('string', name),
        'message': ('string', message), 'hardware_id': ('string', hardware_id),
        'values': ('sequence<diagnostic_msgs/KeyValue>', [
            Shape('diagnostic_msgs/msg/KeyValue', {'key': ('string', k), 'value': ('string', v)})
            for k, v in values])})
    return encode(Shape('diagnostic_msgs/msg/DiagnosticArray', {
        'header': ('std_msgs/Header', header('', time_ns)),
        'status': ('sequence<diagnostic_msgs/DiagnosticStatus>', [status])}))


def input_message(topic: str, value: Any, time_ns: int = 0) -> bytes:
    """The CDR bytes of a command on input ``topic`` whose value
    (:func:`screwgear_ros.sim.commands.command_value`) is ``value``; a JointState is
    stamped ``time_ns``.

    Raises
    ------
    TypeError
        If a joint_commands value is not a :class:`~screwgear_ros.sim.commands.JointCommand`.
    KeyError
        If ``topic`` is not an input.
    """
    if topic == Input.JOINT_COMMANDS:
        if not isinstance(value, JointCommand):
            raise TypeError(f'joint_commands: not a JointCommand: {value!r}')
        return joint_state(value, time_ns)
    if topic == Input.CMD_EFFORT:
        return float64_multi_array(value)
    if topic == Input.CMD_DIRECTION:
        return int8(value)
    if topic in (Input.CMD_TORQUE, Input.LOAD_TORQUE, Input.SETPOINT):
        return float64(value)
    raise KeyError(f'{topic!r} is not an input topic')


__all__ = [
    'diagnostics',
    'empty',
    'encode',
    'float64',
    'float64_multi_array',
    'header',
    'input_message',
    'int8',
    'joint_state',
    'string',
    'time',
]
