"""The launch files through the real ``ros2 launch`` (launch 3.4.3, launch_ros 0.26.6) of the
tests' overlay: their arguments, a namespace, a recording and a parameter file taken, and
a launch that cannot run ending non-zero with the reason and leaving no process behind.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import yaml
from paths import ROOT
from ros2cli import (
    NEEDS_OVERLAY,
    group_alive,
    kill_group,
    overlay,
    ros2cli_overlay,  # noqa: F401  (the fixture NEEDS_OVERLAY uses)
    stop_group,
)
from ros_procs import STARTUP_TIMEOUT, Peer, wait_until, write_params_file
from sensor_msgs.msg import JointState

pytestmark = [pytest.mark.ros, *NEEDS_OVERLAY]

PACKAGE = 'screwgear_ros'


def _share() -> Path:
    from ament_index_python.packages import get_package_share_directory
    return Path(get_package_share_directory(PACKAGE))


def shown_arguments(launch_file: str) -> dict[str, tuple[str, str]]:
    """name → (description, default) as ``ros2 launch -s`` prints them."""
    text = overlay().run('launch', '-s', PACKAGE, launch_file).stdout
    out = {}
    for name, body in re.findall(r"^    '(\w+)':\n((?:        .*\n?)+)", text, re.MULTILINE):
        lines = [line.strip() for line in body.splitlines()]
        default = re.fullmatch(r"\(default: (.*)\)", lines[-1])
        out[name] = (' '.join(lines[:-1] if default else lines),
                     default.group(1) if default else '')
    return out


def test_table_sim_launch_shows_its_three_arguments_and_their_defaults():
    shown = shown_arguments('table_sim.launch.py')
    assert list(shown) == ['params_file', 'namespace', 'record']
    assert shown['params_file'][1] == repr(str(_share() / 'config' / 'paper.yaml'))
    assert shown['namespace'][1] == shown['record'][1] == "''"
    assert all(description for description, _ in shown.values())


def test_ros2_control_launch_shows_its_arguments_and_the_urdfs_namespace():
    shown = shown_arguments('ros2_control.launch.py')
    assert list(shown)[:3] == ['namespace', 'params_file', 'record']
    urdf = ET.parse(ROOT / 'urdf' / 'screwgear_table.urdf').getroot()
    topic = next(p.text.strip() for p in urdf.iterfind('ros2_control/hardware/param')
                 if p.get('name') == 'joint_states_topic')
    assert shown['namespace'][1] == repr(topic.rpartition('/')[0])
    assert shown['params_file'][1] == repr(str(_share() / 'config' / 'paper.yaml'))


def test_a_namespace_a_recording_and_a_params_file_are_taken(tmp_path):
    params = write_params_file(tmp_path / 'mine.yaml', {'max_torque': 300.0})
    bag = tmp_path / 'run1'
    launch = overlay().start('launch', PACKAGE, 'table_sim.launch.py', 'namespace:=axis_c',
                             f'record:={bag}', f'params_file:={params}',
                             workdir=tmp_path / 'launch')
    try:
        with Peer('ros2cli_launch') as peer:
            peer.subscribe('/axis_c/joint_states', JointState, transform=lambda m: None
                           ).wait_for(lambda m: True, STARTUP_TIMEOUT, '/axis_c/joint_states')
            values = peer.get_parameters('/axis_c/table_sim', ['max_torque', 'record'])
        assert values == {'max_torque': 300.0, 'record': str(bag)}
        assert stop_group(launch) == 0, ''.join(launch.output())[-3000:]
    finally:
        kill_group(launch)
    assert (bag / 'metadata.yaml').is_file()
    assert yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information'][
        'message_count'] > 0
    assert list(bag.glob('*.mcap'))


def _failed_launch(tmp_path: Path, *arguments: str) -> str:
    """``ros2 launch table_sim.launch.py *arguments``, expected to end by itself; its
    output. Asserts a non-zero code and that no process of it is left."""
    launch = overlay().start('launch', PACKAGE, 'table_sim.launch.py', *arguments,
                             workdir=tmp_path / 'launch')
    try:
        code = launch.popen.wait(timeout=STARTUP_TIMEOUT)
        output = ''.join(launch.output())
        assert code != 0, output
        wait_until(lambda: not group_alive(launch.pid), 10.0, 'the launch\'s processes ending')
    finally:
        kill_group(launch)
    return output


def test_a_missing_params_file_ends_the_launch_before_anything_starts(tmp_path):
    missing = tmp_path / 'no_such.yaml'
    output = _failed_launch(tmp_path, f'params_file:={missing}')
    assert f'params_file {missing} is not a file; nothing was started' in output, output
    assert 'process started' not in output, output


def test_a_recording_directory_that_exists_ends_the_launch_with_the_nodes_reason(tmp_path):
    bag = tmp_path / 'taken'
    bag.mkdir()
    (bag / 'keep.txt').write_text('a file of the user')
    output = _failed_launch(tmp_path, f'record:={bag}')
    reason = f'{bag} exists and is not an empty directory'
    assert re.search(rf'Caught exception in launch.*table_sim-1 exited with code 2: .*'
                     rf'{re.escape(reason)}', output), output
    assert (bag / 'keep.txt').read_text() == 'a file of the user'
    assert sorted(p.name for p in bag.iterdir()) == ['keep.txt']
