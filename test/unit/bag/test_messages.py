"""The CDR bytes a run records besides its per-tick outputs, written with no ROS message
package (:mod:`screwgear_ros.bag.messages`), against rclpy: its deserializer reads
them back as the message rclpy builds, and the bytes are rclpy's serialization of that
message outside the padding (which rclpy leaves uninitialized); rmw_fastrtps hands
over its size estimate, up to 8 bytes past the CDR's end, which no decoder reads."""

from __future__ import annotations

import random

import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import Empty, Float64, Float64MultiArray, Int8, String

from screwgear_ros.bag import messages
from screwgear_ros.bag.cdr import template_of
from screwgear_ros.interface import Input
from screwgear_ros.ros.messages import input_message, stamp
from screwgear_ros.sim.commands import JointCommand


def _same(ours: bytes, msg: object) -> None:
    theirs = serialize_message(msg)
    if isinstance(msg, (Int8, Empty)):      # padded to rmw's length, as recorded before
        assert len(ours) == len(theirs), (type(msg).__name__, ours, theirs)
    # rmw_fastrtps returns its size estimate: up to 8 bytes past the CDR
    assert 0 <= len(theirs) - len(ours) <= 8, (type(msg).__name__, ours, theirs)
    theirs = theirs[:len(ours)]
    assert deserialize_message(ours, type(msg)) == deserialize_message(theirs, type(msg))
    # rclpy's bytes exactly, but for the padding and past the CDR's end (Empty: one byte)
    layout = template_of(msg) if not isinstance(msg, Empty) else None
    read = np.zeros(len(ours), dtype=bool)
    read[:5 if layout is None else len(layout.bytes)] = True
    for start, end in [(2, 4)] if layout is None else layout.free:
        read[start:end] = False
    assert np.array_equal(np.frombuffer(ours, np.uint8)[read],
                          np.frombuffer(theirs, np.uint8)[read]), type(msg).__name__


@pytest.mark.parametrize('seed', range(4))
def test_every_recorded_message_is_what_rclpy_serializes(seed):
    rng = random.Random(seed)
    t_ns = rng.randrange(0, 10 ** 13)
    value = rng.uniform(-1e3, 1e3)
    text = 'x' * rng.randrange(0, 9) + 'µ'
    for ours, msg in ((messages.float64(value), Float64(data=value)),
                      (messages.int8(rng.choice([-1, 1, 3])), None),
                      (messages.string(text), String(data=text)),
                      (messages.empty(), Empty())):
        if msg is None:
            msg = Int8(data=int(np.frombuffer(ours[4:5], np.int8)[0]))
        _same(ours, msg)
    names = tuple('j' * k for k in range(1, rng.randrange(2, 5)))
    for command in (JointCommand(names, effort=(value,)),
                    JointCommand(names, position=(1.0,) * len(names), velocity=(),
                                 effort=(value,) * len(names)),
                    JointCommand(())):
        ours = messages.input_message(Input.JOINT_COMMANDS, command, t_ns)
        theirs = input_message(Input.JOINT_COMMANDS, command, t_ns)
        _same(ours, theirs)
    for topic, v in ((Input.CMD_EFFORT, [value, -value]), (Input.CMD_EFFORT, []),
                     (Input.CMD_TORQUE, value), (Input.LOAD_TORQUE, -value),
                     (Input.CMD_DIRECTION, rng.choice([-1, 1])), (Input.SETPOINT, value)):
        theirs = input_message(topic, v, t_ns) if topic != Input.SETPOINT else Float64(data=v)
        _same(messages.input_message(topic, v, t_ns), theirs)
    assert deserialize_message(messages.joint_state(JointCommand(('a',)), t_ns),
                               JointState).header.stamp == stamp(t_ns)


def test_a_float64_multi_array_keeps_its_layout_default():
    msg = deserialize_message(messages.float64_multi_array([1.0]), Float64MultiArray)
    assert (list(msg.layout.dim), msg.layout.data_offset, list(msg.data)) == ([], 0, [1.0])


def test_an_unknown_input_is_refused():
    with pytest.raises(KeyError):
        messages.input_message('joint_states', 1.0)
    with pytest.raises(TypeError):
        messages.input_message(Input.JOINT_COMMANDS, [1.0])


@pytest.mark.parametrize('values', [[], [('ticks', '12'), ('real-time factor', '0.98')]])
def test_diagnostics_are_what_rclpy_serializes(values):
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
    status = DiagnosticStatus(level=bytes([1]), name='/table_sim: simulation', message='ok',
                              hardware_id='screwgear_ros/table_sim',
                              values=[KeyValue(key=k, value=v) for k, v in values])
    msg = DiagnosticArray(status=[status])
    msg.header.stamp = stamp(1_234_567_890)
    _same(messages.diagnostics('/table_sim: simulation', 'screwgear_ros/table_sim', 1, 'ok',
                               values, 1_234_567_890), msg)
