"""A recording table_sim process: SIGINT/SIGTERM leave a complete bag; kill -9 leaves
every flushed chunk readable.

Real processes over DDS: the node is started as installed (its console script) with
``record:=PATH``; the test drives it and watches /clock from its own node.
"""

from __future__ import annotations

import signal
import time
from pathlib import Path

import pytest
import yaml
from bag_runs import installed_check_run as check_run
from mcap.reader import make_reader
from ros_procs import STARTUP_TIMEOUT, Peer, assert_clean_exit, stamp_ns, start_process
from rosbags.rosbag2 import Reader
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from screwgear_ros.bag.reader import read_run
from screwgear_ros.bag.recorder import FLUSH_PERIOD

PARAMS = {'table_damping': 8867.0, 'publish_rate': 200.0}
PRELOAD = 350.0                  # N·m on pinion 1 with no command (the default preload)




def drive(seconds: float) -> int:
    """Command 400 N·m and wait until the node's simulation has run ``seconds`` past
    the command; the last /clock seen, ns.

    The command is sent again every 0.5 s until joint_states shows it applied: a
    publisher that sees the node's subscription may still be unknown to it (discovery
    is not symmetric), and a volatile reader drops what came before it matched. On a
    busy machine discovery can take seconds while the node already runs, so the time
    is counted from the command, not from the start.
    """
    with Peer('recorder_test') as peer:
        clock = peer.subscribe('/clock', Clock, transform=stamp_ns)
        efforts = peer.subscribe('/joint_states', JointState, transform=lambda m: m.effort[0])
        torque = peer.publisher('cmd_torque', Float64, wait_matched=STARTUP_TIMEOUT)
        clock.wait_for(lambda t: t > 0, STARTUP_TIMEOUT, 'the node to run')
        deadline = time.monotonic() + STARTUP_TIMEOUT
        while True:
            torque.publish(Float64(data=400.0))
            try:
                efforts.wait_next(lambda e: e > PRELOAD + 1.0, 0.5, 'the command applied')
                break
            except AssertionError:
                if time.monotonic() > deadline:
                    raise
        applied = clock.latest()
        print(f"command applied at t = {applied * 1e-9:.3f} s of simulation")
        clock.wait_for(lambda t: t >= applied + seconds * 1e9, 60.0,
                       f'{seconds} s of simulation after the command')
        return clock.latest()


@pytest.mark.ros
@pytest.mark.parametrize('sig', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
def test_a_stopped_node_leaves_a_complete_bag(sig: int, tmp_path: Path) -> None:
    bag = tmp_path / 'run'
    node = start_process('table_sim', params={**PARAMS, 'record': str(bag)},
                         workdir=tmp_path / 'node')
    try:
        drive(1.0)
    finally:
        assert_clean_exit(node, sig)
    mcap_file, = bag.glob('*.mcap')
    with open(mcap_file, 'rb') as stream:             # summary and chunk index written
        summary = make_reader(stream).get_summary()
    assert summary is not None and summary.chunk_indexes
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    with Reader(bag) as reader:                        # rosbags needs the footer and index
        assert reader.message_count == info['message_count'] \
            == summary.statistics.message_count > 200
        assert reader.duration >= 1e9
    run = read_run(bag)
    assert run.truncated is None and run.events
    result = check_run(bag)
    assert result.returncode == 0, result.stdout + result.stderr


@pytest.mark.ros
def test_kill_9_leaves_the_flushed_part_readable(tmp_path: Path) -> None:
    bag = tmp_path / 'run'
    node = start_process('table_sim', params={**PARAMS, 'record': str(bag)},
                         workdir=tmp_path / 'node')
    try:
        last_seen = drive(2.5)
    finally:
        node.popen.send_signal(signal.SIGKILL)
        node.kill()
    assert node.popen.returncode == -signal.SIGKILL
    assert (bag / 'metadata.yaml').is_file()       # written at open: still a rosbag2 dir
    run = read_run(bag, allow_truncated=True)
    assert run.truncated is not None
    last_read = int(run.joint_states.steps[-1]) * run.dt
    lost = last_seen * 1e-9 - last_read
    print(f'kill -9 at t >= {last_seen * 1e-9:.3f} s of simulation: readable up to '
          f'{last_read:.3f} s, {lost:.3f} s lost (flush period {FLUSH_PERIOD} s of wall '
          'time at real-time factor 1)')
    assert run.events and len(run.joint_states) > 0
    refused = check_run(bag)
    assert refused.returncode == 2 and 'not closed' in refused.stderr, refused.stderr
    result = check_run('--allow-truncated', bag)
    assert result.returncode == 0, result.stdout + result.stderr
