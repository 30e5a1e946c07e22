"""A disk that fills while recording: the recording stops at the fault, says so once,
and leaves a bag that every reader reads back up to the fault, with counts that match.

Two ways to fill the disk: a small tmpfs under a real table_sim process (needs the
right to mount; skipped with the reason where it is missing), and a file wrapper that
behaves as a small disk (the operating system's own partial write, then ENOSPC) under
an in-process recorder, with the fault landing at seeded places.
"""

from __future__ import annotations

import errno
import io
import os
import random
import re
import signal
import subprocess
import time
from pathlib import Path

import pytest
import yaml
from mcap.reader import make_reader
from mcap_stream import iter_messages
from rclpy.serialization import serialize_message
from ros_procs import STARTUP_TIMEOUT, start_process
from rosbags.rosbag2 import Reader
from std_msgs.msg import Float64, String

from screwgear_ros.bag.reader import read_run
from screwgear_ros.bag.recorder import RESERVE_NAME, RunRecorder, TopicSpec
from screwgear_ros.cli.table_sim import EXIT_RECORDING_FAILED

TOPICS = [TopicSpec('/axis_c/text', 'std_msgs/msg/String'),
          TopicSpec('/axis_c/transmission_error', 'std_msgs/msg/Float64')]


class SmallDisk:
    """Files on a disk of ``capacity`` bytes: a write beyond it writes what fits (as
    write(2) does) and the next one fails with ENOSPC; truncating frees the bytes."""

    def __init__(self, capacity: int) -> None:
        self.capacity = capacity
        self.used = 0

    def open(self, path: Path) -> DiskFile:
        return DiskFile(self, path)


class DiskFile(io.RawIOBase):
    def __init__(self, disk: SmallDisk, path: Path) -> None:
        self._disk = disk
        self._file = open(path, 'xb', buffering=0)  # noqa: SIM115 - closed by close()

    def writable(self) -> bool:
        return True

    def write(self, data: bytes) -> int:
        free = self._disk.capacity - self._disk.used
        if free <= 0:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        n = self._file.write(memoryview(data)[:free])
        self._disk.used += n
        return n

    def truncate(self, size: int | None = None) -> int:
        old = os.fstat(self._file.fileno()).st_size
        size = self._file.tell() if size is None else size
        self._file.truncate(size)
        self._disk.used -= max(0, old - size)
        return size

    def seek(self, offset: int, whence: int = 0) -> int:
        return self._file.seek(offset, whence)

    def close(self) -> None:
        self._file.close()
        super().close()


def bag_counts(bag: Path) -> tuple[int, int, int, list]:
    """(rosbags' count, metadata.yaml's count, mcap summary's count, the messages rosbags
    reads: (topic, log time, raw))."""
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    mcap_file, = bag.glob('*.mcap')
    with open(mcap_file, 'rb') as stream:
        summary = make_reader(stream).get_summary()
    with Reader(bag) as reader:
        read = [(c.topic, t, bytes(raw)) for c, t, raw in reader.messages()]
        return reader.message_count, info['message_count'], \
            summary.statistics.message_count, read


@pytest.mark.parametrize('seed', range(8))
def test_a_full_disk_stops_the_recording_with_a_bag_that_reads_back(
        tmp_path: Path, seed: int) -> None:
    """Seeded capacities put the fault inside a chunk, at a chunk's end, while the
    reserve grows, or at the close; each time the bag reads back with rosbags, mcap and
    the project's reader, exactly a prefix of what was handed over, and every count
    (rosbags, metadata.yaml, the MCAP statistics, ``written``) is what was read."""
    rng = random.Random(seed)
    capacity = rng.randrange(150_000, 600_000)
    disk = SmallDisk(capacity)
    said: list[str] = []
    bag = tmp_path / 'bag'
    recorder = RunRecorder(bag, TOPICS, serialize_message, chunk_size=4096,
                           compression=False, batch_period=0.001, on_error=said.append,
                           open_file=disk.open)
    handed = []
    for k in range(4000):
        text = serialize_message(String(data=f'{k}:' + 'x' * rng.randrange(0, 200)))
        value = serialize_message(Float64(data=float(k)))
        recorder.write_group(recorder.group([t.name for t in TOPICS]), k, [text, value],
                             lossless=True)
        handed += [(TOPICS[0].name, k, text), (TOPICS[1].name, k, value)]
    recorder.close()
    assert recorder.error is not None and 'No space left on device' in recorder.error
    assert len(said) == 1 and said[0].startswith('recording failed: OSError')
    assert 'reads back up to the fault' in said[0], said[0]
    assert sorted(p.name for p in bag.iterdir()) == ['bag_0.mcap', 'metadata.yaml']
    rosbags_count, yaml_count, mcap_count, read = bag_counts(bag)
    assert rosbags_count == yaml_count == mcap_count == recorder.written == len(read) > 0
    assert read == handed[:len(read)]
    assert recorder.written + recorder.dropped == len(handed)
    assert f'keeps the {len(read)} messages' in said[0]
    status: dict = {}
    assert sum(1 for _ in iter_messages(next(bag.glob('*.mcap')), status)) == len(read)
    assert status.get('truncated') is None


class TakenDisk(SmallDisk):
    """A disk whose room, once full, another writer takes as soon as it is freed."""

    def open(self, path: Path) -> DiskFile:
        disk = self

        class Taken(DiskFile):
            def write(self, data: bytes) -> int:
                try:
                    return super().write(data)
                except OSError:
                    disk.capacity = 0
                    raise
        return Taken(self, path)


def test_a_disk_that_stays_full_leaves_the_bag_readable_as_truncated(tmp_path: Path) -> None:
    """Even the reserve's room is gone when the end is written: the MCAP file ends at
    its last whole chunk, metadata.yaml counts what it holds, nothing is left behind,
    and the one line says the bag is readable as a truncated one."""
    said: list[str] = []
    bag = tmp_path / 'bag'
    recorder = RunRecorder(bag, TOPICS[1:], serialize_message, chunk_size=4096,
                           compression=False, on_error=said.append,
                           open_file=TakenDisk(200_000).open)
    for k in range(20_000):
        recorder.write(TOPICS[1].name, k, serialize_message(Float64(data=float(k))))
    recorder.close()
    assert len(said) == 1 and 'readable as a truncated bag' in said[0], said
    assert sorted(p.name for p in bag.iterdir()) == ['bag_0.mcap', 'metadata.yaml']
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    status: dict = {}
    read = [t for _, _, t, _ in iter_messages(next(bag.glob('*.mcap')), status)]
    assert status['truncated']
    assert read == list(range(len(read))) and len(read) == recorder.written \
        == info['message_count'] > 0
    assert recorder.written + recorder.dropped == 20_000


def test_the_reserve_is_gone_after_a_normal_close(tmp_path: Path) -> None:
    recorder = RunRecorder(tmp_path / 'bag', TOPICS, serialize_message)
    assert (tmp_path / 'bag' / RESERVE_NAME).stat().st_size > 0
    recorder.write(TOPICS[1].name, 0, Float64(data=1.0))
    recorder.close()
    assert sorted(p.name for p in (tmp_path / 'bag').iterdir()) == ['bag_0.mcap',
                                                                    'metadata.yaml']
    assert recorder.error is None and bag_counts(tmp_path / 'bag')[:3] == (1, 1, 1)


@pytest.fixture
def tmpfs(tmp_path: Path):
    """A 4 MiB tmpfs, or a skip saying why it cannot be mounted here."""
    mount = tmp_path / 'disk'
    mount.mkdir()
    result = subprocess.run(['mount', '-t', 'tmpfs', '-o', 'size=4m', 'tmpfs', str(mount)],
                            capture_output=True, text=True, check=False)
    if result.returncode != 0:
        pytest.skip(f'cannot mount a tmpfs here: {result.stderr.strip() or result.returncode}')
    try:
        yield mount
    finally:
        subprocess.run(['umount', '-l', str(mount)], check=False)


@pytest.mark.ros
def test_a_node_recording_onto_a_full_disk(tmpfs: Path, tmp_path: Path) -> None:
    """table_sim flat out onto a 4 MiB tmpfs: one ERROR line when the disk fills, the
    simulation goes on, SIGINT ends it with EXIT_RECORDING_FAILED and no traceback, and
    the bag reads back with rosbags, mcap and read_run, with the counts the log gave."""
    bag = tmpfs / 'run'
    node = start_process('table_sim', params={'record': str(bag), 'real_time_factor': 0.0},
                         workdir=tmp_path / 'node')
    try:
        deadline = time.monotonic() + STARTUP_TIMEOUT + 60.0
        while 'recording failed' not in node.output()[1] and node.alive():
            assert time.monotonic() < deadline, node.output()[1][-3000:]
            time.sleep(0.2)
        time.sleep(1.0)
        assert node.alive(), node.output()[1][-3000:]
        code, _ = node.stop(signal.SIGINT, timeout=30.0)
    finally:
        node.kill()
    stdout, stderr = node.output()
    log = stdout + stderr
    assert code == EXIT_RECORDING_FAILED, log[-3000:]
    assert 'Traceback' not in log, log[-3000:]
    errors = [line for line in log.splitlines() if '[ERROR]' in line]
    assert len(errors) == 1 and 'No space left on device' in errors[0], errors
    assert sorted(p.name for p in bag.iterdir()) == ['metadata.yaml', 'run_0.mcap']
    written = int(re.search(r'recording closed: (\d+) messages written', log).group(1))
    kept = int(re.search(r'keeps the (\d+) messages', errors[0]).group(1))
    rosbags_count, yaml_count, mcap_count, read = bag_counts(bag)
    print(f'disk full: {rosbags_count} messages read back, '
          f'{os.path.getsize(next(bag.glob("*.mcap")))} bytes of MCAP')
    assert rosbags_count == yaml_count == mcap_count == written == kept == len(read) > 0
    run = read_run(bag)
    assert run.truncated is None and len(run.joint_states) > 0
