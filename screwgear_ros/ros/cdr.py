"""Serialize once: CDR bytes of the node's fixed-layout outputs, written in place.

A ``joint_states`` message always has the same names and three values per array, a
``Float64`` one value, a ``Clock`` one stamp: their CDR layout never changes. A
:class:`Template` is the serialization of one such message with zeros in its varying
fields, and the offsets where each tick's numbers go. Encoding a tick is then a copy of
the template and a few ``struct.pack_into`` calls (no message objects, no rclpy
serializer), and the same bytes are published (rclpy publishes ``bytes`` as a serialized
message) and handed to the recorder.

The layout is written here by :class:`_Writer`, from the plain CDR rules (XCDR1 little
endian, as ROS 2 publishes: a 4-byte encapsulation header, then each primitive aligned
to its size counted from the end of that header; a string is its uint32 length with the
NUL, its UTF-8 bytes and the NUL; a sequence its uint32 count and its elements, the
first element aligned only if there is one), with zero padding. Building a template
so costs microseconds; rosbags' typestore, which serializes any message, costs the
node's start a tenth of a second and more to load. Tests decode every encoding with
rclpy's own deserializer and compare the bytes with rosbags' serialization of the same
message (rosbags pads with zeros too; rclpy leaves padding bytes uninitialized, so only
its decoding is compared).

:func:`joint_state_template`, :func:`float64_template` and :func:`clock_template` build
the three layouts the node publishes every tick.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import Sequence

_STAMP = struct.Struct('<iI')          # builtin_interfaces/Time: int32 sec, uint32 nanosec
_UINT32 = struct.Struct('<I')
#: CDR encapsulation header: plain CDR, little endian, no options.
_CDR_LE = b'\x00\x01\x00\x00'


@dataclass(frozen=True)
class Field:
    """Where a run of doubles (or the stamp) sits in the template."""

    offset: int
    codec: struct.Struct


class _Writer:
    """Appends CDR fields to a buffer; alignment counts from the end of the header."""

    def __init__(self) -> None:
        self.buf = bytearray(_CDR_LE)
        self.free: list[tuple[int, int]] = [(2, 4)]   # the encapsulation options

    def _align(self, size: int) -> None:
        pad = -(len(self.buf) - len(_CDR_LE)) % size
        if pad:
            self.free.append((len(self.buf), len(self.buf) + pad))
            self.buf += bytes(pad)

    def _reserve(self, size: int, codec: struct.Struct) -> Field:
        self._align(size)
        field = Field(len(self.buf), codec)
        self.buf += bytes(codec.size)
        return field

    def uint32(self, value: int) -> None:
        self._align(4)
        self.buf += _UINT32.pack(value)

    def string(self, text: str) -> None:
        data = text.encode('utf-8') + b'\0'
        self.uint32(len(data))
        self.buf += data

    def strings(self, texts: Sequence[str]) -> None:
        """sequence<string>."""
        self.uint32(len(texts))
        for text in texts:
            self.string(text)

    def stamp(self) -> Field:
        """builtin_interfaces/Time, to be filled in."""
        return self._reserve(4, _STAMP)

    def doubles(self, n: int) -> Field:
        """``n`` float64 in a row (a float64 field when ``n`` is 1), to be filled in."""
        codec = struct.Struct(f'<{n}d')
        if n == 0:
            return Field(len(self.buf), codec)
        return self._reserve(8, codec)

    def double_sequence(self, n: int) -> Field:
        """sequence<float64> of ``n`` values, to be filled in."""
        self.uint32(n)
        return self.doubles(n)


class Template:
    """The CDR bytes of one message layout, with the places of its varying fields:
    the stamp (or None) and one run of doubles per value argument of :meth:`encode`;
    ``free``: the byte ranges [start, end) no decoder reads (the encapsulation options
    and the alignment padding, which rclpy leaves uninitialized)."""

    def __init__(self, msgtype: str, data: bytes, stamp: Field | None,
                 fields: Sequence[Field], free: Sequence[tuple[int, int]] = ()) -> None:
        self.msgtype = msgtype
        self.bytes = bytes(data)
        self.stamp = stamp
        self.fields = list(fields)
        self.free = list(free)

    def encode(self, time_ns: int, *runs: Sequence[float]) -> bytes:
        """The message's CDR bytes with this stamp (ns) and these values."""
        buf = bytearray(self.bytes)
        if self.stamp is not None:
            sec, nanosec = divmod(time_ns, 1_000_000_000)
            self.stamp.codec.pack_into(buf, self.stamp.offset, sec, nanosec)
        for f, values in zip(self.fields, runs):
            f.codec.pack_into(buf, f.offset, *values)
        return bytes(buf)


def joint_state_template(names: Sequence[str]) -> Template:
    """sensor_msgs/JointState with these names and one position, velocity and effort each
    (std_msgs/Header stamp, frame_id ''; name; position; velocity; effort)."""
    w = _Writer()
    stamp = w.stamp()
    w.string('')
    w.strings(list(names))
    runs = [w.double_sequence(len(names)) for _ in range(3)]
    return Template('sensor_msgs/msg/JointState', w.buf, stamp, runs, w.free)


def float64_template() -> Template:
    """std_msgs/Float64."""
    w = _Writer()
    data = w.doubles(1)
    return Template('std_msgs/msg/Float64', w.buf, None, [data], w.free)


def clock_template() -> Template:
    """rosgraph_msgs/Clock."""
    w = _Writer()
    stamp = w.stamp()
    return Template('rosgraph_msgs/msg/Clock', w.buf, stamp, [], w.free)


__all__ = ['Template', 'joint_state_template', 'float64_template', 'clock_template']
