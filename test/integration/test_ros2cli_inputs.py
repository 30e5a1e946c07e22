"""Malformed input through the real ``ros2 topic pub``: each message one warning, counted
in /diagnostics, and the node goes on.

The inputs are those the fuzz families send from rclpy (test_floods.py's NaNs,
infinities, wrong lengths and out-of-range values on every input topic, and the
joint_commands rejections of test/unit/sim/test_commands.py), here typed as a user types
them: YAML on the command line of ``ros2 topic pub``, from the tests' overlay.
"""

from __future__ import annotations

import contextlib

import pytest
from diagnostic_msgs.msg import DiagnosticArray
from ros2cli import (
    NEEDS_OVERLAY,
    overlay,
    ros2cli_overlay,  # noqa: F401  (the fixture NEEDS_OVERLAY uses)
)
from ros_procs import STARTUP_TIMEOUT, Peer, assert_clean_exit, start_process, wait_until
from sensor_msgs.msg import JointState

from screwgear_ros.interface import Input

pytestmark = [pytest.mark.ros, *NEEDS_OVERLAY]

FLOAT64 = 'std_msgs/msg/Float64'
JOINTS = '[pinion_1, table, pinion_3]'
#: (topic, type, message as YAML)
MALFORMED = [
    *((Input.CMD_TORQUE, FLOAT64, f'{{data: {v}}}') for v in ('.nan', '-.inf', '-5.0', '400.5')),
    *((Input.CMD_DIRECTION, 'std_msgs/msg/Int8', f'{{data: {v}}}') for v in (0, -128)),
    *((Input.CMD_EFFORT, 'std_msgs/msg/Float64MultiArray', f'{{data: {v}}}')
      for v in ('[]', '[1.0, 2.0]', '[.nan]', '[500.0]')),
    *((Input.LOAD_TORQUE, FLOAT64, f'{{data: {v}}}') for v in ('.inf', '1.0e+300')),
    *((Input.JOINT_COMMANDS, 'sensor_msgs/msg/JointState', v) for v in (
        f'{{name: {JOINTS}, effort: [1.0, 2.0]}}',
        f'{{name: {JOINTS}, effort: []}}',
        f'{{name: {JOINTS}, position: [0.5], effort: [10.0]}}',
        '{name: [table, pinion_3], effort: [10.0]}',
        '{name: [joint_1, pinion_1], effort: [10.0]}',
        f'{{name: {JOINTS}, effort: [.inf]}}',
        f'{{name: {JOINTS}, effort: [400.5]}}')),
]
TWO_NANS = (Input.JOINT_COMMANDS, 'sensor_msgs/msg/JointState',
            f'{{name: {JOINTS}, effort: [.nan, .nan]}}')


class Node:
    def __init__(self, proc, diag):
        self.proc, self.diag = proc, diag

    def warnings(self, topic: str) -> int:
        return sum(f'{topic}: rejected' in line and 'WARN' in line
                   for line in self.proc.output()[1].splitlines())

    def rejected(self, topic: str) -> int:
        msg = self.diag.wait_next(lambda m: True, 15.0, 'diagnostics')
        values = {kv.key: kv.value for s in msg.status for kv in s.values}
        assert 'rejected_inputs' in values, values
        return int(values.get(f'rejected_{topic}', '0'))


@pytest.fixture(scope='module')
def node(tmp_path_factory):
    proc = start_process('table_sim', workdir=tmp_path_factory.mktemp('ros2cli_inputs'))
    try:
        with Peer('ros2cli_inputs') as peer:
            peer.subscribe('/joint_states', JointState, qos=1,
                           transform=lambda m: None).wait_for(
                lambda m: True, STARTUP_TIMEOUT, 'joint_states of table_sim')
            yield Node(proc, peer.subscribe('/diagnostics', DiagnosticArray))
        assert_clean_exit(proc)
    finally:
        proc.kill()


def publish_once(node: Node, topic: str, kind: str, text: str) -> tuple[int, int]:
    """``ros2 topic pub --once`` of ``text``; (rejections counted, warnings logged) for
    ``topic`` because of it."""
    counted, warned = node.rejected(topic), node.warnings(topic)
    overlay().run('topic', 'pub', '--once', '-w', '1', '--keep-alive', '0.5',
                  f'/{topic}', kind, text)
    with contextlib.suppress(AssertionError):   # no count: the caller says what it expected
        wait_until(lambda: node.rejected(topic) > counted, 10.0, f'{topic} counted')
    assert node.proc.alive(), node.proc.output()[1][-3000:]
    return node.rejected(topic) - counted, node.warnings(topic) - warned


@pytest.mark.parametrize('topic, kind, text', MALFORMED,
                         ids=[f'{t}:{x}' for t, _, x in MALFORMED])
def test_a_malformed_message_is_one_warning_counted_and_the_node_goes_on(node, topic,
                                                                        kind, text):
    assert publish_once(node, topic, kind, text) == (1, 1)
    stderr = node.proc.output()[1]
    assert 'Traceback' not in stderr and 'ERROR' not in stderr, stderr[-3000:]


def test_two_nan_efforts_are_a_malformed_joint_command_too(node):
    assert publish_once(node, *TWO_NANS) == (1, 1)
