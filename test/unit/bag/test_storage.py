"""Every storage rosbag2 writes reads as the node's MCAP does (bag/storage.py), and what no
reader can open is refused with the reason (exit 2 in the tools, never a traceback).

The bags in another storage are written here by ``rosbags``' rosbag2 writer (a second
library: sqlite3 plain, with zstd file and message compression, and one split across
two files), from the messages of the checked-in MCAP bags as ``mcap`` reads them; the
real rosbag2's own conversions are in test/integration/test_rosbag2_real.py.
"""

from __future__ import annotations

import contextlib
import io
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml
from bag_runs import BAGS
from mcap.reader import make_reader
from paths import DATA
from rosbags.rosbag2 import CompressionFormat, CompressionMode, Writer
from rosbags.typesys import Stores, get_typestore

from screwgear_ros.bag.errors import InvalidBag, NotABag
from screwgear_ros.bag.reader import read_run
from screwgear_ros.bag.storage import locate
from screwgear_ros.cli.check_run import main as check_run_main

STORE = get_typestore(Stores.ROS2_JAZZY)


def rewrite(src: Path, dst: Path, mode: CompressionMode | None = None,
            split: bool = False) -> Path:
    """``src``'s messages (``mcap``'s reader, in file order) into a rosbags sqlite3 bag
    at ``dst`` (two such bags joined in one metadata.yaml with ``split``)."""
    mcap_file, = src.glob('*.mcap')
    with open(mcap_file, 'rb') as stream:
        messages = [(channel.topic, schema.name, message.log_time, message.data)
                    for schema, channel, message in make_reader(stream).iter_messages(
                        log_time_order=False)]
    parts = [messages[:len(messages) // 2], messages[len(messages) // 2:]] if split \
        else [messages]
    documents = []
    for n, part in enumerate(parts):
        path = dst if not split else dst.with_name(f'{dst.name}_part{n}')
        writer = Writer(path, version=9)
        if mode is not None:
            writer.set_compression(mode, CompressionFormat.ZSTD)
        with writer:
            connections = {}
            for topic, msgtype, _, _ in messages:
                if topic not in connections:
                    connections[topic] = writer.add_connection(topic, msgtype, typestore=STORE)
            for topic, _, log_time, data in part:
                writer.write(connections[topic], log_time, data)
        documents.append(path)
    if split:       # one bag of the two files, as rosbag2 lays out a split recording
        dst.mkdir()
        info = yaml.safe_load((documents[0] / 'metadata.yaml').read_text())
        files = []
        for n, path in enumerate(documents):
            db, = path.glob('*.db3')
            shutil.move(db, dst / f'{dst.name}_{n}.db3')
            files.append(f'{dst.name}_{n}.db3')
        info['rosbag2_bagfile_information']['relative_file_paths'] = files
        (dst / 'metadata.yaml').write_text(yaml.safe_dump(info))
    return dst


def same_run(a, b) -> None:
    assert a.parameters == b.parameters
    assert [e for _, e in a.events] == [e for _, e in b.events]
    for name in ('true_joint_states', 'transmission_error', 'mesh_state', 'active_path'):
        sa, sb = getattr(a, name), getattr(b, name)
        assert np.array_equal(sa.steps, sb.steps), name
        assert np.array_equal(sa.values, sb.values), name


@pytest.mark.parametrize(('kind', 'name'), list(zip(['plain', 'file', 'message', 'split'],
                                                     BAGS[::-1], strict=False)))
def test_a_sqlite3_bag_reads_as_the_mcap_it_was_written_from(tmp_path, kind, name):
    mode = {'file': CompressionMode.FILE, 'message': CompressionMode.MESSAGE}.get(kind)
    bag = rewrite(DATA / name, tmp_path / f'{name}_{kind}', mode, split=kind == 'split')
    assert not locate(bag).fast
    same_run(read_run(bag), read_run(DATA / name))


def check(path: Path) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = check_run_main([str(path), '--no-progress', '--serial'])
    return code, err.getvalue()


def _edit_metadata(bag: Path, **changes: object) -> None:
    meta = bag / 'metadata.yaml'
    info = yaml.safe_load(meta.read_text())
    info['rosbag2_bagfile_information'].update(changes)
    meta.write_text(yaml.safe_dump(info))


@pytest.mark.parametrize(('changes', 'why', 'error'), [
    ({'storage_identifier': 'hdf5'}, "storage 'hdf5' is not one of rosbag2's", NotABag),
    ({'compression_mode': 'file', 'compression_format': 'lz4'},
     "compressed with 'lz4', and no decompressor", NotABag),
    ({'relative_file_paths': ['gone_0.mcap']}, 'gone_0.mcap which is not there', NotABag),
])
def test_what_no_reader_opens_is_refused_with_the_reason(tmp_path, changes, why, error):
    bag = tmp_path / 'bag'
    shutil.copytree(DATA / 'steady_drive', bag)
    _edit_metadata(bag, **changes)
    with pytest.raises(error, match=why.replace('(', r'\(')):
        read_run(bag)
    code, err = check(bag)
    assert code == 2 and why in err and 'Traceback' not in err, err


def test_a_damaged_sqlite3_bag_is_refused_with_the_reason(tmp_path):
    bag = rewrite(DATA / 'steady_drive', tmp_path / 'bag')
    db, = bag.glob('*.db3')
    db.write_bytes(b'not a database' * 100)
    with pytest.raises(InvalidBag, match='sqlite3 storage cannot be read'):
        read_run(bag)
    zstd_bag = rewrite(DATA / 'steady_drive', tmp_path / 'zbag', CompressionMode.FILE)
    zst, = zstd_bag.glob('*.zstd')
    zst.write_bytes(zst.read_bytes()[:len(zst.read_bytes()) // 2])
    code, err = check(zstd_bag)
    assert code == 2 and 'file compression) cannot be read' in err, err
    assert 'Traceback' not in err


def test_a_directory_without_metadata_reads_its_one_file_and_refuses_two(tmp_path):
    bag = tmp_path / 'bag'
    shutil.copytree(DATA / 'steady_drive', bag)
    (bag / 'metadata.yaml').unlink()
    assert read_run(bag).message_count == read_run(DATA / 'steady_drive').message_count
    shutil.copy(next(bag.glob('*.mcap')), bag / 'other_0.mcap')
    with pytest.raises(InvalidBag, match='ros2 bag reindex'):
        read_run(bag)
