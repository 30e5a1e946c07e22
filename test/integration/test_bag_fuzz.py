"""Seeded, bounded bag corruption: check_run and plot_run on damaged copies of the
checked-in bags never end in a traceback, exit with a documented code, give the true
reason, and check_run never says PASS unless the data section is intact and samples
were compared.

What "intact" means is decided by a second reader: ``mcap``'s own stream reader (chunk
CRCs checked) reads the copy's data section as it reads the original's, message for
message (topic, type, log time, bytes), to its end, or, when only the readable part is
asked for (--allow-truncated), as far as it reads.
Each case is one seeded corruption: bit flips in the data section, the summary
section or the footer, a cut at a random offset, metadata.yaml replaced by garbage
(invalid UTF-8 among it), a topic's messages deleted, a topic renamed or declared
with another type, one message's CDR cut short, a run_parameters value made extreme
or of the wrong type. Most cases call the tools' main()
in-process with their output captured; a few run the installed console scripts.
"""

from __future__ import annotations

import contextlib
import io
import random
import shutil
import struct
from pathlib import Path

import pytest
import yaml
from bag_runs import BAGS, installed, retyped_copy
from mcap.records import Channel, DataEnd, Footer, Message, Schema
from mcap.stream_reader import StreamReader
from paths import DATA

from screwgear_ros.cli import check_run, plot_run

SEED = 20
CHECK_CODES = {0, 1, 2}
PLOT_CODES = {0, 2}


def messages(mcap_file: Path) -> tuple[list[tuple[str, str, int, bytes]], bool]:
    """(topic, type, log time, bytes) of the messages of the data section by mcap's stream
    reader (chunk CRCs checked), up to where it cannot read on; and whether it read the
    whole data section."""
    schemas: dict[int, str] = {}
    channels: dict[int, tuple[str, str]] = {}
    out = []
    try:
        with open(mcap_file, 'rb') as stream:
            for record in StreamReader(stream, validate_crcs=True,
                                       record_size_limit=1 << 28).records:
                if isinstance(record, Schema):
                    schemas[record.id] = record.name
                elif isinstance(record, Channel):
                    channels[record.id] = (record.topic, schemas.get(record.schema_id, ''))
                elif isinstance(record, Message):
                    out.append((*channels[record.channel_id], record.log_time, record.data))
                elif isinstance(record, (DataEnd, Footer)):
                    return out, True
    except Exception:  # noqa: BLE001, S110 - where the second reader gives up: the end of it
        pass
    return out, False


def intact(src: Path, dst: Path, allow_truncated: bool) -> bool:
    """Every message read from the copy is the original's, in order, and the copy reads
    to the end of its data section (or only its readable part is asked for)."""
    copy_file = next(dst.glob('*.mcap'), None)
    if copy_file is None:
        return False
    original, _ = messages(next(src.glob('*.mcap')))
    read, whole = messages(copy_file)
    return read == original[:len(read)] and (whole or allow_truncated)




def _summary_start(mcap_file: Path) -> int:
    data = mcap_file.read_bytes()
    _, _, start, _, _ = struct.unpack_from('<BQQQI', data, len(data) - 8 - 29)
    return start


def _first_chunk(data: bytes | bytearray) -> int:
    """Offset of the first Chunk record of an MCAP file."""
    at = 8
    while data[at] != 0x06:
        at += 9 + struct.unpack_from('<Q', data, at + 1)[0]
    return at


def _bad_parameters(src: Path, dst: Path, rng: random.Random) -> str:
    """One value of every run_parameters message replaced by an extreme or a wrong type."""
    from rosbags.typesys import Stores, get_typestore
    store = get_typestore(Stores.ROS2_JAZZY)
    value = rng.choice([float('inf'), float('nan'), -1e300, 0, 'text', [1.0, 2.0], None])
    chosen: list[str] = []

    def edit(topic: str, raw: bytes) -> bytes:
        if topic != 'run_parameters':
            return raw
        msg = store.deserialize_cdr(raw, 'std_msgs/msg/String')
        document = yaml.safe_load(msg.data)
        if not chosen:
            chosen.append(rng.choice(sorted(document)))
            chosen.append(document[chosen[0]] == value or chosen[0] == 'package_version')
        document[chosen[0]] = value
        return bytes(store.serialize_cdr(store.types['std_msgs/msg/String'](
            data=yaml.safe_dump(document)), 'std_msgs/msg/String'))
    retyped_copy(src, dst, edit=edit)
    return f'run_parameters {chosen[0]} = {value!r}' + (NO_CHANGE if chosen[1] else '')


#: What :func:`corrupt` adds when the bag's physics did not change (a value set to what
#: it was, or the package version): its messages differ, but a PASS is right.
NO_CHANGE = ' (no physical change)'


def corrupt(kind: str, src: Path, dst: Path, rng: random.Random) -> str:
    """Write a corrupted copy of ``src`` at ``dst``; returns what was done."""
    if kind in ('data_flip', 'summary_flip', 'footer_flip', 'cut'):
        shutil.copytree(src, dst)
        mcap_file, = dst.glob('*.mcap')
        data = bytearray(mcap_file.read_bytes())
        start = _summary_start(mcap_file)
        if kind == 'cut':
            at = rng.randrange(0, len(data))
            mcap_file.write_bytes(bytes(data[:at]))
            return f'cut at {at} of {len(data)}'
        # data flips from the first chunk on: the records before it (header, the rosbag2
        # metadata record) no tool reads, and the oracle (mcap's reader) stops at them
        first_chunk = _first_chunk(data)
        lo, hi = {'data_flip': (first_chunk, start), 'summary_flip': (start, len(data) - 37),
                  'footer_flip': (len(data) - 37, len(data))}[kind]
        flips = [rng.randrange(lo, hi) for _ in range(rng.choice((1, 2)))]
        for at in flips:
            data[at] ^= 1 << rng.randrange(8)
        mcap_file.write_bytes(bytes(data))
        return f'{kind} at {flips}'
    if kind == 'metadata':
        shutil.copytree(src, dst)
        garbage = rng.choice([
            bytes(rng.randrange(256) for _ in range(200)),
            b'rosbag2_bagfile_information:\n  storage_identifier: \xff\xfe mcap\n',
            b'rosbag2_bagfile_information: [1, 2, 3]\n',
            (b'rosbag2_bagfile_information:\n  storage_identifier: mcap\n'
            b'  relative_file_paths: 7\n'),
            (dst / 'metadata.yaml').read_bytes()[:rng.randrange(1, 400)] + b'\x80\x81',
        ])
        (dst / 'metadata.yaml').write_bytes(garbage)
        return f'metadata.yaml garbage {garbage[:24]!r}'
    if kind == 'parameters':
        return _bad_parameters(src, dst, rng)
    rel = rng.choice(['joint_states', 'transmission_error', 'mesh_state', 'active_path',
                      'run_parameters', 'cmd_torque'])
    if kind == 'delete':
        retyped_copy(src, dst, edit=lambda topic, raw: None if topic == rel else raw)
        return f'{rel} deleted'
    if kind == 'rename':
        retyped_copy(src, dst, rename={rel: rel + '_x'})
        return f'{rel} renamed'
    if kind == 'retype':
        other = rng.choice(['std_msgs/msg/Float32', 'std_msgs/msg/String',
                            'sensor_msgs/msg/JointState', 'std_msgs/msg/Int8'])
        retyped_copy(src, dst, retype={rel: other})
        return f'{rel} declared as {other}'
    assert kind == 'cdr'
    count = {'n': 0}
    target = rng.randrange(1, 5)

    def cut(topic: str, raw: bytes) -> bytes:
        if topic == rel:
            count['n'] += 1
            if count['n'] == target:
                return raw[:rng.randrange(0, max(1, len(raw) - 1))]
        return raw
    retyped_copy(src, dst, edit=cut)
    return f'message {target} on {rel} cut short'


KINDS = ['data_flip', 'summary_flip', 'footer_flip', 'cut', 'metadata', 'delete', 'rename',
         'retype', 'cdr', 'parameters']
#: (kind, bag, seed) of every case: seeded, a few dozen.
CASES = [(kind, BAGS[k % len(BAGS)], SEED + 100 * i + k)
         for i, kind in enumerate(KINDS) for k in range(2)]


def run_main(main, argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


def judge(tool: str, code: int, out: str, err: str, intact: bool, what: str) -> None:
    where = f'{tool} on {what}: exit {code}\n{out}\n{err}'
    assert 'Traceback' not in err and 'Traceback' not in out, where
    assert 'unexpected' not in err, where         # the true reason, not the catch-all
    assert code in (CHECK_CODES if tool == 'check_run' else PLOT_CODES), where
    if code == 2:
        assert err.startswith(f'{tool}: '), where
    if tool == 'check_run' and code == 0:
        assert intact, where
        compared = int(out.split(' recorded values compared')[0].rsplit(None, 1)[-1])
        assert 'RESULT: PASS' in out and compared > 0, where


@pytest.mark.parametrize('kind,name,seed', CASES)
def test_a_corrupted_bag_gets_a_documented_answer(kind: str, name: str, seed: int,
                                                  tmp_path: Path) -> None:
    rng = random.Random(seed)
    src, dst = DATA / name, tmp_path / 'bag'
    what = corrupt(kind, src, dst, rng)
    allow = ['--allow-truncated'] if rng.random() < 0.5 else []
    whole = intact(src, dst, bool(allow)) or what.endswith(NO_CHANGE)
    code, out, err = run_main(check_run.main, ['--no-progress', '--serial', *allow, str(dst)])
    judge('check_run', code, out, err, whole, what)
    code, out, err = run_main(plot_run.main, [*allow, str(dst), '-o',
                                              str(tmp_path / 'plot.png')])
    judge('plot_run', code, out, err, whole, what)


@pytest.mark.ros
@pytest.mark.parametrize('kind,seed', [('metadata', 7), ('cdr', 11)])
def test_the_installed_tools_on_a_corrupted_bag(kind: str, seed: int, tmp_path: Path) -> None:
    """The same as real processes (console scripts), so nothing relies on in-process state."""
    rng = random.Random(seed)
    src, dst = DATA / 'steady_drive', tmp_path / 'bag'
    what = corrupt(kind, src, dst, rng)
    whole = intact(src, dst, False)
    result = installed('check_run', '--no-progress', dst)
    judge('check_run', result.returncode, result.stdout, result.stderr, whole, what)
    result = installed('plot_run', dst, '-o', tmp_path / 'plot.png')
    judge('plot_run', result.returncode, result.stdout, result.stderr, whole, what)
