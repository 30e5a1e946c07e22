"""Serialize once: what the node's CDR templates encode for every tick's values is what
rclpy's own deserializer reads back, and the bytes equal rosbags' serialization of the
same message (rosbags pads with zeros; rclpy leaves its padding bytes uninitialized, so
only its decoding is compared). The markers' templates decode to what table_markers
draws, serialized by rclpy."""

from __future__ import annotations

import math
import random

import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from rosbags.typesys import Stores, get_typestore
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64
from visualization_msgs.msg import MarkerArray

from screwgear_ros.bag.cdr import (
    MessageBundle,
    clock_template,
    float64_template,
    joint_state_template,
    template_of,
)
from screwgear_ros.params.table import SimSettings, TableParams
from screwgear_ros.ros.messages import to_message
from screwgear_ros.sim.plant import DriveInput, Outputs, Plant
from screwgear_ros.sim.status import Contact, contact_states
from screwgear_ros.view.markers import MarkerEncoder, table_markers

STORE = get_typestore(Stores.ROS2_JAZZY)
T = STORE.types
NAMES = ['pinion_1', 'table', 'pinion_3']


def _values(rng: random.Random, n: int) -> list[float]:
    special = [0.0, -0.0, 1e-300, -2.5e12, math.pi, 350.0]
    return [rng.choice(special) if rng.random() < 0.3 else rng.uniform(-1e4, 1e4)
            for _ in range(n)]


def _time(t_ns: int):
    return T['builtin_interfaces/msg/Time'](sec=t_ns // 10 ** 9, nanosec=t_ns % 10 ** 9)


def _rosbags_joint_state(t_ns: int, names: list[str], pos: list[float], vel: list[float],
                         eff: list[float]) -> bytes:
    """rosbags' CDR of the JointState (frame_id '')."""
    msg = T['sensor_msgs/msg/JointState'](
        header=T['std_msgs/msg/Header'](stamp=_time(t_ns), frame_id=''), name=names,
        position=np.array(pos), velocity=np.array(vel), effort=np.array(eff))
    return bytes(STORE.serialize_cdr(msg, 'sensor_msgs/msg/JointState'))


def test_joint_state_encodings_decode_to_the_values_in_rclpy_and_match_rosbags():
    rng = random.Random(7)
    # every string padding (lengths 1..4 mod 4), no joint (empty sequences are not
    # aligned to 8), a name whose UTF-8 is longer than its characters
    for names in (NAMES, ['a', 'longer_joint_name', 'x'], ['mesh_1', 'mesh_3'],
                  ['ab', 'abc', 'abcd', 'abcde'], [], ['zahnrad_ä', 'ü']):
        template = joint_state_template(names)
        n = len(names)
        for _ in range(200):
            t_ns = rng.randrange(0, 10 ** 13)
            pos, vel, eff = _values(rng, n), _values(rng, n), _values(rng, n)
            data = template.encode(t_ns, pos, vel, eff)
            msg = deserialize_message(data, JointState)
            assert list(msg.name) == names
            assert (list(msg.position), list(msg.velocity), list(msg.effort)) == (pos, vel, eff)
            assert [math.copysign(1.0, v) for v in msg.velocity] == [
                math.copysign(1.0, v) for v in vel]                  # -0.0 stays -0.0
            assert msg.header.stamp.sec * 10 ** 9 + msg.header.stamp.nanosec == t_ns
            assert msg.header.frame_id == ''
            assert data == _rosbags_joint_state(t_ns, names, pos, vel, eff)


def test_a_bundle_cuts_out_each_message_as_rosbags_serializes_it():
    """A tick's messages packed by one struct (cdr.MessageBundle, what RunIO sends) and cut
    apart: each is the bytes rosbags serializes for that message alone."""
    rng = random.Random(11)
    mesh = ['mesh_1', 'mesh_3']
    for names in (NAMES, ['zahnrad_ä', 'ü', 'abcde'], []):
        bundle = MessageBundle([clock_template(), joint_state_template(names),
                         joint_state_template(mesh), float64_template()])
        for _ in range(100):
            t_ns = rng.randrange(0, 10 ** 13)
            blocks = [_values(rng, len(names)) for _ in range(3)] + [
                _values(rng, 2) for _ in range(3)] + [_values(rng, 1)]
            clock, joints, meshes, value = bundle.encode(t_ns, *blocks)
            assert clock == bytes(STORE.serialize_cdr(
                T['rosgraph_msgs/msg/Clock'](clock=_time(t_ns)), 'rosgraph_msgs/msg/Clock'))
            assert joints == _rosbags_joint_state(t_ns, names, *blocks[:3])
            assert meshes == _rosbags_joint_state(t_ns, mesh, *blocks[3:6])
            assert value == bytes(STORE.serialize_cdr(
                T['std_msgs/msg/Float64'](data=blocks[6][0]), 'std_msgs/msg/Float64'))


def test_float64_and_clock_encodings():
    rng = random.Random(3)
    f64, clock = float64_template(), clock_template()
    for _ in range(200):
        value, t_ns = _values(rng, 1)[0], rng.randrange(0, 10 ** 13)
        assert deserialize_message(f64.encode(0, [value]), Float64).data == value
        assert f64.encode(0, [value]) == bytes(STORE.serialize_cdr(
            T['std_msgs/msg/Float64'](data=value), 'std_msgs/msg/Float64'))
        stamp = deserialize_message(clock.encode(t_ns), Clock).clock
        assert stamp.sec * 10 ** 9 + stamp.nanosec == t_ns
        assert clock.encode(t_ns) == bytes(STORE.serialize_cdr(
            T['rosgraph_msgs/msg/Clock'](clock=_time(t_ns)), 'rosgraph_msgs/msg/Clock'))


def test_template_of_writes_what_rclpy_serializes_for_every_kind_of_field():
    """The generic writer against rclpy's serializer: fixed arrays (Imu's covariances),
    byte and octet sequences, strings of every padding, nested messages in sequences,
    every primitive size; equal bytes outside the padding (which rclpy leaves
    uninitialized) and equal decoding."""
    from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
    from geometry_msgs.msg import Point, Pose, PoseArray
    from sensor_msgs.msg import CompressedImage, Imu, RegionOfInterest
    from std_msgs.msg import ByteMultiArray, ColorRGBA, Int16MultiArray
    rng = random.Random(11)
    imu = Imu(orientation_covariance=_values(rng, 9), linear_acceleration_covariance=[-0.0] * 9)
    imu.header.frame_id = 'imu_link'
    for msg in (imu, CompressedImage(format='png', data=bytes(range(7))),
                PoseArray(poses=[Pose(position=Point(x=v)) for v in _values(rng, 3)]),
                DiagnosticStatus(level=DiagnosticStatus.WARN, name='a', message='abcde',
                                 values=[KeyValue(key='k', value='vw')]),     # byte, strings
                ByteMultiArray(data=[b'a', b'\xff']),                        # octets
                RegionOfInterest(x_offset=3, height=7, do_rectify=True),     # uint32, bool
                ColorRGBA(r=0.1, g=-2.5),                                    # float32
                Int16MultiArray(data=[-3, 300]),                             # int16 after u32
                JointState(name=['ab', 'abc', 'abcd', 'abcde'], position=[0.5], velocity=[1.0],
                           effort=[1.5, -2.0])):
        template, rclpy_bytes = template_of(msg), serialize_message(msg)
        # rmw_fastrtps returns its size estimate: up to 8 bytes past the CDR (run_io.serialize)
        assert 0 <= len(rclpy_bytes) - len(template.bytes) <= 8, type(msg).__name__
        rclpy_bytes = rclpy_bytes[:len(template.bytes)]
        read = np.ones(len(rclpy_bytes), dtype=bool)
        for start, end in template.free:
            read[start:end] = False
        assert np.array_equal(np.frombuffer(template.bytes, np.uint8)[read],
                              np.frombuffer(rclpy_bytes, np.uint8)[read]), type(msg).__name__
        assert deserialize_message(template.bytes, type(msg)) == deserialize_message(
            serialize_message(msg), type(msg))            # float32 fields round alike


def _reversals(params: TableParams, torque: float, steps: int = 400) -> list[Outputs]:
    """Outputs every 40 steps of ``steps`` forward at ``torque``, then as many reversed,
    then forward again: both active paths, and in conventional mode the backlash gap."""
    plant = Plant(params, 5e-5)
    found = [plant.compute_outputs()]
    for direction in (1, -1, 1):
        plant.set_input(DriveInput(torque, direction, 0.0))
        found += [plant.advance_outputs(40) for _ in range(steps // 40)]
    return found


def test_marker_encodings_decode_to_what_table_markers_draws():
    """Through every look met in both modes' reversals (active pinion, contact of each
    mesh: on either flank, in the gap, disengaged), and for another table (the template
    follows the parameters and joint names it was made for)."""
    rng = random.Random(5)
    looks = set()
    for params, names in ((TableParams(), SimSettings().joint_names),
                          (TableParams(mode='conventional', preload_torque=0.0),
                           ['p1', 'the_table', 'p3']),
                          (TableParams().replace(radius_table=0.3), NAMES)):
        encoder = MarkerEncoder(params, names)
        for out in _reversals(params, 200.0):
            t_ns = rng.randrange(0, 10 ** 13)
            drawn = serialize_message(to_message(table_markers(params, names, out, t_ns)))
            assert deserialize_message(encoder.encode(out, t_ns), MarkerArray) == \
                deserialize_message(drawn, MarkerArray)
            looks.add((out.active_path, *contact_states(params, out)))
    assert {look[0] for look in looks} == {1, 3}, looks
    assert {contact for look in looks for contact in look[1:]} >= {
        Contact.FORWARD, Contact.REVERSE, Contact.GAP, Contact.DISENGAGED}, looks


def test_the_free_bytes_are_exactly_those_no_decoder_reads():
    """Template.free (the encapsulation options and the alignment padding, which the bulk
    bag reader ignores): a byte there, flipped, still decodes in rosbags to the message
    of the template; any other byte outside the stamps and values, flipped, does not."""
    markers = MarkerEncoder(TableParams(), NAMES)
    markers.encode(Plant(TableParams(), 5e-5).compute_outputs(), 0)
    templates = [float64_template(), clock_template(), *markers._templates.values()] + [
        joint_state_template(names) for names in
        (NAMES, ['a'], ['mesh_1', 'mesh_3'], ['ab', 'abc', 'abcd', 'abcde'], [])]
    for template in templates:
        varying = np.zeros(len(template.bytes), dtype=bool)
        for f in [*template.stamps, *template.fields]:
            varying[f.offset:f.offset + f.codec.size] = True
        free = np.zeros(len(template.bytes), dtype=bool)
        for start, end in template.free:
            free[start:end] = True
        assert not np.any(free & varying)
        for i in np.flatnonzero(~varying).tolist():
            flipped = bytearray(template.bytes)
            flipped[i] ^= 0xFF
            try:
                again = bytes(STORE.serialize_cdr(
                    STORE.deserialize_cdr(bytes(flipped), template.msgtype), template.msgtype))
            except Exception:  # noqa: BLE001 - the decoder refuses it: the byte is read
                again = None
            assert (again == template.bytes) == free[i], (template.msgtype, i)


@pytest.mark.parametrize('names', [[], ['a'], ['pinion_1', 'table', 'pinion_3'],
                                   ['mesh_1', 'mesh_3']])
def test_the_rosfree_shapes_lay_out_what_rclpys_messages_do(names):
    """The core's templates spell the three per-tick messages out (no message packages
    in the core); walked from rclpy's own messages they must come out the same."""
    from builtin_interfaces.msg import Time

    def same(a, b):
        assert (a.msgtype, a.bytes, a.free, a.stamps) == (b.msgtype, b.bytes, b.free, b.stamps)
        assert [(f.offset, f.codec.format) for f in a.fields] == \
            [(f.offset, f.codec.format) for f in b.fields]
    n = len(names)
    same(joint_state_template(names), template_of(
        JointState(name=names, position=[0.0] * n, velocity=[0.0] * n, effort=[0.0] * n),
        [('header', 'stamp')], [[(k, 0), (k, n - 1)] if n else []
                                for k in ('position', 'velocity', 'effort')]))
    same(float64_template(), template_of(Float64(), blocks=[[('data',)]]))
    same(clock_template(), template_of(Clock(clock=Time()), [('clock',)]))
