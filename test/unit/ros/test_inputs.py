"""The node's reading of a serialized input: ``inputs.value`` gives exactly what rclpy's
decoding and ``command_value`` give, for cmd_effort messages of every layout (read
directly when they have no layout dimensions) and for the other inputs."""

from __future__ import annotations

import math
import random
import struct

import pytest
from rclpy.serialization import deserialize_message, serialize_message
from std_msgs.msg import Float64, Float64MultiArray, Int8, MultiArrayDimension

from screwgear_ros.ros import inputs
from screwgear_ros.sim.commands import command_value

SPECIAL = [0.0, -0.0, math.inf, -math.inf, math.nan, 5e-324, 1.7976931348623157e308]


def bits(values):
    return struct.pack(f'<{len(values)}d', *values)


def rclpy_value(topic, data, kind):
    return command_value(topic, deserialize_message(data, kind))


def test_cmd_effort_reads_as_rclpy_decodes_it():
    """Seeded: data of 0 to 5 doubles (special values among them), with and without
    layout dimensions and data_offset, the alignment padding as rclpy leaves it or
    overwritten with junk (rclpy leaves it uninitialized), trailing bytes."""
    rng = random.Random(28)
    for k in range(2000):
        values = [rng.choice(SPECIAL) if rng.random() < 0.2 else rng.uniform(-1e3, 1e3)
                  for _ in range(rng.randrange(6))]
        msg = Float64MultiArray(data=values)
        if k % 3 == 0:
            msg.layout.dim = [MultiArrayDimension(label='x' * rng.randrange(4),
                                                  size=len(values), stride=len(values))
                              for _ in range(rng.randrange(1, 3))]
        msg.layout.data_offset = rng.choice([0, 0, 7])
        data = bytearray(serialize_message(msg))
        if not msg.layout.dim and values and k % 2:
            data[16:20] = bytes(rng.randrange(256) for _ in range(4))    # the padding
        if k % 5 == 0:
            data += bytes(rng.randrange(4))                               # trailing bytes
        elif not msg.layout.dim and k % 5 == 1:
            # As DDS delivers it: exactly its CDR length (rclpy's serializer may return
            # its size estimate, longer: an empty message then has 4 more bytes).
            data = data[:20 + 8 * len(values)] if values else data[:16]
        data = bytes(data)
        got = inputs.value('cmd_effort', data)
        want = rclpy_value('cmd_effort', data, Float64MultiArray)
        assert type(got) is list and all(type(v) is float for v in got)
        assert bits(got) == bits(want), (k, values)


def test_a_truncated_cmd_effort_is_refused_as_rclpy_refuses_it():
    data = serialize_message(Float64MultiArray(data=[1.0, 2.0]))
    for cut in range(len(data)):
        try:
            want = ('value', bits(rclpy_value('cmd_effort', data[:cut], Float64MultiArray)))
        except Exception as exc:            # noqa: BLE001 (whatever rclpy raises)
            want = ('error', type(exc))
        try:
            got = ('value', bits(inputs.value('cmd_effort', data[:cut])))
        except Exception as exc:            # noqa: BLE001
            got = ('error', type(exc))
        assert got == want, cut


@pytest.mark.parametrize('topic, msg', [('cmd_torque', Float64(data=3.5)),
                                        ('cmd_direction', Int8(data=-1)),
                                        ('load_torque', Float64(data=-2.0))])
def test_the_other_inputs_read_as_rclpy_decodes_them(topic, msg):
    data = serialize_message(msg)
    assert inputs.value(topic, data) == rclpy_value(topic, data, type(msg)) == msg.data
