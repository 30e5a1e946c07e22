"""RunRecorder: what it writes is a rosbag2/MCAP bag other readers decode, and it never blocks.

The recorder writes with ``mcap`` (container) and rclpy (CDR); every test reads
back with something else: ``rosbags`` (its own rosbag2 directory reader, MCAP
parser and CDR codec) and ``mcap_ros2``'s decoder built from the schemas embedded
in the file. Type hashes are compared with the interface descriptions a ROS 2 Jazzy
install ships (share/<pkg>/msg/<Type>.json).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import yaml
from ament_index_python.packages import get_package_share_directory
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from mcap_stream import iter_messages
from rclpy.serialization import serialize_message
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import (
    Empty,
    Float64,
    Float64MultiArray,
    Header,
    Int8,
    MultiArrayDimension,
    MultiArrayLayout,
    String,
)

from screwgear_ros.bag import RunRecorder, TopicSpec
from screwgear_ros.bag.errors import BagError, NoParameters, TruncatedBag
from screwgear_ros.bag.reader import read_run

TOPICS = [
    TopicSpec('/axis_c/joint_states', 'sensor_msgs/msg/JointState'),
    TopicSpec('/axis_c/transmission_error', 'std_msgs/msg/Float64'),
    TopicSpec('/axis_c/active_path', 'std_msgs/msg/Int8', transient_local=True),
    TopicSpec('/clock', 'rosgraph_msgs/msg/Clock'),
    TopicSpec('/diagnostics', 'diagnostic_msgs/msg/DiagnosticArray'),
    TopicSpec('/axis_c/cmd_effort', 'std_msgs/msg/Float64MultiArray'),
    TopicSpec('/axis_c/table_sim/run_parameters', 'std_msgs/msg/String'),
    TopicSpec('/axis_c/table_sim/reset', 'std_msgs/msg/Empty'),
]


def sample_messages() -> list[tuple[str, int, object]]:
    """One or more messages of every type the node records, with awkward values."""
    t = 1_234_567_890_123
    stamp = Time(sec=t // 10**9, nanosec=t % 10**9)
    return [
        ('/axis_c/table_sim/run_parameters', 0, String(data='dt: 5.0e-05\nmode: anti_backlash\n'
                                                       'note: "ümlaut µs"\n')),
        ('/axis_c/active_path', 0, Int8(data=3)),
        ('/axis_c/joint_states', t, JointState(
            header=Header(stamp=stamp, frame_id='table'), name=['pinion_1', 'table', 'pinion_3'],
            position=[1e-300, -2.5, np.pi], velocity=[0.0, -0.0, 1e300],
            effort=[350.0, -1.25e-7, -750.0])),
        ('/axis_c/transmission_error', t, Float64(data=-7.5e-05)),
        ('/clock', t, Clock(clock=stamp)),
        ('/diagnostics', t, DiagnosticArray(header=Header(stamp=stamp), status=[
            DiagnosticStatus(level=DiagnosticStatus.WARN, name='table_sim: timing',
                             message='overruns', hardware_id='sim',
                             values=[KeyValue(key='real_time_factor', value='0.98'),
                                     KeyValue(key='overruns', value='3')])])),
        ('/axis_c/cmd_effort', t, Float64MultiArray(
            layout=MultiArrayLayout(dim=[MultiArrayDimension(label='x', size=1, stride=1)],
                                    data_offset=0), data=[-399.5])),
        ('/axis_c/table_sim/reset', t + 50_000, Empty()),
    ]


def plain(reference: object, value: object) -> object:
    """``value`` (decoded by any library) as plain Python, shaped by the rclpy ``reference``."""
    if hasattr(reference, 'get_fields_and_field_types'):
        return {name: plain(getattr(reference, name), getattr(value, name))
                for name in reference.get_fields_and_field_types()}
    if isinstance(reference, (list, tuple, np.ndarray)) or type(reference).__name__ == 'array':
        return [plain(r, v) for r, v in zip(list(reference), list(value), strict=True)]
    if isinstance(reference, float):
        return float(value)
    if isinstance(reference, bytes):     # rclpy's `byte` fields; other readers give ints
        return value[0] if isinstance(value, bytes) else int(value)
    return value


def write_samples(path: Path) -> list[tuple[str, int, object]]:
    messages = sample_messages()
    recorder = RunRecorder(path, TOPICS, serialize_message)
    for topic, t, msg in messages:
        recorder.write(topic, t, msg)
    recorder.close()
    assert (recorder.written, recorder.dropped, recorder.error) == (len(messages), 0, None)
    return messages


def test_rosbags_reads_every_message_back(tmp_path: Path) -> None:
    messages = write_samples(tmp_path / 'bag')
    store = get_typestore(Stores.ROS2_JAZZY)
    with Reader(tmp_path / 'bag') as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        decoded = [(c.topic, t, store.deserialize_cdr(raw, c.msgtype))
                   for c, t, raw in reader.messages()]
    assert counts == {s.name: sum(m[0] == s.name for m in messages) for s in TOPICS}
    assert sorted((t, topic) for topic, t, _ in decoded) == sorted(
        (t, topic) for topic, t, _ in messages)
    by_topic = {topic: msg for topic, _, msg in decoded}
    for topic, _, original in messages:
        assert plain(original, by_topic[topic]) == plain(original, original), topic


def test_mcap_ros2_decodes_every_message_from_the_embedded_schemas(tmp_path: Path) -> None:
    messages = write_samples(tmp_path / 'bag')
    mcap_file, = (tmp_path / 'bag').glob('*.mcap')
    with open(mcap_file, 'rb') as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        header = reader.get_header()
        decoded = [(channel.topic, message.log_time, schema.encoding, channel, obj)
                   for schema, channel, message, obj in reader.iter_decoded_messages(
                       log_time_order=False)]
        summary = reader.get_summary()
    assert header.profile == 'ros2'
    assert len(decoded) == len(messages)
    # File order is write order, also for equal log times.
    assert [(d[0], d[1]) for d in decoded] == [(m[0], m[1]) for m in messages]
    for (topic, _, encoding, channel, obj), (_, _, original) in zip(decoded, messages, strict=True):
        assert encoding == 'ros2msg' and channel.message_encoding == 'cdr'
        assert plain(original, obj) == plain(original, original), topic
    assert summary is not None and summary.statistics.message_count == len(messages)


def test_many_chunks_read_back_through_every_index(tmp_path: Path) -> None:
    """Thousands of messages on three topics at different rates over many small chunks
    (the recorder writes MCAP records itself): mcap's seeking reader (chunk indexes, CRCs
    validated, per-topic and log-time-ordered reads), its stream reader (every record in
    file order, each message index entry pointing at its message) and rosbags (which
    counts a chunk's messages per topic from the message index layout) all read back
    exactly what was written."""
    topics = [TOPICS[0], TOPICS[1], TOPICS[3]]
    recorder = RunRecorder(tmp_path / 'bag', topics, serialize_message, chunk_size=4096)
    handed: list[tuple[str, int, float]] = []
    for k in range(3000):
        t = 1_000_000 * k
        stamp = Time(sec=t // 10**9, nanosec=t % 10**9)
        tick = [(topics[1].name, t, Float64(data=k * 0.5))]
        if k % 3 == 0:
            tick.append((topics[0].name, t, JointState(header=Header(stamp=stamp),
                                                       name=['table'], position=[-k * 0.25])))
        if k % 7 == 0:
            tick.insert(0, (topics[2].name, t, Clock(clock=stamp)))
        recorder.write_group(recorder.group([topic for topic, _, _ in tick]), t,
                             [msg for _, _, msg in tick])
        handed.extend((topic, t, msg.data if isinstance(msg, Float64) else
                       msg.position[0] if isinstance(msg, JointState) else float(k))
                      for topic, t, msg in tick)
    recorder.close()
    assert (recorder.written, recorder.dropped, recorder.error) == (len(handed), 0, None)
    mcap_file, = (tmp_path / 'bag').glob('*.mcap')

    def value(topic: str, t: int, obj: object) -> tuple[str, int, float]:
        return (topic, t, obj.data if topic == topics[1].name else
                obj.position[0] if topic == topics[0].name else float(t // 1_000_000))

    with open(mcap_file, 'rb') as stream:
        reader = make_reader(stream, validate_crcs=True, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        in_order = [value(c.topic, m.log_time, o) for _, c, m, o in
                    reader.iter_decoded_messages(log_time_order=True)]
        per_topic = {spec.name: [value(c.topic, m.log_time, o) for _, c, m, o in
                                 reader.iter_decoded_messages(topics=[spec.name])]
                     for spec in topics}
    assert len(summary.chunk_indexes) > 10
    assert summary.statistics.message_count == len(handed)
    by_id = {c.id: c.topic for c in summary.channels.values()}
    assert {by_id[i]: n for i, n in summary.statistics.channel_message_counts.items()} == \
        {spec.name: sum(h[0] == spec.name for h in handed) for spec in topics}
    assert in_order == sorted(handed, key=lambda h: h[1]) and len(in_order) == len(handed)
    for spec in topics:
        assert per_topic[spec.name] == [h for h in handed if h[0] == spec.name]
    assert indexed_messages(mcap_file) == len(handed)
    with Reader(tmp_path / 'bag') as reader:
        for spec in topics:
            connections = [c for c in reader.connections if c.topic == spec.name]
            times = [t for _, t, _ in reader.messages(connections=connections)]
            assert times == [h[1] for h in handed if h[0] == spec.name]


def test_metadata_qos_and_jazzy_type_hashes(tmp_path: Path) -> None:
    write_samples(tmp_path / 'bag')
    info = yaml.safe_load((tmp_path / 'bag' / 'metadata.yaml').read_text())[
        'rosbag2_bagfile_information']
    assert info['version'] == 9 and info['storage_identifier'] == 'mcap'
    assert info['relative_file_paths'] == ['bag_0.mcap']
    assert info['message_count'] == len(sample_messages())
    for entry in info['topics_with_message_count']:
        meta = entry['topic_metadata']
        pkg, _, name = meta['type'].split('/')
        shipped = json.loads(Path(get_package_share_directory(pkg), 'msg',
                                  f'{name}.json').read_text())
        assert meta['type_description_hash'] == shipped['type_hashes'][0]['hash_string']
        durability = meta['offered_qos_profiles'][0]['durability']
        assert durability == ('transient_local' if name == 'Int8' else 'volatile')
    # rosbag2's MCAP plugin reads QoS and hashes from the channel metadata.
    mcap_file, = (tmp_path / 'bag').glob('*.mcap')
    with open(mcap_file, 'rb') as stream:
        summary = make_reader(stream).get_summary()
        metadata = list(make_reader(stream).iter_metadata())
    for channel in summary.channels.values():
        profiles = yaml.safe_load(channel.metadata['offered_qos_profiles'])
        assert profiles[0]['reliability'] == 'reliable'
        assert channel.metadata['topic_type_hash'].startswith('RIHS01_')
    assert metadata[-1].name == 'rosbag2'
    assert yaml.safe_load(metadata[-1].metadata['serialized_metadata'])['version'] == 9


def test_an_open_recording_is_already_a_rosbag2_directory(tmp_path: Path) -> None:
    recorder = RunRecorder(tmp_path / 'bag', TOPICS, serialize_message)
    try:
        info = yaml.safe_load((tmp_path / 'bag' / 'metadata.yaml').read_text())
        names = [t['topic_metadata']['name']
                 for t in info['rosbag2_bagfile_information']['topics_with_message_count']]
        assert names == [t.name for t in TOPICS]
    finally:
        recorder.close()


def test_refuses_to_overwrite(tmp_path: Path) -> None:
    (tmp_path / 'bag').mkdir()
    (tmp_path / 'bag' / 'x').write_text('keep me')
    with pytest.raises(FileExistsError):
        RunRecorder(tmp_path / 'bag', TOPICS, serialize_message)
    with pytest.raises(ValueError, match='not declared'):
        recorder = RunRecorder(tmp_path / 'other', TOPICS, serialize_message)
        try:
            recorder.write('/nope', 0, Empty())
        finally:
            recorder.close()


def test_write_never_blocks_on_a_stalled_writer(tmp_path: Path) -> None:
    """A serializer stuck (a disk that hangs) fills the bounded queue; writes drop and count."""
    release = threading.Event()

    def stalled(msg: object) -> bytes:
        release.wait()
        return serialize_message(msg)

    recorder = RunRecorder(tmp_path / 'bag', TOPICS[1:2], stalled, queue_size=50)
    total = 500
    for k in range(total):          # would hang here if write() waited for the writer
        recorder.write('/axis_c/transmission_error', k, Float64(data=float(k)))
    assert recorder.dropped >= total - 51
    release.set()
    recorder.close()
    recorder.write('/axis_c/transmission_error', total, Float64(data=0.0))   # after close
    assert recorder.written + recorder.dropped == total + 1
    status: dict = {}
    values = [t for _, _, t, _ in iter_messages(next((tmp_path / 'bag').glob('*.mcap')), status)]
    assert values == sorted(values) and len(values) == recorder.written
    assert status.get('truncated') is None


def indexed_messages(mcap_file: Path) -> int:
    """How many message index entries the file has, each checked (by mcap's stream
    reader, in file order) to follow its chunk and point at a message of its channel at
    its log time."""
    from mcap.records import Chunk, MessageIndex
    from mcap.stream_reader import StreamReader, breakup_chunk
    with open(mcap_file, 'rb') as stream:
        records = list(StreamReader(stream, emit_chunks=True, validate_crcs=True).records)
    messages: dict = {}
    seen = 0
    for record in records:
        if isinstance(record, Chunk):
            messages, offset = {}, 0
            for message in breakup_chunk(record, validate_crc=True):
                messages[offset] = message
                offset += 9 + 22 + len(message.data)
        elif isinstance(record, MessageIndex):
            for log_time, offset in record.records:
                assert messages[offset].log_time == log_time
                assert messages[offset].channel_id == record.channel_id
                seen += 1
    return seen


def test_runs_of_ticks_read_back_like_single_messages(tmp_path: Path) -> None:
    """The writer thread writes a run of one group's bytes messages (the node's ticks one
    after the other) as NumPy columns, anything else message by message. Mixed on
    purpose: a topic twice in the group, message objects between the ticks, a tick
    whose joint_states has another size, chunks that end inside runs. The writer is
    held until every tick is queued, so it meets them as one long run. mcap's reader
    (CRCs, file order, sequence numbers, message indexes) and rosbags read back exactly
    what was handed over, in order."""
    release = threading.Event()

    def held(msg: object) -> bytes:
        release.wait()
        return serialize_message(msg)

    topics = [TOPICS[0], TOPICS[1], TOPICS[3]]
    js, te, clock = (t.name for t in topics)
    recorder = RunRecorder(tmp_path / 'bag', topics, held, chunk_size=4096)
    group = recorder.group([clock, js, te, te])
    handed: list[tuple[str, int, bytes]] = []
    for k in range(3000):
        t = 1_000_000 * k
        stamp = Time(sec=t // 10**9, nanosec=t % 10**9)
        if k % 700 == 0:                   # an object: the writer serializes it
            recorder.write(te, t, Float64(data=float(k)))
            handed.append((te, t, serialize_message(Float64(data=float(k)))))
        names = ['table'] if k == 2345 else ['pinion_1', 'table', 'pinion_3']
        tick = [serialize_message(Clock(clock=stamp)),
                serialize_message(JointState(header=Header(stamp=stamp), name=names,
                                             position=[k * 0.5] * len(names),
                                             velocity=[-k * 0.5] * len(names),
                                             effort=[1.0] * len(names))),
                serialize_message(Float64(data=k * 0.25)),
                serialize_message(Float64(data=-k * 0.25))]
        recorder.write_group(group, t, tick)
        handed.extend(zip(group.topics, [t] * 4, tick, strict=True))
    release.set()
    recorder.close()
    assert (recorder.written, recorder.dropped, recorder.error) == (len(handed), 0, None)
    sequence: dict[str, int] = {}
    expected = []
    for topic, t, data in handed:
        expected.append((topic, t, sequence.setdefault(topic, 0), data))
        sequence[topic] += 1
    mcap_file, = (tmp_path / 'bag').glob('*.mcap')
    with open(mcap_file, 'rb') as stream:
        reader = make_reader(stream, validate_crcs=True)
        read = [(channel.topic, message.log_time, message.sequence, bytes(message.data))
                for _, channel, message in reader.iter_messages(log_time_order=False)]
        summary = reader.get_summary()
    assert read == expected
    assert len(summary.chunk_indexes) > 10
    assert indexed_messages(mcap_file) == len(handed)
    with Reader(tmp_path / 'bag') as reader:
        assert [(c.topic, t, bytes(raw)) for c, t, raw in reader.messages()] == \
            sorted(handed, key=lambda h: h[1])


def test_write_group_keeps_order_and_counts_whole_batches(tmp_path: Path) -> None:
    """Groups and single writes interleaved come back from the file in the order they
    were handed over (mcap's own reader, file order); a group's messages the bounded queue
    cannot take are dropped whole and counted; a group with an undeclared topic is
    refused when it is made, and messages that do not fit the group are refused."""
    release = threading.Event()

    def held(msg: object) -> bytes:
        release.wait()
        return serialize_message(msg)

    topics = TOPICS[:2]
    names = [t.name for t in topics]
    recorder = RunRecorder(tmp_path / 'bag', topics, held, queue_size=10)
    with pytest.raises(ValueError, match='not declared'):
        recorder.group([names[1], '/nope'])
    group = recorder.group([names[1], names[0], names[1]])
    with pytest.raises(ValueError, match='2 messages for the 3 topics'):
        recorder.write_group(group, 0, [Float64(data=-1.0), Float64(data=-2.0)])
    handed: list[tuple[str, int, float]] = []
    for k in range(12):                 # batches of 3, single writes between them
        if k % 2:
            recorder.write(names[1], k, Float64(data=float(k)))
            handed.append((names[1], k, float(k)))
        else:
            batch = [(names[1], k, Float64(data=float(k) + 0.5)),
                     (names[0], k, JointState(name=['table'], position=[float(k)])),
                     (names[1], k, Float64(data=float(k) + 0.25))]
            recorder.write_group(group, k, [msg for _, _, msg in batch])
            handed.extend((topic, t, msg.data if topic == names[1] else msg.position[0])
                          for topic, t, msg in batch)
    release.set()
    recorder.close()
    mcap_file, = (tmp_path / 'bag').glob('*.mcap')
    with open(mcap_file, 'rb') as stream:
        read = [(channel.topic, message.log_time,
                 obj.data if channel.topic == names[1] else obj.position[0])
                for _, channel, message, obj in make_reader(
                    stream, decoder_factories=[DecoderFactory()]).iter_decoded_messages(
                        log_time_order=False)]
    assert recorder.error is None
    assert recorder.written == len(read) and recorder.written + recorder.dropped == len(handed)
    # The writer is held on the first message until every write was made: at most the
    # bound (10 messages) was accepted, at least the first batch and the write after it.
    assert 4 <= recorder.written <= 10
    # What was written is what was handed over, in order, batches never split.
    position = {m: k for k, m in enumerate(handed)}
    at = [position[m] for m in read]
    assert at == sorted(at)
    batches = [handed[k:k + 3] for k in range(0, len(handed), 4)]
    for batch in batches:
        assert sum(m in read for m in batch) in (0, 3)


def test_a_producer_that_may_wait_loses_nothing(tmp_path: Path, monkeypatch) -> None:
    """write_group(lossless=True), as the node flat out writes: a queue of 40 messages and
    5000 ticks written as fast as the loop goes. The producer waits for the writer to
    make room instead of dropping: every message is in the bag, in order."""
    from screwgear_ros.bag import recorder as recording
    monkeypatch.setattr(recording, 'ROOM_TIMEOUT', 60.0)    # a margin, not a measurement
    topic = TOPICS[1].name
    recorder = RunRecorder(tmp_path / 'bag', TOPICS[1:2], serialize_message, queue_size=40)
    group = recorder.group([topic, topic])
    data = [serialize_message(Float64(data=float(k))) for k in range(10000)]
    for k in range(5000):
        recorder.write_group(group, k, data[2 * k:2 * k + 2], lossless=True)
    recorder.close()
    assert (recorder.written, recorder.dropped, recorder.error) == (10000, 0, None)
    mcap_file, = (tmp_path / 'bag').glob('*.mcap')
    with open(mcap_file, 'rb') as stream:
        read = [(message.log_time, bytes(message.data)) for _, _, message in
                make_reader(stream, validate_crcs=True).iter_messages(log_time_order=False)]
    assert read == [(k // 2, d) for k, d in enumerate(data)]


def test_bytes_are_written_as_they_are(tmp_path: Path) -> None:
    """A message handed over as bytes is its CDR: the serializer is never asked, and a
    second reader decodes exactly those bytes."""
    def refuse(msg: object) -> bytes:
        raise AssertionError(f'serialize called for {msg!r}')

    topic = TOPICS[1].name
    data = [serialize_message(Float64(data=v)) for v in (0.5, -1e300, 7.25)]
    recorder = RunRecorder(tmp_path / 'bag', TOPICS[1:2], refuse)
    recorder.write(topic, 0, data[0])
    recorder.write_group(recorder.group([topic, topic]), 1, data[1:])
    recorder.close()
    assert (recorder.written, recorder.dropped, recorder.error) == (3, 0, None)
    store = get_typestore(Stores.ROS2_JAZZY)
    with Reader(tmp_path / 'bag') as reader:
        read = [(t, bytes(raw), store.deserialize_cdr(raw, c.msgtype).data)
                for c, t, raw in reader.messages()]
    assert read == [(0, data[0], 0.5), (1, data[1], -1e300), (1, data[2], 7.25)]


def test_a_message_that_fails_to_serialize_keeps_what_came_before(tmp_path: Path) -> None:
    """The first write error stops the writing: the messages before it are in the bag,
    which is finalized and reads back; that message and every later one are counted as
    dropped; ``error`` says what went wrong."""
    def fussy(msg: object) -> bytes:
        if isinstance(msg, Float64) and msg.data < 0.0:
            raise ValueError('negative data refused')
        return serialize_message(msg)

    topic = TOPICS[1].name
    recorder = RunRecorder(tmp_path / 'bag', TOPICS[:2], fussy)
    for k in range(5):
        recorder.write(topic, k, Float64(data=float(k)))
    recorder.write_group(recorder.group([topic] * 3), 5,
                         [Float64(data=5.0), Float64(data=-6.0), Float64(data=7.0)])
    recorder.write(topic, 8, Float64(data=8.0))
    recorder.close()
    assert (recorder.written, recorder.dropped) == (6, 3)
    assert recorder.error == 'ValueError: negative data refused'
    store = get_typestore(Stores.ROS2_JAZZY)
    with Reader(tmp_path / 'bag') as reader:
        assert [c.msgcount for c in reader.connections if c.topic == topic] == [6]
        read = [(t, store.deserialize_cdr(raw, c.msgtype).data)
                for c, t, raw in reader.messages()]
    assert read == [(k, float(k)) for k in range(6)]


def test_a_write_racing_close_is_written_or_counted(tmp_path: Path) -> None:
    """The race: write() has checked that the recorder is open, close() then runs to the
    end, and only then does write() queue its message, behind the writer's stop mark.
    The queue's put is held open here until close() has finished (or 0.5 s, when close
    rightly waits for the write): the message must be in the bag or counted as dropped."""
    recorder = RunRecorder(tmp_path / 'bag', TOPICS[1:2], serialize_message)
    in_put, closed = threading.Event(), threading.Event()

    class SlowPut:
        def __init__(self, queue: object) -> None:
            self.queue = queue

        def __getattr__(self, name: str) -> object:
            return getattr(self.queue, name)

        def put(self, item: object) -> None:
            if isinstance(item, tuple) and not in_put.is_set():   # the message, not the stop mark
                in_put.set()
                closed.wait(0.5)
            self.queue.put(item)

    recorder._queue = SlowPut(recorder._queue)   # type: ignore[assignment]
    writer = threading.Thread(target=recorder.write,
                              args=('/axis_c/transmission_error', 0, Float64(data=1.0)))
    writer.start()
    assert in_put.wait(5.0)
    closer = threading.Thread(target=lambda: (recorder.close(), closed.set()))
    closer.start()
    writer.join(5.0)
    closer.join(5.0)
    assert not writer.is_alive() and not closer.is_alive()
    assert recorder.written + recorder.dropped == 1
    mcap_file, = (tmp_path / 'bag').glob('*.mcap')
    assert sum(1 for _ in iter_messages(mcap_file, {})) == recorder.written


KILLED_WRITER = textwrap.dedent('''
    import sys, time
    from rclpy.serialization import serialize_message
    from std_msgs.msg import Float64
    from screwgear_ros.bag import RunRecorder, TopicSpec
    rec = RunRecorder(sys.argv[1], [TopicSpec('/transmission_error', 'std_msgs/msg/Float64')],
                      serialize_message, chunk_size=4096, flush_period=0.1)
    k = 0
    def burst(n):
        global k
        for _ in range(n):
            rec.write('/transmission_error', k * 50_000, Float64(data=float(k)))
            k += 1
    burst(3000)
    while rec.written < 3000:
        time.sleep(0.01)
    time.sleep(0.5)                       # several flush periods: all 3000 are on disk
    print('flushed', k, flush=True)
    while True:
        burst(20)
        print('written', rec.written, flush=True)
        time.sleep(0.002)
''')


@pytest.mark.ros
def test_kill_9_leaves_every_flushed_chunk_readable(tmp_path: Path) -> None:
    bag = tmp_path / 'bag'
    proc = subprocess.Popen([sys.executable, '-c', KILLED_WRITER, str(bag)],
                            stdout=subprocess.PIPE, text=True)
    written = 0
    try:
        assert proc.stdout.readline().split() == ['flushed', '3000']
        deadline = time.monotonic() + 0.5
        while time.monotonic() < deadline:
            written = int(proc.stdout.readline().split()[1])
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    assert proc.returncode == -signal.SIGKILL
    assert (bag / 'metadata.yaml').is_file()          # still a rosbag2 directory
    status: dict = {}
    mcap_file, = bag.glob('*.mcap')
    values = [(t, topic) for topic, _, t, _ in iter_messages(mcap_file, status)]
    assert status['truncated'] and 'not closed' in status['truncated']
    # Exactly a prefix of what was written, in order, with everything flushed before.
    assert [t for t, _ in values] == [k * 50_000 for k in range(len(values))]
    assert len(values) >= 3000
    lost = written - len(values)
    print(f'kill -9: {len(values)} messages readable, {lost} of the {written} handed to the '
          f'writer lost ({os.path.getsize(mcap_file)} bytes on disk)')
    with pytest.raises(BagError) as err:
        read_run(bag)
    assert isinstance(err.value, (TruncatedBag, NoParameters))
