"""check_run, as installed (its console script): passes every checked-in bag, fails a
corrupted copy with exit 1, and refuses what it cannot check with exit 2.

The checked-in bags were recorded by table_sim itself (scripts/record_test_bags.sh);
the reference they are judged against is the compiled DOP853 on the recorded inputs.
A run the reference cannot follow (driven through the mesh resonance) exits 2 with
the reason, never a traceback.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from bag_runs import BAGS, copy_bag, nudge_table_angle, record_session, truncated_copy
from bag_runs import installed_check_run as check_run
from paths import DATA
from rosbags.typesys import Stores, get_typestore

from screwgear_ros.params.table import SimSettings, TableParams
from screwgear_ros.sim.events import Command
from screwgear_ros.sim.schedule import Schedule

STORE = get_typestore(Stores.ROS2_JAZZY)



@pytest.mark.parametrize('name', BAGS)
def test_every_checked_in_bag_passes(name: str) -> None:
    bag = DATA / name
    assert sum(f.stat().st_size for f in bag.iterdir()) < 1_000_000
    result = check_run(bag)
    assert result.returncode == 0, result.stdout + result.stderr
    out = result.stdout
    assert 'RESULT: PASS' in out
    for needle in ('table position', 'rad/s', 'N·m', 'transmission_error', 'tolerance',
                   'Richardson', 'DOP853', 'bit for bit'):
        assert needle in out, needle


def _edited(tmp_path: Path, edit) -> Path:
    dst = tmp_path / 'edited'
    copy_bag(DATA / 'steady_drive', dst, edit)
    return dst


def test_an_unchanged_copy_passes(tmp_path: Path) -> None:
    """The copy machinery itself does not break a bag (so the failures below are the edits)."""
    result = check_run(_edited(tmp_path, None))
    assert result.returncode == 0, result.stdout + result.stderr


def test_a_corrupted_output_fails(tmp_path: Path) -> None:
    """0.1 µrad on the table angle at one instant: physically nothing, far beyond RK4's error."""
    target = 2 * 10**9            # t = 2 s
    result = check_run(_edited(tmp_path, nudge_table_angle(target, 1e-7)))
    assert result.returncode == 1, result.stdout + result.stderr
    fails = [line for line in result.stdout.splitlines() if line.endswith('FAIL')]
    assert [line.split()[0:2] for line in fails] == [['table', 'position']]
    assert 'RESULT: FAIL' in result.stdout and '2.0000' in fails[0]


def test_a_joint_states_stamp_off_its_log_time_fails(tmp_path: Path) -> None:
    """Every joint_states must carry the simulation time it is logged at."""
    target = 2 * 10**9

    def restamp(topic, msgtype, log_time, raw):
        if topic.endswith('/joint_states') and log_time == target:
            msg = STORE.deserialize_cdr(raw, msgtype)
            msg.header.stamp.nanosec += 1000         # 1 µs off
            raw = bytes(STORE.serialize_cdr(msg, msgtype))
        return log_time, raw
    result = check_run(_edited(tmp_path, restamp))
    assert result.returncode == 1, result.stdout + result.stderr
    assert 'joint_states header stamps: 1 differ from their log time (first: log time ' \
        f'{target} ns, stamp {target + 1000} ns)' in result.stdout
    assert not [line for line in result.stdout.splitlines() if line.endswith('FAIL')]
    assert 'RESULT: FAIL: joint_states header stamps differ' in result.stdout


def test_a_corrupted_input_fails(tmp_path: Path) -> None:
    """The recorded command says 380 N·m where the node applied 400 N·m."""
    def lie(topic, msgtype, log_time, raw):
        if topic.endswith('/cmd_torque'):
            raw = bytes(STORE.serialize_cdr(STORE.types[msgtype](data=380.0), msgtype))
        return log_time, raw
    result = check_run(_edited(tmp_path, lie))
    assert result.returncode == 1, result.stdout + result.stderr
    assert 'table velocity' in result.stdout and 'RESULT: FAIL' in result.stdout
    assert 'differs from the recording' in result.stdout      # replay disagrees too


def test_a_bag_without_parameters_is_refused(tmp_path: Path) -> None:
    bag = _edited(tmp_path, lambda topic, msgtype, t, raw:
                  None if topic.endswith('/run_parameters') else (t, raw))
    result = check_run(bag)
    assert result.returncode == 2, result.stdout + result.stderr
    assert 'no run_parameters' in result.stderr


def test_a_truncated_bag_is_refused_unless_asked(tmp_path: Path) -> None:
    bag = truncated_copy(DATA / 'reversals_anti_backlash', tmp_path / 'cut')
    result = check_run(bag)
    assert result.returncode == 2, result.stdout + result.stderr
    assert 'not closed' in result.stderr and '--allow-truncated' in result.stderr
    result = check_run('--allow-truncated', bag)
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'WARNING' in result.stdout and 'RESULT: PASS' in result.stdout


def test_paths_that_are_not_bags_are_refused(tmp_path: Path) -> None:
    (tmp_path / 'notes.txt').write_text('not a bag')
    (tmp_path / 'empty').mkdir()
    (tmp_path / 'fake').mkdir()
    (tmp_path / 'fake' / 'fake_0.mcap').write_bytes(b'definitely not MCAP data')
    for path in (tmp_path / 'missing', tmp_path / 'notes.txt', tmp_path / 'empty',
                 tmp_path / 'fake'):
        result = check_run(path)
        assert result.returncode == 2, (path, result.stdout, result.stderr)
        assert result.stderr.startswith('check_run: cannot check'), result.stderr
        assert 'Traceback' not in result.stderr


def test_a_run_through_the_mesh_resonance_is_refused_with_the_reason(tmp_path: Path) -> None:
    """10 N·m held on the ideal torque source (drive_no_load_speed 0) with no table
    damping: the table accelerates through the mesh resonance (table ≈ 8 rad/s), the
    meshes rattle ever harder, and within seconds the reference's step size collapses
    below the float spacing. check_run says so, when and where, with exit 2 and no traceback."""
    dt = 50e-6
    params = TableParams(table_damping=0.0, drive_no_load_speed=0.0)
    settings = SimSettings(dt=dt, publish_rate=200.0, command_timeout=0.0)
    schedule = Schedule(params, settings, [Command('cmd_torque', 10.0, 0)],
                        end_step=round(10.0 / dt))
    record_session(tmp_path / 'resonance', schedule)
    result = check_run(tmp_path / 'resonance')
    assert result.returncode == 2, result.stdout + result.stderr
    assert 'Traceback' not in result.stderr
    err = result.stderr
    assert err.startswith('check_run: cannot check'), err
    assert 'reference solver cannot follow the run at t = ' in err
    assert 'below the spacing of floating-point numbers' in err
    assert 'in segment 1 of 1' in err and 'torque 10 N·m' in err
    t = float(err.split('at t = ')[1].split(' s')[0])
    assert 1.0 < t < 10.0, err              # measured: 3.75 s, table at ~5 rad/s
