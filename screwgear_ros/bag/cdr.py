"""Serialize once: CDR bytes of the node's fixed-layout outputs, from templates.

A ``joint_states`` message always has the same names and three values per array, a
``Float64`` one value, a ``Clock`` one stamp, a ``table_markers`` array the same markers
for as long as its colours and texts stay: their CDR layout does not change. A
:class:`Template` is the serialization of one such message, and the offsets where its
varying fields go (the stamps and blocks of doubles). Encoding is then one
``struct.pack`` of the whole message, the template's unchanging bytes included (no
message objects, no rclpy serializer), and the same bytes are published (rclpy
publishes ``bytes`` as a serialized message) and handed to the recorder. A
:class:`MessageBundle` packs several templates, a tick's messages, with one call and cuts them
apart.

:func:`template_of` writes the template of a prototype message, walking its fields in
the order of the message definition (``get_fields_and_field_types``, as rclpy's generated
classes answer it). The three layouts of every tick are prototyped by :class:`Shape`, a
message's field list spelt out, so that this module (and the bag reader that decodes
with the same templates) needs none of ROS's message packages; tests compare their bytes
with what rclpy and rosbags make of the real messages. The CDR rules are the plain ones (XCDR1 little endian,
as ROS 2 publishes): a 4-byte encapsulation header, then each primitive aligned to its
size counted from the end of that header; a string is its uint32 length with the NUL,
its UTF-8 bytes and the NUL; a sequence its uint32 count and its elements, the first
element aligned only if there is one; a nested message its fields, with no alignment of
its own; padding is zeros. Building a template so costs microseconds to a millisecond;
rosbags' typestore, which serializes any message, costs the node's start a tenth of a
second and more to load. Tests decode every encoding with rclpy's own deserializer and
compare the bytes with rosbags' serialization of the same message (rosbags pads with
zeros too; rclpy leaves padding bytes uninitialized, so only its decoding is compared).

:func:`joint_state_template`, :func:`float64_template` and :func:`clock_template` build
the three layouts the node publishes every tick; :mod:`screwgear_ros.view.markers` builds
the markers' from the MarkerArray it draws as a :class:`Shape`, and
:mod:`screwgear_ros.bag.messages` the other messages a run records.

Why not ``rosbags``' serializer, which the package depends on anyway: to serialize a
tick with it the node would build its messages as objects first, and the two together
cost several times one pack of a message bundle, on the pacing thread, every tick
(``benchmarks/bench_serialization.py`` measures both on a recorded run's ticks and checks
that their bytes are identical).
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

_STAMP = struct.Struct('<iI')          # builtin_interfaces/Time: int32 sec, uint32 nanosec
#: CDR encapsulation header: plain CDR, little endian, no options.
_CDR_LE = b'\x00\x01\x00\x00'
#: rosidl primitive type → struct code (the size is the alignment); rclpy holds an octet
#: as one byte of bytes. (char and wstring are not supported: no layout here has them.)
_PRIMITIVES = {'boolean': '?', 'octet': 'c', 'uint8': 'B', 'int8': 'b',
               'int16': 'h', 'uint16': 'H', 'int32': 'i', 'uint32': 'I', 'int64': 'q',
               'uint64': 'Q', 'float': 'f', 'double': 'd'}

#: Where a field sits in a message: field names and sequence indices from the top.
Path = tuple[str | int, ...]


@dataclass(frozen=True)
class Field:
    """Where a block of doubles (or a stamp) sits in the template."""

    offset: int
    codec: struct.Struct


class _Writer:
    """Appends a message's fields to a CDR buffer and notes where each one went:
    ``spans[path]`` = (start, end) of every field, ``leaves`` the (offset, struct code)
    of every primitive, ``free`` the bytes no decoder reads (encapsulation options and
    alignment padding)."""

    def __init__(self) -> None:
        self.buf = bytearray(_CDR_LE)
        self.free: list[tuple[int, int]] = [(2, 4)]   # the encapsulation options
        self.spans: dict[Path, tuple[int, int]] = {}
        self.leaves: list[tuple[int, str]] = []

    def _align(self, size: int) -> None:
        pad = -(len(self.buf) - len(_CDR_LE)) % size
        if pad:
            self.free.append((len(self.buf), len(self.buf) + pad))
            self.buf += bytes(pad)

    def _primitive(self, code: str, value: Any) -> None:
        codec = struct.Struct('<' + code)
        self._align(codec.size)
        self.leaves.append((len(self.buf), code))
        self.buf += codec.pack(value)

    def _string(self, text: str) -> None:
        data = text.encode('utf-8') + b'\0'
        self._primitive('I', len(data))
        self.buf += data

    def value(self, kind: str, value: Any, path: Path) -> None:
        """One field of rosidl type ``kind`` (as ``get_fields_and_field_types`` names it);
        its span starts at its first primitive (after that one's alignment)."""
        first = len(self.leaves)
        if kind in _PRIMITIVES:
            self._primitive(_PRIMITIVES[kind], value)
        elif kind == 'string' or kind.startswith('string<='):
            self._string(value)
        elif kind.startswith('sequence<'):
            element = kind[len('sequence<'):-1].split(',')[0]
            self._primitive('I', len(value))
            for i, item in enumerate(value):
                self.value(element, item, path + (i,))
        elif kind.endswith(']'):                      # fixed array T[N]: no count
            element = kind[:kind.index('[')]
            for i, item in enumerate(value):
                self.value(element, item, path + (i,))
        elif '/' in kind:
            self.message(value, path)
        else:
            raise TypeError(f'cdr: {kind!r} at {path} is not a supported field type')
        start = self.leaves[first][0] if len(self.leaves) > first else len(self.buf)
        self.spans[path] = (start, len(self.buf))

    def message(self, msg: Any, path: Path = ()) -> None:
        """All fields of ``msg`` in their declared order."""
        fields = msg.get_fields_and_field_types()
        if not fields:    # rosidl serializes a placeholder byte that Python does not show
            raise TypeError(f'cdr: {type(msg).__name__} at {path} has no fields')
        first = len(self.leaves)
        for name, kind in fields.items():
            self.value(kind, getattr(msg, name), path + (name,))
        self.spans[path] = (self.leaves[first][0], len(self.buf))

    def _codes(self, start: int, end: int) -> str:
        """The struct codes of the primitives written in [start, end)."""
        return ''.join(code for offset, code in self.leaves if start <= offset < end)

    def block(self, paths: Sequence[Path]) -> Field:
        """The doubles from the start of ``paths[0]`` to the end of ``paths[-1]``, which
        must hold nothing but doubles (no padding, no other field)."""
        if not paths:
            return Field(0, struct.Struct('<0d'))
        start, end = self.spans[paths[0]][0], self.spans[paths[-1]][1]
        codec = struct.Struct('<' + self._codes(start, end))
        if set(codec.format[1:]) != {'d'} or codec.size != end - start:
            raise ValueError(f'cdr: {paths[0]}..{paths[-1]} is not a block of doubles')
        return Field(start, codec)

    def stamp(self, path: Path) -> Field:
        """The builtin_interfaces/Time at ``path``."""
        start, end = self.spans[path]
        if '<' + self._codes(start, end) != _STAMP.format:
            raise ValueError(f'cdr: {path} is not a builtin_interfaces/Time')
        return Field(start, _STAMP)


class _Packed:
    """A layout encoded by one ``struct.pack``: ``_whole`` the struct, ``_items`` its
    arguments with the unchanging bytes in place, and where the varying ones go: a
    stamp's two at ``_stamp_items[i]``, a block's doubles at ``_block_items[k] = (first,
    count)``."""

    _whole: struct.Struct
    _items: list[Any]
    _stamp_items: list[int]
    _block_items: list[tuple[int, int]]

    def _pack(self, time_ns: int, blocks: Sequence[Sequence[float]]) -> bytes:
        """Every stamp set to ``time_ns`` (ns), the blocks in order, packed."""
        items = self._items.copy()
        if self._stamp_items:
            sec, nanosec = divmod(time_ns, 1_000_000_000)
            for i in self._stamp_items:
                items[i], items[i + 1] = sec, nanosec
        for (i, count), values in zip(self._block_items, blocks, strict=False):
            items[i:i + count] = values
        return self._whole.pack(*items)


class Template(_Packed):
    """The CDR bytes of one message layout, with the places of its varying fields:
    its stamps (each set to the same time; none for an unstamped message) and one block
    of doubles per value argument of :meth:`encode`; ``free``: the byte ranges
    [start, end) no decoder reads (the encapsulation options and the alignment padding,
    which rclpy leaves uninitialized)."""

    def __init__(self, msgtype: str, data: bytes, stamps: Sequence[Field],
                 fields: Sequence[Field], free: Sequence[tuple[int, int]] = ()) -> None:
        self.msgtype = msgtype
        self.bytes = bytes(data)
        self.stamps = tuple(stamps)
        self.fields = list(fields)
        self.free = list(free)
        # The whole message as one struct (_Packed): the bytes that never change between
        # the varying fields are 's' items of it, so encode() is one pack call.
        varying = sorted([(s.offset, s.codec, -1) for s in self.stamps]
                         + [(f.offset, f.codec, k) for k, f in enumerate(self.fields)],
                         key=lambda v: v[0])
        formats, self._items, at = ['<'], [], 0
        self._stamp_items: list[int] = []
        self._block_items = [(0, 0)] * len(self.fields)
        for offset, codec, block in varying:
            if not codec.size:
                continue
            count = len(codec.format) - 1           # one struct code per item
            if offset > at:
                formats.append(f'{offset - at}s')
                self._items.append(self.bytes[at:offset])
            if block < 0:
                self._stamp_items.append(len(self._items))
            else:
                self._block_items[block] = (len(self._items), count)
            formats.append(codec.format[1:])
            self._items.extend([0] * count)
            at = offset + codec.size
        if at < len(self.bytes):
            formats.append(f'{len(self.bytes) - at}s')
            self._items.append(self.bytes[at:])
        self._whole = struct.Struct(''.join(formats))

    def encode(self, time_ns: int, *blocks: Sequence[float]) -> bytes:
        """The message's CDR bytes with these stamps (ns) and these values."""
        return self._pack(time_ns, blocks)


class MessageBundle(_Packed):
    """Several templates side by side, encoded by one ``struct.pack`` and then cut
    apart: the messages a tick publishes (one pack instead of one per message: each
    pack call has a fixed cost, paid every tick). ``templates`` keep their own layouts; each encoding is byte for
    byte what its template's :meth:`Template.encode` gives."""

    def __init__(self, templates: Sequence[Template]) -> None:
        self.templates = tuple(templates)
        formats, self._items = ['<'], []
        self._stamp_items, self._block_items = [], []
        self._bounds: list[tuple[int, int]] = []     # each message's bytes in the pack
        at = 0
        for t in self.templates:
            first = len(self._items)
            self._items.extend(t._items)
            self._stamp_items.extend(first + i for i in t._stamp_items)
            self._block_items.extend((first + i, count) for i, count in t._block_items)
            formats.append(t._whole.format[1:])
            self._bounds.append((at, at + t._whole.size))
            at += t._whole.size
        self._whole = struct.Struct(''.join(formats))

    def encode(self, time_ns: int, *blocks: Sequence[float]) -> list[bytes]:
        """Each template's CDR bytes, in order, every stamp set to ``time_ns`` (ns) and
        the blocks of the first template, then of the second, and so on."""
        data = self._pack(time_ns, blocks)
        return [data[start:end] for start, end in self._bounds]


def type_name(msg: Any) -> str:
    """'sensor_msgs/msg/JointState' for a sensor_msgs.msg.JointState (class or message)
    or a :class:`Shape` of one."""
    if isinstance(msg, Shape):
        return msg.msgtype
    cls = msg if isinstance(msg, type) else type(msg)
    return f'{cls.__module__.split(".")[0]}/msg/{cls.__name__}'


@dataclass(frozen=True)
class Shape:
    """A message as :func:`template_of` walks it: its type name and its fields in
    declared order, each as (rosidl type, value)."""

    msgtype: str
    fields: dict[str, tuple[str, Any]]

    def get_fields_and_field_types(self) -> dict[str, str]:
        return {name: kind for name, (kind, _) in self.fields.items()}

    def __getattr__(self, name: str) -> Any:
        try:
            return self.fields[name][1]
        except KeyError:
            raise AttributeError(name) from None


def _time() -> Shape:
    return Shape('builtin_interfaces/msg/Time', {'sec': ('int32', 0), 'nanosec': ('uint32', 0)})


def template_of(msg: Any, stamps: Sequence[Path] = (),
                blocks: Sequence[Sequence[Path]] = ()) -> Template:
    """The template of ``msg``'s layout: its CDR bytes, the builtin_interfaces/Time at
    each of ``stamps``, and one block of doubles per entry of ``blocks`` (the fields from its
    first path to its last, nothing but doubles)."""
    w = _Writer()
    w.message(msg)
    return Template(type_name(msg), bytes(w.buf), [w.stamp(p) for p in stamps],
                    [w.block(paths) for paths in blocks], w.free)


def joint_state_template(names: Sequence[str]) -> Template:
    """sensor_msgs/JointState with these names and one position, velocity and effort each
    (frame_id '')."""
    n = len(names)
    header = Shape('std_msgs/msg/Header', {'stamp': ('builtin_interfaces/Time', _time()),
                                           'frame_id': ('string', '')})
    prototype = Shape('sensor_msgs/msg/JointState', {
        'header': ('std_msgs/Header', header), 'name': ('sequence<string>', list(names)),
        **{key: ('sequence<double>', [0.0] * n) for key in ('position', 'velocity', 'effort')}})
    return template_of(prototype, [('header', 'stamp')],
                       [[(key, 0), (key, n - 1)] if n else []
                        for key in ('position', 'velocity', 'effort')])


def float64_template() -> Template:
    """std_msgs/Float64."""
    return template_of(Shape('std_msgs/msg/Float64', {'data': ('double', 0.0)}),
                       blocks=[[('data',)]])


def clock_template() -> Template:
    """rosgraph_msgs/Clock."""
    return template_of(Shape('rosgraph_msgs/msg/Clock',
                             {'clock': ('builtin_interfaces/Time', _time())}), [('clock',)])


__all__ = [
    'Field',
    'MessageBundle',
    'Shape',
    'Template',
    'clock_template',
    'float64_template',
    'joint_state_template',
    'template_of',
    'type_name',
]
