"""table_sim as a process: it stops by itself at ``duration`` (simulated seconds) with
its recording closed (also after its model diverged), and free-running it counts the
ticks a controller answered too late, in /diagnostics and in its log.

The controllers are the test's own rclpy node over real DDS; the recording is read back
with rosbags (a second library) and the package's reader.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from ros_procs import STARTUP_TIMEOUT, Peer, stamp_ns, start_process, wait_until
from rosbags.rosbag2 import Reader
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from screwgear_ros.bag.reader import read_run
from screwgear_ros.params.table import TableParams
from screwgear_ros.physics.quantities import natural_frequency

pytestmark = pytest.mark.ros

RUN_TIMEOUT = 120.0      # s of wall time for 50 lockstep ticks on a loaded machine


def diag_values(msg: DiagnosticArray) -> dict[str, str]:
    return {kv.key: kv.value for kv in msg.status[0].values}


def test_duration_stops_the_node_with_the_recording_closed_at_that_time(tmp_path: Path):
    """A user's controller in lockstep, the node flat out at 200 Hz with duration 0.25 s:
    the node exits 0 by itself, and the bag ends with the tick at exactly 0.25 s."""
    bag = tmp_path / 'run'
    node = start_process('table_sim', params={
        'lockstep': True, 'real_time_factor': 0.0, 'publish_rate': 200.0, 'duration': 0.25,
        'record': str(bag)},
        workdir=tmp_path / 'node')
    answered: set[int] = set()
    try:
        with Peer('duration_controller') as peer:
            effort = peer.publisher('/cmd_effort', Float64MultiArray)

            def answer(msg: JointState) -> None:
                stamp = stamp_ns(msg)
                if stamp in answered or not effort.get_subscription_count():
                    return                      # each new stamp once (lockstep's repeats)
                answered.add(stamp)
                error = 0.01 - msg.position[1]
                effort.publish(Float64MultiArray(data=[2000.0 * error - 300.0 * msg.velocity[1]]))

            peer.node.create_subscription(JointState, '/joint_states', answer, 10)
            code = node.popen.wait(timeout=STARTUP_TIMEOUT + RUN_TIMEOUT)
    finally:
        node.kill()
    _, stderr = node.output()
    assert code == 0, stderr[-3000:]
    assert 'Traceback' not in stderr
    assert 'duration reached at t = 0.250000 s of simulation' in stderr, stderr[-3000:]
    assert 'recording closed' in stderr
    with Reader(bag) as reader:                 # needs the footer and index: closed
        stamps = [t for c, t, _ in reader.messages() if c.topic == '/joint_states']
    assert max(stamps) == 250_000_000, max(stamps)
    assert len(stamps) == len(set(stamps)) == 51           # t = 0 and 50 ticks, none lost
    run = read_run(bag)
    assert run.truncated is None
    assert max(answered) == 250_000_000          # the controller saw the last tick too


def test_free_running_counts_the_ticks_answered_too_late(tmp_path: Path):
    """No controller: nothing counted, no warning. A controller that answers every
    other joint_states: at most about half the ticks in time, the missed ones counted,
    the diagnostics at WARN naming min_answer_rate, one warning in the log, and the
    status line showing the share."""
    node = start_process('table_sim', params={'publish_rate': 200.0},
                         workdir=tmp_path / 'node')
    try:
        with Peer('late_controller') as peer:
            diag = peer.subscribe('/diagnostics', DiagnosticArray)
            before = diag_values(diag.wait_for(lambda m: True, STARTUP_TIMEOUT,
                                               'the first diagnostics'))
            assert before['answer_rate'] == '' and before['answers_missed'] == '0', before
            effort = peer.publisher('/cmd_effort', Float64MultiArray)
            seen = [0]

            def answer(msg: JointState) -> None:
                seen[0] += 1
                if seen[0] % 2:
                    effort.publish(Float64MultiArray(data=[0.0]))

            peer.node.create_subscription(JointState, '/joint_states', answer, 10)
            msg = diag.wait_next(lambda m: diag_values(m)['answer_rate'] != '', 30.0,
                                 'diagnostics with an answer rate')
            values = diag_values(msg)
            rate = float(values['answer_rate'])
            assert 0.0 < rate <= 0.6, values
            assert int(values['answers_missed']) > 0 and int(values['answers_in_time']) > 0
            assert msg.status[0].level == DiagnosticStatus.WARN, msg.status[0]
            assert 'min_answer_rate' in msg.status[0].message, msg.status[0].message
            wait_until(lambda: '% in time' in node.output()[1], 30.0,
                       'a status line with the answers')
    finally:
        node.stop()
        node.kill()
    stderr = node.output()[1]
    assert 'free-running: the controller answered' in stderr, stderr[-3000:]
    status = [line for line in stderr.splitlines() if '| answers' in line]
    assert status, stderr[-3000:]


def test_a_node_whose_model_diverged_still_stops_at_duration(tmp_path: Path):
    """The model diverges on its way (a parametric resonance of the mesh stiffness, as in
    test_node_fault): the plant's time stands still after the fault, and the node still
    stops when it has run duration's ticks, exit 0."""
    unstable = TableParams(mode='conventional', backlash=0.0, mesh_phase='time',
                           mesh_stiffness_amplitude=5.0e6, mesh_damping=0.0)
    node = start_process('table_sim', params={
        'mode': 'conventional', 'backlash': 0.0, 'mesh_phase': 'time',
        'mesh_stiffness_amplitude': 5.0e6, 'mesh_damping': 0.0,
        'mesh_frequency': 2.0 * natural_frequency(unstable), 'drive_no_load_speed': 0.0,
        'real_time_factor': 0.0, 'duration': 8.0}, workdir=tmp_path / 'node')
    try:
        code = node.popen.wait(timeout=STARTUP_TIMEOUT + RUN_TIMEOUT)
    finally:
        node.kill()
    stderr = node.output()[1]
    assert code == 0, stderr[-3000:]
    halted = stderr.find('simulation halted')
    assert 0 <= halted < stderr.find('duration reached at t = 8.000000 s'), stderr[-3000:]
