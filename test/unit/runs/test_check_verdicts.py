"""check_run's verdicts on bags that once got the wrong one.

- nothing compared (only run_parameters; outputs deleted; a killed bag whose readable
  part ends at the start) is exit 2 with the reason, never PASS; the comparisons of
  replay_run refuse an empty comparison the same way (a typed error);
- the summary section is never trusted over the data: a damaged copy of a Channel
  record there (mcap's own indexed reader shows the damage) reads as the data
  section says, checks out, and the report says the summary is damaged;
- a contract topic declared with another type is refused, naming topic and types;
- mesh_state and active_path are checked: altering them fails;
- a message that does not decode is refused as such by check_run and plot_run (not
  blamed on the parameters);
- a run whose pinions oscillate about the drive line's corner (the reference at rtol
  1e-11 lands a good part of RK4's tolerance away from RK4's converged limit) is
  judged against the reference at 1e-12, which RK4 at dt/4 and dt/8 converges to.
"""

from __future__ import annotations

import math
import shutil
import struct
from pathlib import Path

import numpy as np
import pytest
from bag_runs import copy_bag, installed, record_session, retyped_copy
from bag_runs import installed_check_run as check_run
from mcap.reader import make_reader
from paths import DATA
from rosbags.typesys import Stores, get_typestore

from screwgear_ros.bag.reader import read_run
from screwgear_ros.runs import check
from screwgear_ros.runs.compare import compare_runs, exact_comparison
from screwgear_ros.runs.replay_in_process import replay_in_process
from screwgear_ros.sim.events import Command, ParameterChange, Reset
from screwgear_ros.sim.parameter_set import default_values, split_parameters
from screwgear_ros.sim.schedule import Schedule

STORE = get_typestore(Stores.ROS2_JAZZY)


def _keep(topics: set[str]):
    return lambda topic, msgtype, t, raw: (t, raw) if topic.rsplit('/', 1)[1] in topics else None


def _refused(result, *needles: str) -> None:
    assert result.returncode == 2, result.stdout + result.stderr
    assert 'Traceback' not in result.stderr and 'PASS' not in result.stdout
    for needle in needles:
        assert needle in result.stderr, (needle, result.stderr)


@pytest.mark.ros
def test_a_bag_with_only_run_parameters_compares_nothing(tmp_path: Path) -> None:
    copy_bag(DATA / 'steady_drive', tmp_path / 'bag', _keep({'run_parameters'}))
    _refused(check_run(tmp_path / 'bag'), 'nothing to compare', 'joint_states')


@pytest.mark.ros
def test_a_bag_whose_outputs_were_deleted_compares_nothing(tmp_path: Path) -> None:
    copy_bag(DATA / 'steady_drive', tmp_path / 'bag',
             _keep({'run_parameters', 'cmd_torque', 'active_path', 'clock'}))
    _refused(check_run(tmp_path / 'bag'), 'nothing to compare',
             'joint_states, transmission_error, mesh_state')


@pytest.mark.ros
def test_a_killed_bag_read_up_to_its_start_compares_nothing(tmp_path: Path) -> None:
    """The writer killed after the first tick's messages were flushed: what is readable
    ends at the start of the run, and --allow-truncated must not make that a PASS."""
    copy_bag(DATA / 'steady_drive', tmp_path / 'whole',
             lambda topic, msgtype, t, raw: (t, raw) if t == 0 else None)
    mcap_file, = (tmp_path / 'whole').glob('*.mcap')
    data_end = _footer_start(mcap_file) - 13         # the DataEnd record before the summary
    shutil.copytree(tmp_path / 'whole', tmp_path / 'cut')
    cut, = (tmp_path / 'cut').glob('*.mcap')
    cut.write_bytes(mcap_file.read_bytes()[:data_end])      # no DataEnd, no summary
    _refused(check_run(tmp_path / 'cut'), '--allow-truncated')
    _refused(check_run('--allow-truncated', tmp_path / 'cut'), 'nothing to compare',
             'not closed')


def _footer_start(mcap_file: Path) -> int:
    data = mcap_file.read_bytes()
    return struct.unpack_from('<BQQQI', data, len(data) - 8 - 29)[2]


def test_replay_comparisons_refuse_to_compare_nothing(tmp_path: Path) -> None:
    from screwgear_ros.runs.compare import format_comparison, format_exact
    original = read_run(DATA / 'steady_drive')
    copy_bag(DATA / 'steady_drive', tmp_path / 'empty', _keep({'run_parameters'}))
    empty = read_run(tmp_path / 'empty')
    exact = exact_comparison(original, empty)
    assert exact.nothing_compared is not None and not exact.ok
    assert 'IDENTICAL' not in format_exact(exact)
    free = compare_runs(original, empty)
    assert free.nothing_compared is not None and not free.ok
    assert 'PASS' not in format_comparison(free)


def _indexed_channels(mcap_file: Path) -> dict | str:
    """The channels (id → topic, schema id) mcap's indexed reader takes from the summary,
    or why it cannot."""
    try:
        with open(mcap_file, 'rb') as stream:
            summary = make_reader(stream).get_summary()
        return {c.id: (c.topic, c.schema_id) for c in summary.channels.values()}
    except Exception as exc:  # noqa: BLE001 - its failure is a difference too
        return repr(exc)


def _summary_channels(mcap_file: Path) -> list[tuple[int, str]]:
    """(offset, topic) of every Channel record in the summary section."""
    data = mcap_file.read_bytes()
    at, end = _footer_start(mcap_file), len(data) - 8 - 29
    found = []
    while at < end:
        opcode, length = struct.unpack_from('<BQ', data, at)
        if opcode == 0x04:
            n, = struct.unpack_from('<I', data, at + 9 + 4)
            found.append((at, data[at + 17:at + 17 + n].decode()))
        at += 9 + length
    return found


@pytest.mark.ros
def test_a_damaged_summary_is_not_trusted_over_the_data(tmp_path: Path) -> None:
    """A byte flipped in the summary's copy of each Channel record (in the topic name
    or the schema id): mcap's indexed reader, which trusts the summary, now sees other
    channels; read_run reads the data section, as before, and says the summary is
    damaged; check_run passes the intact physics and says so."""
    src = DATA / 'load_steps_parameter_changes'
    original = read_run(src)
    mcap_file, = src.glob('*.mcap')
    channels = _summary_channels(mcap_file)
    assert {t.rsplit('/', 1)[1] for _, t in channels} >= {'joint_states', 'mesh_state'}
    for k, (at, topic) in enumerate(channels):
        for where in (at + 17 + len(topic) - 1, at + 11):    # topic's last byte, schema id
            bag = tmp_path / f'bag{k}_{where}'
            shutil.copytree(src, bag)
            copy, = bag.glob('*.mcap')
            data = bytearray(copy.read_bytes())
            data[where] ^= 0x01
            copy.write_bytes(bytes(data))
            assert _indexed_channels(copy) != _indexed_channels(mcap_file)
            run = read_run(bag)
            assert 'does not match the CRC' in run.summary
            assert run.topics == original.topics
            for name in ('joint_states', 'transmission_error', 'mesh_state', 'active_path'):
                assert np.array_equal(getattr(run, name).values,
                                      getattr(original, name).values), name
            assert len(run.events) == len(original.events)
    at, topic = next(c for c in channels if c[1].endswith('/joint_states'))
    bag = tmp_path / 'checked'
    shutil.copytree(src, bag)
    copy, = bag.glob('*.mcap')
    data = bytearray(copy.read_bytes())
    data[at + 17 + len(topic) - 1] ^= 0x01
    copy.write_bytes(bytes(data))
    result = check_run(bag)
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'summary section does not match the CRC' in result.stdout
    assert 'RESULT: PASS' in result.stdout


@pytest.mark.ros
@pytest.mark.parametrize('rel,declared,expected', [
    ('transmission_error', 'std_msgs/msg/Float32', 'std_msgs/msg/Float64'),
    ('mesh_state', 'std_msgs/msg/String', 'sensor_msgs/msg/JointState'),
    ('cmd_torque', 'std_msgs/msg/Float32', 'std_msgs/msg/Float64')])
def test_a_topic_declared_with_another_type_is_refused(tmp_path: Path, rel: str,
                                                       declared: str, expected: str) -> None:
    retyped_copy(DATA / 'steady_drive', tmp_path / 'bag', retype={rel: declared})
    mcap_file, = (tmp_path / 'bag').glob('*.mcap')
    with open(mcap_file, 'rb') as stream:       # the bag says so, by mcap's reader
        summary = make_reader(stream).get_summary()
    assert any(c.topic.endswith('/' + rel) and summary.schemas[c.schema_id].name == declared
               for c in summary.channels.values())
    _refused(check_run(tmp_path / 'bag'), f'/{rel} is declared as {declared}', expected,
             'inconsistent')
    result = installed('plot_run', tmp_path / 'bag', '-o', tmp_path / 'plot.png')
    _refused(result, f'/{rel} is declared as {declared}')


def _edit(rel: str, change, at: int | None = None):
    """A copy_bag edit: ``change(msg)`` on the messages of ``rel`` (at log time ``at``)."""
    def edit(topic, msgtype, t, raw):
        if topic.rsplit('/', 1)[1] == rel and at in (None, t):
            msg = STORE.deserialize_cdr(raw, msgtype)
            change(msg)
            raw = bytes(STORE.serialize_cdr(msg, msgtype))
        return t, raw
    return edit


@pytest.mark.ros
def test_an_altered_mesh_state_fails(tmp_path: Path) -> None:
    """1 N more on mesh 1 at t = 2 s: far beyond RK4's error on a force of kN."""
    def more_force(msg):
        msg.effort = msg.effort.copy()
        msg.effort[0] += 1.0
    copy_bag(DATA / 'steady_drive', tmp_path / 'bag', _edit('mesh_state', more_force, 2 * 10**9))
    result = check_run(tmp_path / 'bag')
    assert result.returncode == 1, result.stdout + result.stderr
    fails = [line.split()[:2] for line in result.stdout.splitlines() if line.endswith('FAIL')]
    assert fails == [['mesh_state', 'F1']], result.stdout


@pytest.mark.ros
def test_an_altered_active_path_fails(tmp_path: Path) -> None:
    def other_path(msg):
        msg.data = 4 - msg.data       # 1 <-> 3
    copy_bag(DATA / 'reversals_anti_backlash', tmp_path / 'bag',
             _edit('active_path', other_path))
    result = check_run(tmp_path / 'bag')
    assert result.returncode == 1, result.stdout + result.stderr
    assert 'active_path: ' in result.stdout and 'recorded path 3' in result.stdout
    assert 'RESULT: FAIL: active_path differs from the replay' in result.stdout


@pytest.mark.ros
def test_a_message_that_does_not_decode_is_refused_as_such(tmp_path: Path) -> None:
    def cut(topic, msgtype, t, raw):
        return (t, raw[:6]) if topic.endswith('/cmd_torque') else (t, raw)
    copy_bag(DATA / 'steady_drive', tmp_path / 'bag', cut)
    for result in (check_run(tmp_path / 'bag'),
                   installed('plot_run', tmp_path / 'bag', '-o', tmp_path / 'p.png')):
        _refused(result, 'cmd_torque is not a valid std_msgs/msg/Float64')
        assert 'cannot be simulated' not in result.stderr


@pytest.mark.ros
def test_invalid_utf8_in_metadata_is_refused_with_the_reason(tmp_path: Path) -> None:
    shutil.copytree(DATA / 'steady_drive', tmp_path / 'bag')
    (tmp_path / 'bag' / 'metadata.yaml').write_bytes(b'rosbag2_bagfile_information:\n  \xff\xfe')
    for result in (check_run(tmp_path / 'bag'),
                   installed('plot_run', tmp_path / 'bag', '-o', tmp_path / 'p.png')):
        _refused(result, 'metadata.yaml: not a rosbag2 metadata file', 'utf-8')


def _oscillating_run(path: Path) -> None:
    """Default parameters at 200 Hz: a bang-bang effort of ±400 N·m every tick, the
    mesh damping lowered to 100 N·s/m at 1.5 s, a reset at 2.5 s. The pinions ring
    about the drive line's corner and past its no-load speed."""
    values = {**default_values(), 'publish_rate': 200.0}
    params, settings = split_parameters(values)
    dt = settings.dt

    def at(t: float) -> int:
        return round(t / dt)
    events = [Command('cmd_effort', [400.0 * math.copysign(1.0, (1.0 if (t % 2.0) < 1.0
                                                                 else -0.5)
                                                                - 0.3 * math.sin(t))], at(t))
              for t in (k * 0.005 for k in range(1, 800))]
    low, settings2 = split_parameters({**values, 'mesh_damping': 100.0})
    events += [ParameterChange(low, settings2, at(1.5)), Reset(at(2.5))]
    events.sort(key=lambda e: e.step)
    record_session(path, Schedule(params, settings, events, end_step=at(4.0)))


@pytest.mark.ros
def test_a_run_ringing_about_the_drive_corner_is_judged_by_a_converged_reference(
        tmp_path: Path) -> None:
    _oscillating_run(tmp_path / 'bag')
    run = read_run(tmp_path / 'bag')
    p = run.parameters.params
    w = run.joint_states.values[:, 3:6:2]
    assert np.abs(w).max() > 1.3 * p.drive_no_load_speed     # past the no-load speed
    result = check_run(tmp_path / 'bag')
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'RESULT: PASS' in result.stdout and 'ref. err' in result.stdout
    # Independently of the reference: RK4 converges (order 4) to a limit that the
    # reference at rtol 1e-12 matches to a small part of the tolerance, while the one at
    # 1e-11 may land a good part of it away.
    rk = {r: replay_in_process(run, r).joint_states for r in (1, 2, 4, 8)}
    replayed = replay_in_process(run, 1)
    tight = check.reference_outputs(run, replayed, rtol=1e-12)[0]
    tolerance = np.maximum(1.5 * np.abs(rk[1] - rk[2]).max(axis=0), 1e-12)
    converged = np.abs(rk[4] - rk[8]).max(axis=0)
    assert np.all(converged < 0.01 * tolerance)
    assert np.all(np.abs(rk[8] - tight).max(axis=0) < 0.1 * tolerance)


@pytest.mark.ros
def test_run_parameters_with_an_infinite_start_step_are_refused_with_the_reason(
        tmp_path: Path) -> None:
    """A value the parameter loader does not foresee is still a refused bag, not an
    'unexpected' error."""
    import yaml

    def edit(topic, msgtype, t, raw):
        if topic.endswith('/run_parameters'):
            document = yaml.safe_load(STORE.deserialize_cdr(raw, msgtype).data)
            document['start_step'] = float('inf')
            raw = bytes(STORE.serialize_cdr(STORE.types[msgtype](data=yaml.safe_dump(document)),
                                            msgtype))
        return t, raw
    copy_bag(DATA / 'steady_drive', tmp_path / 'bag', edit)
    for result in (check_run(tmp_path / 'bag'),
                   installed('plot_run', tmp_path / 'bag', '-o', tmp_path / 'p.png')):
        _refused(result, 'run_parameters refused', 'OverflowError')
        assert 'unexpected' not in result.stderr
