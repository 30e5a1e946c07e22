"""Decode a bag's messages: the fixed-layout ones in bulk with NumPy, the others with
the ROS 2 Jazzy CDR codec of ``rosbags``, every failure an :class:`InvalidBag`.

A message is decoded in bulk only if every byte outside its stamps and values equals
the template's (:class:`screwgear_ros.bag.cdr.Template`), which fixes where they are;
any other message of these topics goes through ``rosbags``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from .cdr import Template, float64_template, joint_state_template
from .errors import InvalidBag
from .format import typestore
from .mcap_scan import OUTPUT_TOPICS


def _fixed_bytes(template: Template) -> np.ndarray:
    """Mask of the template's bytes that fix the layout: all but the stamps, the values and
    the bytes no decoder reads (:attr:`Template.free`: the encapsulation options and the
    alignment padding, which rclpy leaves uninitialized)."""
    fixed = np.ones(len(template.bytes), dtype=bool)
    for f in [*template.stamps, *template.fields]:
        fixed[f.offset:f.offset + f.codec.size] = False
    for start, end in template.free:
        fixed[start:end] = False
    return fixed


def _bulk(parts: list[np.ndarray | list[bytes]], template: Template | None, width: int,
          one: Any) -> tuple[np.ndarray, np.ndarray]:
    """Values (n, width) and header stamps (n,) ns (0 if unstamped) of messages.

    A message whose bytes equal ``template``'s outside its stamp and values (``width``
    of them) is read in place with NumPy; any other is ``one(bytes) -> (values, stamp)``
    (``rosbags``), and every one if ``template`` is None.
    """
    n = sum(len(p) for p in parts)
    values = np.empty((n, width))
    stamps = np.zeros(n, dtype=np.int64)
    if template is not None:
        assert sum(f.codec.size for f in template.fields) == 8 * width
        fixed = _fixed_bytes(template)
        reference = np.frombuffer(template.bytes, dtype=np.uint8)[fixed]
    i = 0
    for part in parts:
        k = len(part)
        fits = np.zeros(k, dtype=bool)
        if (template is not None and isinstance(part, np.ndarray)
                and part.shape[1] == len(template.bytes)):
            fits = np.all(part[:, fixed] == reference, axis=1)
            rows = part[fits]
            values[i:i + k][fits] = np.hstack(
                [np.ascontiguousarray(rows[:, f.offset:f.offset + f.codec.size]).view('<f8')
                 for f in template.fields])
            if template.stamps:      # the header's: the layouts read here have one
                o = template.stamps[0].offset
                sec = np.ascontiguousarray(rows[:, o:o + 4]).view('<i4')[:, 0]
                nanosec = np.ascontiguousarray(rows[:, o + 4:o + 8]).view('<u4')[:, 0]
                stamps[i:i + k][fits] = sec.astype(np.int64) * 1_000_000_000 + nanosec
        for j in np.flatnonzero(~fits).tolist():
            raw = part[j].tobytes() if isinstance(part, np.ndarray) else part[j]
            values[i + j], stamps[i + j] = one(raw)
        i += k
    return values, stamps


#: A message decoded one by one: (file order, topic, type name, log time, CDR bytes).
_Message = tuple[int, str, str, int, bytes]
#: A bulk topic's messages as scanned: (file orders, log times, raw messages) per chunk.
_Pieces = list[tuple[np.ndarray, np.ndarray, 'np.ndarray | list[bytes]']]


class _Decoder:
    """Decodes the messages of one bag, every failure a :class:`BagError` naming it:
    ``names`` (relative name → topic) from :func:`_topics`, the step grid (``dt_ns``)
    and the joints from the first run_parameters once read."""

    def __init__(self, path: str | Path, names: dict[str, str]) -> None:
        self.path = path
        self.names = names
        self.store = typestore()
        self.dt_ns = 0.0
        self.joints: list[str] = []

    def decode(self, raw: bytes, msgtype: str, topic: str) -> Any:
        """``raw`` decoded; a message that is not valid CDR of its type is an invalid bag
        (whatever the codec raised)."""
        try:
            return self.store.deserialize_cdr(raw, msgtype)
        except Exception as exc:  # noqa: BLE001 - the codec's errors are of many types
            raise InvalidBag(f'{self.path}: a message on {topic} is not a valid '
                           f'{msgtype} ({type(exc).__name__}: {exc})') from None

    def steps(self, log_time: np.ndarray, topic: str) -> np.ndarray:
        """The steps of these log times, which must lie on the step grid."""
        dt_ns = self.dt_ns
        steps = np.rint(log_time / dt_ns)
        off = np.flatnonzero(np.abs(log_time - steps * dt_ns) > 0.5 + 1e-6 * dt_ns)
        if len(off):
            raise InvalidBag(f'{topic}: log time {int(log_time[off[0]])} ns is not on '
                           f'the step grid of dt = {dt_ns:g} ns')
        return steps.astype(np.int64)

    def _sized(self, msg: Any, topic: str, n: int) -> None:
        if not len(msg.position) == len(msg.velocity) == len(msg.effort) == n:
            raise InvalidBag(f'{self.path}: a message on {topic} has '
                           f'{len(msg.position)} positions, {len(msg.velocity)} velocities '
                           f'and {len(msg.effort)} efforts for {n} names')

    def joint_state(self, raw: bytes, rel: str = 'joint_states') -> tuple[np.ndarray, int]:
        """One joint_states (or true_joint_states) message the bulk decoder could not
        take: its values in the recorded joints' order, and its stamp (ns)."""
        topic = self.names[rel]
        msg = self.decode(raw, OUTPUT_TOPICS[rel], topic)
        try:
            idx = [list(msg.name).index(n) for n in self.joints]
        except ValueError:
            raise InvalidBag(f'{topic}: joints {list(msg.name)} do '
                           f'not include {self.joints}') from None
        self._sized(msg, topic, len(msg.name))
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        return np.concatenate([msg.position[idx], msg.velocity[idx], msg.effort[idx]]), stamp

    def mesh_state(self, raw: bytes) -> tuple[np.ndarray, int]:
        topic = self.names['mesh_state']
        msg = self.decode(raw, OUTPUT_TOPICS['mesh_state'], topic)
        self._sized(msg, topic, 2)
        return np.concatenate([msg.position, msg.velocity, msg.effort]), 0

    def float64(self, raw: bytes) -> tuple[np.ndarray, int]:
        topic = self.names['transmission_error']
        return np.array([self.decode(raw, OUTPUT_TOPICS['transmission_error'], topic).data]), 0

    def mesh_template(self, parts: list[np.ndarray | list[bytes]]) -> Template | None:
        """The layout of the first mesh_state message's names (the node's: one δ1, δ3)."""
        if not parts:
            return None
        raw = parts[0][0].tobytes() if isinstance(parts[0], np.ndarray) else parts[0][0]
        msg = self.decode(raw, OUTPUT_TOPICS['mesh_state'], self.names['mesh_state'])
        return joint_state_template(list(msg.name)) if len(msg.name) == 2 else None

    def layout(self, rel: str) -> tuple[Any, int, Any]:
        """(the template of a bulk topic from its parts, values per message, the decoder
        of one message the template does not fit)."""
        if rel == 'joint_states':
            return lambda parts: joint_state_template(self.joints), 9, self.joint_state
        if rel == 'true_joint_states':
            return (lambda parts: joint_state_template(self.joints), 9,
                    lambda raw: self.joint_state(raw, rel))
        if rel == 'transmission_error':
            return lambda parts: float64_template(), 1, self.float64
        return self.mesh_template, 6, self.mesh_state


