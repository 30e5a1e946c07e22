"""In-process recorded runs: the node's own session and RunIO, with no DDS and no node.

:func:`record_session` (from :mod:`screwgear_ros.runs.session_record`) plays a
:class:`~screwgear_ros.sim.schedule.Schedule` into a :class:`~screwgear_ros.sim.session.Session`
and records it with the node's :class:`~screwgear_ros.runs.run_io.RunIO` (publishers none),
so a bag is written exactly as table_sim writes it, tick by tick, as fast as the machine goes.
:func:`copy_bag` rewrites a bag message by message (to corrupt one on purpose); :data:`BAGS`
names the runs checked in under :data:`paths.DATA`.
"""

from __future__ import annotations

import shutil
import subprocess
from collections.abc import Callable
from pathlib import Path

import numpy as np
import yaml
from mcap.records import Channel, Message, Schema
from mcap.stream_reader import StreamReader

from screwgear_ros.bag import RunRecorder, TopicSpec
from screwgear_ros.params.table import SimSettings, TableParams
from screwgear_ros.runs.session_record import record_session
from screwgear_ros.sim.events import Command
from screwgear_ros.sim.session import Session

#: The runs checked in under test/data, each a rosbag2 directory table_sim recorded; every
#: reader, checker and replay is tried on all of them.
BAGS = ['steady_drive', 'reversals_anti_backlash', 'reversals_conventional',
        'load_steps_parameter_changes']


def reversal_run(params: TableParams, settings: SimSettings, torque: float, reversal: int,
                 end: int) -> tuple[np.ndarray, np.ndarray, int]:
    """RK4 as the node runs it: a session driven forward with ``torque`` from step 0 and
    reversed (cmd_direction −1) at step ``reversal``, ticking until step ``end``:
    (initial state, the state after every tick, contact changes located)."""
    session = Session(params, settings)
    y0 = session.plant.state.copy()
    session.submit(Command('cmd_torque', torque))
    out = []
    while session.step < end:
        if session.step == reversal:
            session.submit(Command('cmd_direction', -1))
        assert session.tick().fault is None
        out.append(session.plant.state.copy())
    return y0, np.array(out), session.plant.contact_changes


Edit = Callable[[str, str, int, bytes], 'tuple[int, bytes] | None']


def nudge_table_angle(at_ns: int, by: float) -> Edit:
    """An edit for :func:`copy_bag`: the table angle of the joint_states at log time
    ``at_ns`` moved by ``by`` rad, every other message as it was."""
    from rosbags.typesys import Stores, get_typestore
    store = get_typestore(Stores.ROS2_JAZZY)

    def edit(topic: str, msgtype: str, log_time: int, raw: bytes) -> tuple[int, bytes]:
        if topic.endswith('/joint_states') and log_time == at_ns:
            msg = store.deserialize_cdr(raw, msgtype)
            msg.position = msg.position.copy()     # rosbags decodes read-only views
            msg.position[1] += by
            raw = bytes(store.serialize_cdr(msg, msgtype))
        return log_time, raw
    return edit


def installed(exe: str, *args: object, timeout: float = 300.0) -> subprocess.CompletedProcess:
    """The installed console script ``exe`` on ``args``, output captured."""
    path = shutil.which(exe)
    assert path is not None, f'{exe} is not installed in the venv'
    return subprocess.run([path, *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, check=False)


def installed_check_run(*args: object) -> subprocess.CompletedProcess:
    """The installed ``check_run`` console script on ``args`` (no progress bar)."""
    return installed('check_run', '--no-progress', *args)


def truncated_copy(src: Path, dst: Path, keep: float = 0.6) -> Path:
    """A copy of the bag ``src`` at ``dst`` whose MCAP file is cut to ``keep`` of its
    length, as a killed writer leaves it."""
    mcap_file, = Path(src).glob('*.mcap')
    damaged_copy(src, dst, keep=int(mcap_file.stat().st_size * keep))
    return dst


def damaged_copy(src: Path, dst: Path, keep: int | None = None,
                 flip: int | None = None) -> Path:
    """A copy of the bag ``src`` at ``dst`` whose MCAP file keeps its first ``keep``
    bytes (None: all of them), with byte ``flip`` inverted; the copy's MCAP file."""
    shutil.copytree(src, dst)
    mcap_file, = Path(dst).glob('*.mcap')
    data = bytearray(mcap_file.read_bytes())
    if flip is not None:
        data[flip] ^= 0xFF
    mcap_file.write_bytes(bytes(data[:keep] if keep is not None else data))
    return mcap_file


def bag_messages(src: Path) -> tuple[dict[int, TopicSpec], list[tuple[int, int, bytes]]]:
    """The topics of the bag ``src`` by channel id, and its messages as (channel id, log
    time, CDR) in file order."""
    mcap_file, = Path(src).glob('*.mcap')
    schemas: dict[int, str] = {}
    channels: dict[int, TopicSpec] = {}
    messages: list[tuple[int, int, bytes]] = []
    with open(mcap_file, 'rb') as stream:
        for record in StreamReader(stream).records:
            if isinstance(record, Schema):
                schemas[record.id] = record.name
            elif isinstance(record, Channel):
                qos = yaml.safe_load(record.metadata['offered_qos_profiles'])
                channels[record.id] = TopicSpec(record.topic, schemas[record.schema_id],
                                                qos[0]['durability'] == 'transient_local')
            elif isinstance(record, Message):
                messages.append((record.channel_id, record.log_time, record.data))
    return channels, messages


def write_bag(dst: Path, specs: list[TopicSpec],
              messages: list[tuple[str, int, bytes]]) -> Path:
    """A bag at ``dst`` of ``messages`` (topic, log time, CDR), every one written by the
    node's recorder; ``dst``."""
    recorder = RunRecorder(dst, specs, bytes, queue_size=len(messages) + 1)  # all in memory
    for topic, log_time, data in messages:
        recorder.write(topic, log_time, data)
    recorder.close()
    assert recorder.dropped == 0 and recorder.written == len(messages)
    return dst


def copy_bag(src: Path, dst: Path, edit: Edit | None = None) -> int:
    """Rewrite the bag ``src`` to ``dst`` message by message, in file order.

    ``edit(topic, type, log_time, cdr)`` returns the (log_time, cdr) to write, or
    None to drop the message. Returns the number of messages written.
    """
    channels, recorded = bag_messages(src)
    messages: list[tuple[str, int, bytes]] = []
    for channel, log_time, data in recorded:
        spec = channels[channel]
        kept = (log_time, data) if edit is None else edit(spec.name, spec.msgtype, log_time,
                                                          data)
        if kept is not None:
            messages.append((spec.name, *kept))
    write_bag(dst, list(channels.values()), messages)
    return len(messages)


__all__ = [
    'bag_messages',
    'copy_bag',
    'damaged_copy',
    'installed',
    'installed_check_run',
    'nudge_table_angle',
    'record_session',
    'reversal_run',
    'truncated_copy',
    'write_bag',
]

def record_topic(specs: dict[int, TopicSpec], record: Message) -> str:
    return specs[record.channel_id].name.rsplit('/', 1)[1]


def retyped_copy(src: Path, dst: Path, rename: dict[str, str] | None = None,
                 retype: dict[str, str] | None = None, edit=None) -> None:
    """``src`` rewritten with the node's recorder, topics renamed / declared with other
    types (by relative name), each message through ``edit(rel, raw) -> raw | None``."""
    rename, retype = rename or {}, retype or {}
    schemas: dict[int, str] = {}
    specs: dict[int, TopicSpec] = {}
    out: list[tuple[str, int, bytes]] = []
    mcap_file, = src.glob('*.mcap')
    with open(mcap_file, 'rb') as stream:
        for record in StreamReader(stream).records:
            if isinstance(record, Schema):
                schemas[record.id] = record.name
            elif isinstance(record, Channel):
                head, rel = record.topic.rsplit('/', 1)
                qos = yaml.safe_load(record.metadata['offered_qos_profiles'])
                specs[record.id] = TopicSpec(f'{head}/{rename.get(rel, rel)}',
                                             retype.get(rel, schemas[record.schema_id]),
                                             qos[0]['durability'] == 'transient_local')
            elif isinstance(record, Message):
                spec = specs[record.channel_id]
                raw = record.data if edit is None else edit(
                    record_topic(specs, record), record.data)
                if raw is not None:
                    out.append((spec.name, record.log_time, raw))
    recorder = RunRecorder(dst, list(specs.values()), bytes, queue_size=len(out) + 1)
    for topic, log_time, raw in out:
        recorder.write(topic, log_time, raw)
    recorder.close()
