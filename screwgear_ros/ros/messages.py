"""The message classes of the node's topics (declared in :mod:`screwgear_ros.interface`),
and the messages that are not serialized once per tick by :mod:`screwgear_ros.bag.cdr`:
inputs as recorded, the active path, the URDF, diagnostics. Fresh objects: a recorder serializes them later on
its own thread, so a message handed over must never change afterwards.
"""

from __future__ import annotations

import importlib
from typing import Any

from builtin_interfaces.msg import Time
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64, Int8, String

from ..bag import messages as cdr_messages
from ..bag.cdr import Shape
from ..bag.tick_encoder import MESH_NAMES
from ..interface import (
    BY_KEY,
    COMMAND_TOPICS,
    INFO_TOPICS,
    OUTPUT_TOPICS,
    Input,
)
from ..sim.commands import JointCommand


def message_class(name: str) -> type:
    """The rclpy message class of a type name: sensor_msgs.msg.JointState for
    'sensor_msgs/msg/JointState'."""
    package, kind, cls = name.split('/')
    return getattr(importlib.import_module(f'{package}.{kind}'), cls)


#: The message class of each input topic of :data:`screwgear_ros.sim.commands.INPUT_TOPICS`.
INPUT_TYPES = {key: message_class(name) for key, name in COMMAND_TOPICS.items()}
#: The inputs the node only records (the setpoint): key → message class.
INFO_TYPES = {key: message_class(name) for key, name in INFO_TOPICS.items()}
#: The node's outputs: key → (topic, relative unless absolute, message class).
OUTPUT_TYPES = {key: (BY_KEY[key].name, message_class(name))
                for key, name in OUTPUT_TOPICS.items()}


def to_message(shape: Shape) -> Any:
    """The rclpy message a :class:`~screwgear_ros.bag.cdr.Shape` spells out (every field
    named by the shape; the message class refuses a field it does not have)."""
    def value(item: Any) -> Any:
        if isinstance(item, Shape):
            return to_message(item)
        if isinstance(item, list):
            return [value(v) for v in item]
        return item
    return message_class(shape.msgtype)(**{name: value(v)
                                          for name, (_, v) in shape.fields.items()})


def input_message(topic: str, value: Any, time_ns: int = 0) -> object:
    """The message of a command on input ``topic`` whose value
    (:func:`screwgear_ros.sim.commands.command_value`) is ``value``; a JointState is
    stamped ``time_ns``."""
    if topic == Input.JOINT_COMMANDS:
        if not isinstance(value, JointCommand):
            raise TypeError(f'joint_commands: not a JointCommand: {value!r}')
        msg = JointState(name=list(value.name), position=list(value.position),
                         velocity=list(value.velocity), effort=list(value.effort))
        msg.header.stamp = stamp(time_ns)
        return msg
    data = [float(v) for v in value] if topic == Input.CMD_EFFORT else value
    return INPUT_TYPES[topic](data=data)


def stamp(time_ns: int) -> Time:
    """builtin_interfaces/Time of a simulation time in integer nanoseconds."""
    sec, nanosec = divmod(time_ns, 1_000_000_000)
    return Time(sec=sec, nanosec=nanosec)


def setpoint(value: float) -> Float64:
    return Float64(data=float(value))


def active_path(path: int) -> Int8:
    return Int8(data=path)


def robot_description(urdf: str) -> String:
    return String(data=urdf)


def diagnostics(name: str, hardware_id: str, level: int, message: str,
                values: list[tuple[str, str]], time_ns: int) -> bytes:
    """A DiagnosticArray with the node's one status, as CDR bytes: published as they are
    and recorded by :class:`~screwgear_ros.runs.run_io.RunIO`, which records bytes only."""
    return cdr_messages.diagnostics(name, hardware_id, level, message, values, time_ns)


__all__ = [
    'INFO_TYPES',
    'INPUT_TYPES',
    'MESH_NAMES',
    'OUTPUT_TYPES',
    'active_path',
    'diagnostics',
    'input_message',
    'message_class',
    'robot_description',
    'setpoint',
    'stamp',
    'to_message',
]
