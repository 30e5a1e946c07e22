"""The files of one recording: the MCAP file, ``metadata.yaml`` and the reserve beside them.

:class:`BagFiles` opens a rosbag2 directory the way ``ros2 bag record -s mcap`` on ROS 2
Jazzy lays it out (``metadata.yaml`` and one ``<name>_0.mcap``, profile ``ros2``,
``ros2msg`` schemas, QoS profiles on every channel), holds the room its last records
need in ``RESERVE_NAME`` (so a full disk still closes the bag), and closes it: summary,
index and the final ``metadata.yaml``. What is written when, and from which thread, is
:class:`screwgear_ros.bag.recorder.RunRecorder`'s business.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from .. import __version__
from .format import (
    MCAP_PROFILE,
    MESSAGE_ENCODING,
    SCHEMA_ENCODING,
    message_definition,
    metadata_document,
    metadata_yaml,
    qos_profile,
    qos_yaml,
)
from .mcap_writer import McapWriter

#: The file in the bag directory that holds the room for the bag's last records.
RESERVE_NAME = '.recording_reserve'


def create_file(path: Path) -> Any:
    """A new file for writing, unbuffered (see :class:`McapWriter`)."""
    return open(path, 'xb', buffering=0)


class _Reserve:
    """Bytes of the disk held in a file until the bag's last records need them."""

    _BLOCK = bytes(64 * 1024)

    def __init__(self, path: Path, open_file: Callable[[Path], Any], size: int) -> None:
        self._path = path
        self._file = open_file(path)
        self.size = 0
        self.grow(size)

    def grow(self, size: int) -> None:
        """Hold at least ``size`` bytes (OSError when the disk has no more)."""
        while self.size < size:
            self.size += self._file.write(self._BLOCK) or 0

    def release(self) -> None:
        self._file.truncate(0)
        self._file.close()
        self._path.unlink(missing_ok=True)


@dataclass(frozen=True)
class TopicGroup:
    """Topics recorded together, one message on each (in this order) at one log time:
    what a tick records. :meth:`RunRecorder.group` makes one, checking the topics once;
    :meth:`RunRecorder.write_group` then takes the messages with nothing to look up."""

    topics: tuple[str, ...]
    indexes: tuple[int, ...]        # each topic's place among the recorder's topics
    channel_ids: tuple[int, ...]    # each topic's MCAP channel


@dataclass(frozen=True)
class TopicSpec:
    """A topic of the bag: fully resolved name, ROS type, and whether it is latched."""

    name: str            # e.g. '/axis_c/joint_states'
    msgtype: str         # e.g. 'sensor_msgs/msg/JointState'
    transient_local: bool = False


class BagFiles:
    """The rosbag2 directory ``path`` of one recording, with ``topics``.

    :meth:`open` writes what the bag starts with; a start cut short leaves what it made
    on the object, for :meth:`discard`. :attr:`mcap` takes the messages; :meth:`finish`
    closes the bag.
    """

    def __init__(self, path: Path, topics: Sequence[TopicSpec]) -> None:
        self.path = path
        self.mcap_name = f'{path.name}_0.mcap'
        self.topics: list[dict[str, Any]] = [{'name': t.name, 'type': t.msgtype,
                        'qos': [qos_profile(t.transient_local)]} for t in topics]
        self._specs = list(topics)
        self.custom = {'screwgear_ros.package_version': __version__}
        self.channel_ids: list[int] = []     # per topic, in the order of ``topics``
        self.alone: dict[str, TopicGroup] = {}   # topic → the group of it alone
        self.file: Any = None
        self.mcap: McapWriter | None = None
        self.reserve: _Reserve | None = None
        self._metadata_bound = 0

    def open(self, open_file: Callable[[Path], Any], chunk_size: int,
             compression: bool) -> McapWriter:
        """Start the bag: metadata.yaml, the MCAP header, schemas and channels, the
        reserve. Returns the MCAP writer."""
        self.file = open_file(self.path / self.mcap_name)
        mcap = self.mcap = McapWriter(self.file, chunk_size, compression)
        self.write_metadata_yaml()
        mcap.start(profile=MCAP_PROFILE, library=f'screwgear_ros-{__version__}')
        mcap.add_metadata('rosbag2', {'serialized_metadata': self.serialized_metadata()})
        schemas: dict[str, int] = {}
        for index, (spec, topic) in enumerate(zip(self._specs, self.topics, strict=True)):
            if spec.msgtype not in schemas:
                text, _ = message_definition(spec.msgtype)
                schemas[spec.msgtype] = mcap.register_schema(
                    spec.msgtype, SCHEMA_ENCODING, text.encode())
            channel = mcap.register_channel(
                spec.name, MESSAGE_ENCODING, schemas[spec.msgtype],
                {'offered_qos_profiles': qos_yaml(topic['qos']),
                 'topic_type_hash': message_definition(spec.msgtype)[1]})
            self.alone[spec.name] = TopicGroup((spec.name,), (index,), (channel,))
            self.channel_ids.append(channel)
        # metadata.yaml and its copy in the MCAP file, with room for the counts' digits.
        self._metadata_bound = 4 * len(self.serialized_metadata()) + 4096
        self.reserve = _Reserve(self.path / RESERVE_NAME, open_file, 2 * self.end_bound())
        return mcap

    def discard(self, made: bool) -> None:
        """Remove what a start cut short had written (the directory too if it made it)."""
        if self.reserve is not None:
            self.reserve.release()
        if self.file is not None:
            self.file.close()
        for name in (self.mcap_name, RESERVE_NAME, 'metadata.yaml', 'metadata.yaml.tmp'):
            (self.path / name).unlink(missing_ok=True)
        if made:
            with contextlib.suppress(OSError):
                self.path.rmdir()

    def end_bound(self) -> int:
        """Bytes the end of the bag needs at most: the MCAP summary and the metadata."""
        assert self.mcap is not None
        return self.mcap.summary_bound() + self._metadata_bound

    def hold_room(self) -> None:
        """Keep the reserve at least what the end of the bag needs, doubling it."""
        assert self.reserve is not None
        if self.reserve.size < self.end_bound():
            self.reserve.grow(2 * self.end_bound())

    def finish(self, fail: Callable[[BaseException], None]) -> str:
        """Write summary and index, close, rewrite metadata.yaml; each failure goes to
        ``fail``. Returns '' or what of the end could not be written ('; ...')."""
        assert self.mcap is not None and self.reserve is not None
        unfinished = ''
        with contextlib.suppress(OSError):
            self.reserve.release()        # its room is the end's, whatever failed
        try:
            self.mcap.flush()             # the metadata counts what the file holds
            self.mcap.add_metadata('rosbag2',
                                   {'serialized_metadata': self.serialized_metadata()})
            self.mcap.finish()
        except Exception as exc:  # noqa: BLE001 - reported through fail
            fail(exc)
            unfinished = (f'; its summary could not be written ({type(exc).__name__}: {exc}): '
                          'it ends at its last whole chunk, readable as a truncated bag')
        finally:
            self.file.close()
        try:
            self.write_metadata_yaml()
        except OSError as exc:
            (self.path / 'metadata.yaml.tmp').unlink(missing_ok=True)
            fail(exc)
            unfinished += (f'; metadata.yaml could not be rewritten ({exc}): it is the one '
                           'written when the recording started, without counts')
        return unfinished

    def document(self) -> dict[str, Any]:
        """The rosbag2 metadata of the bag as it is now."""
        assert self.mcap is not None
        written = self.mcap.counts()        # none before the channels are registered
        return metadata_document(self.mcap_name, self.topics,
                                 [written.get(channel, 0) for channel in self.channel_ids]
                                 or [0] * len(self.topics),
                                 *self.mcap.time_range(), self.custom)

    def serialized_metadata(self) -> str:
        """:meth:`document` as the MCAP file's rosbag2 metadata record holds it."""
        return yaml.safe_dump(self.document(), default_flow_style=False, sort_keys=False)

    def write_metadata_yaml(self) -> None:
        """(Re)write metadata.yaml, atomically."""
        tmp = self.path / 'metadata.yaml.tmp'
        tmp.write_text(metadata_yaml(self.document()), encoding='utf-8')
        tmp.replace(self.path / 'metadata.yaml')


__all__ = ['RESERVE_NAME', 'BagFiles', 'TopicGroup', 'TopicSpec', 'create_file']
