"""read_run's bulk reading, against two other readers of the same bytes.

read_run walks the MCAP records itself and decodes joint_states, transmission_error and
mesh_state with NumPy on the node's fixed layout (:class:`screwgear_ros.bag.cdr.Template`).
Here that is held against ``rosbags``' CDR decoder on every message of the checked-in bags,
against ``mcap``'s own stream reader (``iter_messages``) on what a cut or damaged file still
holds, and messages that are not in the node's layout (another frame_id, other joint
order, a big-endian encoding) are shown to be decoded by rosbags instead, correctly.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from bag_runs import BAGS, copy_bag, damaged_copy
from mcap.reader import make_reader
from mcap_stream import iter_messages
from paths import DATA
from rosbags.typesys import Stores, get_typestore

from screwgear_ros.bag.bulk_decode import _bulk
from screwgear_ros.bag.cdr import float64_template, joint_state_template
from screwgear_ros.bag.errors import BagError, NotABag, TruncatedBag
from screwgear_ros.bag.mcap_scan import OUTPUT_TOPICS, scan
from screwgear_ros.bag.reader import read_run

STORE = get_typestore(Stores.ROS2_JAZZY)


def _messages(bag: Path, rel: str) -> list[tuple[int, bytes]]:
    mcap_file, = bag.glob('*.mcap')
    return [(t, raw) for topic, _, t, raw in iter_messages(mcap_file, {})
            if topic.rsplit('/', 1)[1] == rel]


def _footer(bag: Path):
    """The footer of a bag's MCAP file, by mcap's own reader."""
    from mcap.records import Footer
    from mcap.stream_reader import StreamReader
    with open(next(bag.glob('*.mcap')), 'rb') as stream:
        return next(r for r in StreamReader(stream).records if isinstance(r, Footer))


def _refuse(raw: bytes):
    raise AssertionError('a message of the node was not read in bulk')


@pytest.mark.parametrize('name', BAGS)
def test_every_node_message_is_read_in_bulk_as_rosbags_decodes_it(name: str) -> None:
    """All of the node's messages fit the template (none falls back), and the values and
    stamps read in place are rosbags' for the same bytes, bit for bit."""
    run = read_run(DATA / name)
    joints = list(run.parameters.settings.joint_names)
    raws = _messages(DATA / name, 'joint_states')
    rows = np.array([np.frombuffer(raw, np.uint8) for _, raw in raws])
    values, stamps = _bulk([rows], joint_state_template(joints), 9, _refuse)
    decoded = [STORE.deserialize_cdr(raw, OUTPUT_TOPICS['joint_states']) for _, raw in raws]
    assert all(list(m.name) == joints for m in decoded)
    assert np.array_equal(values, [[*m.position, *m.velocity, *m.effort] for m in decoded])
    assert stamps.tolist() == [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec
                               for m in decoded]
    assert np.array_equal(run.joint_states.values, values)

    raws = _messages(DATA / name, 'transmission_error')
    rows = np.array([np.frombuffer(raw, np.uint8) for _, raw in raws])
    values, _ = _bulk([rows], float64_template(), 1, _refuse)
    expected = [STORE.deserialize_cdr(raw, OUTPUT_TOPICS['transmission_error']).data
                for _, raw in raws]
    assert values[:, 0].tolist() == expected
    assert run.transmission_error.values[:, 0].tolist() == expected

    raws = _messages(DATA / name, 'mesh_state')
    decoded = [STORE.deserialize_cdr(raw, OUTPUT_TOPICS['mesh_state']) for _, raw in raws]
    rows = np.array([np.frombuffer(raw, np.uint8) for _, raw in raws])
    values, _ = _bulk([rows], joint_state_template(list(decoded[0].name)), 6, _refuse)
    assert np.array_equal(values, [[*m.position, *m.velocity, *m.effort] for m in decoded])
    assert np.array_equal(run.mesh_state.values, values)


def test_messages_in_another_layout_are_decoded_by_rosbags(tmp_path: Path) -> None:
    """Three joint_states rewritten as another publisher might: a frame_id, the joints in
    another order, big-endian CDR. Their bytes no longer fit the template; read_run
    decodes them with rosbags (reordering the joints), and every value is still right."""
    targets = {10**9: 'frame', 2 * 10**9: 'order', 3 * 10**9: 'big'}

    def rewrite(topic, msgtype, log_time, raw):
        if topic.endswith('/joint_states') and log_time in targets:
            msg = STORE.deserialize_cdr(raw, msgtype)
            how = targets[log_time]
            if how == 'frame':
                msg.header.frame_id = 'table'
            elif how == 'order':
                order = [2, 0, 1]
                msg.name = [msg.name[i] for i in order]
                msg.position, msg.velocity, msg.effort = (
                    a[order].copy() for a in (msg.position, msg.velocity, msg.effort))
            if how == 'big':
                raw = bytes(STORE.serialize_cdr(msg, msgtype, little_endian=False))
            else:
                raw = bytes(STORE.serialize_cdr(msg, msgtype))
        return log_time, raw
    copy_bag(DATA / 'steady_drive', tmp_path / 'edited', rewrite)
    original, edited = read_run(DATA / 'steady_drive'), read_run(tmp_path / 'edited')
    assert np.array_equal(original.joint_states.values, edited.joint_states.values)
    assert np.array_equal(original.joint_states.steps, edited.joint_states.steps)
    assert edited.stamp_mismatches == []
    raws = dict(_messages(tmp_path / 'edited', 'joint_states'))
    template = joint_state_template(list(original.parameters.settings.joint_names))
    for t in targets:              # really outside the template's layout: not read in bulk
        with pytest.raises(AssertionError, match='not read in bulk'):
            _bulk([np.frombuffer(raws[t], np.uint8).reshape(1, -1)], template, 9, _refuse)


@pytest.mark.parametrize('fraction', [0.004, 0.1, 0.37, 0.5, 0.83, 0.999])
def test_a_cut_file_reads_what_mcaps_stream_reader_reads(tmp_path: Path, fraction: float) -> None:
    """A killed writer's file: the same messages as mcap's StreamReader yields (up to the
    last whole chunk), and the cut is reported."""
    src = DATA / 'reversals_anti_backlash'
    size = next(src.glob('*.mcap')).stat().st_size
    mcap_file = damaged_copy(src, tmp_path / 'cut', keep=int(size * fraction))
    theirs: dict = {}
    count = sum(1 for _ in iter_messages(mcap_file, theirs))
    ours: dict = {}
    assert scan(mcap_file, ours).count == count
    summary_start = _footer(src).summary_start
    if size * fraction >= summary_start:    # cut in the summary: the data section is whole
        assert 'truncated' not in theirs and 'truncated' not in ours
        assert 'no valid footer' in ours['summary']
        run = read_run(tmp_path / 'cut')
        assert run.message_count == count and not run.truncated and run.summary
        return
    assert theirs['truncated'] and ours['truncated'] and 'not closed' in ours['truncated']
    try:
        run = read_run(tmp_path / 'cut', allow_truncated=True)
    except BagError as exc:
        assert isinstance(exc, TruncatedBag) and count < 20     # not even run_parameters
    else:
        assert run.message_count == count and run.truncated


def test_a_damaged_chunk_ends_the_readable_part(tmp_path: Path) -> None:
    """A byte flipped inside the compressed records of a chunk in the middle: the messages
    of the chunks before it read (as many as mcap's reader finds in the file cut where
    that chunk starts), the damage is reported, read_run refuses without --allow-truncated."""
    src = DATA / 'reversals_anti_backlash'
    with open(next(src.glob('*.mcap')), 'rb') as stream:
        chunks = make_reader(stream).get_summary().chunk_indexes
    middle = chunks[len(chunks) // 2]
    mcap_file = damaged_copy(src, tmp_path / 'bad',
                             flip=middle.chunk_start_offset + middle.chunk_length - 20)
    before = damaged_copy(src, tmp_path / 'before', keep=middle.chunk_start_offset)
    count = sum(1 for _ in iter_messages(before, {}))
    ours: dict = {}
    assert scan(mcap_file, ours).count == count > 0
    assert 'damaged' in ours['truncated']
    with pytest.raises(BagError) as refused:
        read_run(tmp_path / 'bad')
    assert isinstance(refused.value, TruncatedBag)
    assert read_run(tmp_path / 'bad', allow_truncated=True).message_count == count


def test_an_empty_or_foreign_file() -> None:
    """Shorter than the magic: a writer killed at once (truncated); other bytes: not MCAP."""
    import tempfile
    with tempfile.TemporaryDirectory() as tmp:
        empty = Path(tmp) / 'empty.mcap'
        empty.write_bytes(b'')
        status: dict = {}
        assert scan(empty, status).count == 0 and 'not closed' in status['truncated']
        foreign = Path(tmp) / 'foreign.mcap'
        foreign.write_bytes(b'definitely not MCAP data')
        with pytest.raises(BagError) as refused:
            scan(foreign, {})
        assert isinstance(refused.value, NotABag)
