"""Floods at a real table_sim process over DDS: oversized and malformed inputs on every
input topic, a burst of ~/reset calls, a second node of the same name.

The input flood is a seeded, bounded family (sizes up to 10⁵ elements, NaNs, wrong
lengths, every input topic); the node's joint_states rate under it is compared with its
rate without it, measured the same way in the same test, and only loosely: the machine
is shared.
"""

from __future__ import annotations

import math
import random
import signal
import time
from pathlib import Path

import pytest
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message
from ros_procs import STARTUP_TIMEOUT, Peer, assert_clean_exit, start_process, wait_until
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64, Float64MultiArray, Int8
from std_srvs.srv import Trigger

from screwgear_ros.ros.inputs import MAX_LINE

SEED = 20
#: Joint_states rate under the flood, at least this fraction of the rate without it.
LOOSE_RATIO = 0.3
FLOOD_SECONDS = 4.0
FLOOD_RATE = 100.0          # messages a second, over all input topics


def flood_family(rng: random.Random) -> list[tuple[str, bytes]]:
    """(topic, serialized message) on every input topic: sizes up to 10⁵ elements
    (log-uniform), NaNs and infinities, wrong lengths, values out of range."""
    def size() -> int:
        return int(10 ** rng.uniform(0, 5))

    def number() -> float:
        return rng.choice([math.nan, math.inf, -math.inf, 1e300, rng.uniform(-1e4, 1e4)])

    family = []
    for _ in range(12):
        family.append(('cmd_torque', serialize_message(Float64(data=number()))))
        family.append(('load_torque', serialize_message(Float64(data=number()))))
        family.append(('cmd_direction', serialize_message(Int8(data=rng.randrange(-128, 128)))))
        family.append(('cmd_effort', serialize_message(Float64MultiArray(
            data=[number() for _ in range(size())]))))
        n = size()
        family.append(('joint_commands', serialize_message(JointState(
            name=[f'joint_{k}' for k in range(rng.choice([0, 1, n]))],
            position=[number() for _ in range(rng.choice([0, n]))],
            velocity=[number() for _ in range(rng.choice([0, size()]))],
            effort=[number() for _ in range(size())]))))
    rng.shuffle(family)
    return family


def rate(inbox, seconds: float) -> float:
    """Messages a second arriving in ``inbox`` over ``seconds`` of wall time."""
    before, t0 = len(inbox.snapshot()), time.monotonic()
    time.sleep(seconds)
    return (len(inbox.snapshot()) - before) / (time.monotonic() - t0)


def log_size(node) -> int:
    return sum(len(text) for text in node.output())


@pytest.mark.ros
def test_an_input_flood_neither_slows_the_node_nor_floods_its_log(tmp_path: Path) -> None:
    family = flood_family(random.Random(SEED))
    biggest = max(len(data) for _, data in family)
    node = start_process('table_sim', workdir=tmp_path / 'node')
    try:
        with Peer('flood_test') as peer:
            states = peer.subscribe('/joint_states', JointState, qos=1000,
                                    transform=lambda m: None)
            publishers = {topic: peer.publisher(topic, type_, wait_matched=STARTUP_TIMEOUT)
                          for topic, type_ in [('cmd_torque', Float64), ('load_torque', Float64),
                                               ('cmd_direction', Int8),
                                               ('cmd_effort', Float64MultiArray),
                                               ('joint_commands', JointState)]}
            states.wait_for(lambda m: True, STARTUP_TIMEOUT, 'joint_states')
            time.sleep(1.0)
            calm = rate(states, 2.0)
            logged = log_size(node)
            before = len(states.snapshot())
            t0 = time.monotonic()
            sent = 0
            while time.monotonic() - t0 < FLOOD_SECONDS:
                topic, data = family[sent % len(family)]
                publishers[topic].publish(data)       # serialized: published as it is
                sent += 1
                time.sleep(max(0.0, t0 + sent / FLOOD_RATE - time.monotonic()))
            flooded = (len(states.snapshot()) - before) / (time.monotonic() - t0)
            time.sleep(1.0)                           # what was queued has arrived
            grown = log_size(node) - logged
            print(f'joint_states {calm:.0f} Hz calm, {flooded:.0f} Hz flooded with {sent} '
                  f'messages (up to {biggest} bytes); the log grew {grown} characters')
            assert node.alive(), node.output()[1][-3000:]
            assert flooded >= LOOSE_RATIO * calm, (calm, flooded)
            # At most one line a second per topic and kind, each at most an excerpt.
            assert grown <= 2 * 5 * (FLOOD_SECONDS + 2) * (MAX_LINE + 200), grown
            longest = max(len(line) for line in node.output()[1].splitlines())
            assert longest <= MAX_LINE + 200, longest
            assert 'refused a message of' in node.output()[1]
        assert_clean_exit(node)
    finally:
        node.kill()


@pytest.mark.ros
def test_every_reset_of_a_burst_gets_an_answer(tmp_path: Path) -> None:
    """200 asynchronous ~/reset calls at once from one client: 200 answers."""
    node = start_process('table_sim', workdir=tmp_path / 'node')
    try:
        with Peer('reset_burst') as peer:
            qos = QoSProfile(history=HistoryPolicy.KEEP_ALL,
                             reliability=ReliabilityPolicy.RELIABLE)
            client = peer.node.create_client(Trigger, '/table_sim/reset', qos_profile=qos)
            assert client.wait_for_service(timeout_sec=STARTUP_TIMEOUT)
            futures = [client.call_async(Trigger.Request()) for _ in range(200)]
            try:
                wait_until(lambda: all(f.done() for f in futures), 60.0, '200 answers')
            finally:
                answered = sum(f.done() for f in futures)
                print(f'{answered} of 200 reset calls answered')
            assert all(f.result().success for f in futures)
        assert_clean_exit(node)
    finally:
        node.kill()


@pytest.mark.ros
def test_a_second_node_of_the_same_name_is_warned_about(tmp_path: Path) -> None:
    """Two table_sim in one domain under one full name: the second says so at start;
    one in another namespace beside them does not."""
    first = start_process('table_sim', workdir=tmp_path / 'first')
    second = other = None
    warning = 'another node named /table_sim runs in this ROS domain'
    try:
        with Peer('name_test') as peer:
            peer.subscribe('/joint_states', JointState).wait_for(
                lambda m: True, STARTUP_TIMEOUT, 'the first node running')
            second = start_process('table_sim', workdir=tmp_path / 'second')
            other = start_process('table_sim', ['-r', '__ns:=/elsewhere'],
                                  workdir=tmp_path / 'other')
            wait_until(lambda: warning in second.output()[1], STARTUP_TIMEOUT + 10.0,
                       'the warning of the second node')
            peer.subscribe('/elsewhere/joint_states', JointState).wait_for(
                lambda m: True, STARTUP_TIMEOUT, 'the other node running')
            time.sleep(6.0)                    # longer than the node's checks
        assert 'another node named' not in other.output()[1]
        for proc in (first, second, other):
            assert_clean_exit(proc, signal.SIGINT)
    finally:
        for proc in (first, second, other):
            if proc is not None:
                proc.kill()
