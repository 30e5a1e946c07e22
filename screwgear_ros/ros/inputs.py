"""What arrives on the node's input topics, before it becomes a command.

The node subscribes to its inputs raw (serialized CDR) and looks at a message's size
before anything else: a command carries one value, and a ``joint_commands`` message one
name and at most one value per joint, so a message of more than ``MAX_INPUT_BYTES`` is
no command. It is refused unread: decoding it, validating it and writing the value into
a warning cost the executor and the pacing thread time in proportion to its size, which
a flood of them took from the simulation. What the node logs about a rejected value is
at most an :func:`excerpt` of it.

A closed loop sends one ``cmd_effort`` a tick, and in lockstep the tick waits for it:
:func:`value` reads its doubles straight from the CDR when the message has the layout
rclpy sends (little endian, no layout dimensions), instead of building a message object
to read them from; any other message is decoded by rclpy.
"""

from __future__ import annotations

import struct
from typing import Any

from rclpy.serialization import deserialize_message

from ..interface import Input
from ..sim.commands import command_value
from .messages import INPUT_TYPES

#: Largest serialized input message decoded, bytes: room for hundreds of joints.
MAX_INPUT_BYTES = 16 * 1024
#: Longest line about a rejected input, characters.
MAX_LINE = 400


def oversized(topic: str, data: bytes) -> str | None:
    """Why the serialized message ``data`` on input ``topic`` is refused unread, or None."""
    if len(data) <= MAX_INPUT_BYTES:
        return None
    return (f'{topic}: refused a message of {len(data)} bytes unread (a command has at most '
            f'{MAX_INPUT_BYTES}); the last valid command stays in force')


def decode(topic: str, data: bytes) -> Any:
    """The message of input ``topic`` in ``data`` (serialized CDR)."""
    return deserialize_message(data, INPUT_TYPES[topic])


#: std_msgs/Float64MultiArray in plain little-endian CDR: the encapsulation header, then
#: (from byte 4) the count of layout dimensions, data_offset and the count of doubles,
#: and the doubles from byte 20 (8-aligned counted from the end of the header).
_CDR_LE = b'\x00\x01'
_MULTI_ARRAY = struct.Struct('<I4xI')
_MULTI_ARRAY_DATA = 20


def value(topic: str, data: bytes) -> Any:
    """The command value (:func:`~screwgear_ros.sim.commands.command_value`) of the message of
    input ``topic`` in ``data`` (serialized CDR); a cmd_effort without layout dimensions
    is read without a message object (module docstring), with the same values."""
    if topic == Input.CMD_EFFORT and len(data) >= 16 and data[:2] == _CDR_LE:
        dims, count = _MULTI_ARRAY.unpack_from(data, 4)
        if not dims and not count:
            return []
        if not dims and len(data) >= _MULTI_ARRAY_DATA + 8 * count:
            return list(struct.unpack_from(f'<{count}d', data, _MULTI_ARRAY_DATA))
    return command_value(topic, decode(topic, data))


def excerpt(text: str, limit: int = MAX_LINE) -> str:
    """``text`` cut in the middle to at most about ``limit`` characters: its start names
    the topic and the value, its end the rule broken and what is kept."""
    if len(text) <= limit:
        return text
    half = limit // 2
    return f'{text[:half]} … [{len(text) - 2 * half} characters left out] … {text[-half:]}'


__all__ = ['MAX_INPUT_BYTES', 'MAX_LINE', 'decode', 'excerpt', 'oversized', 'value']
