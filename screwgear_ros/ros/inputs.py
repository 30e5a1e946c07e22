"""What arrives on the node's input topics, before it becomes a command.

The node subscribes to its inputs raw (serialized CDR) and looks at a message's size
before anything else: a command carries one value, and a ``joint_commands`` message one
name and at most one value per joint, so a message of more than ``MAX_INPUT_BYTES`` is
no command. It is refused unread: decoding it, validating it and writing the value into
a warning cost the executor and the pacing thread time in proportion to its size, which
a flood of them took from the simulation. What the node logs about a rejected value is
at most an :func:`excerpt` of it.
"""

from __future__ import annotations

from typing import Any

from rclpy.serialization import deserialize_message

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


def excerpt(text: str, limit: int = MAX_LINE) -> str:
    """``text`` cut in the middle to at most about ``limit`` characters: its start names
    the topic and the value, its end the rule broken and what is kept."""
    if len(text) <= limit:
        return text
    half = limit // 2
    return f'{text[:half]} … [{len(text) - 2 * half} characters left out] … {text[-half:]}'


__all__ = ['MAX_INPUT_BYTES', 'MAX_LINE', 'oversized', 'decode', 'excerpt']
