"""Command validation against the input contract of shared/spec/interface.md."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest
from paths import ROOT

from screwgear_ros.params.table import TableParams
from screwgear_ros.sim.commands import (
    COMMANDED_JOINT,
    INPUT_TOPICS,
    InputRejected,
    JointCommand,
    apply_command,
    apply_direction,
    apply_effort,
    apply_load,
    apply_torque,
    carries_no_command,
    command_value,
    load_limit,
)
from screwgear_ros.sim.plant import DriveInput

P = TableParams()                 # max_torque 400 N·m, r1 = 0.078 m, r2 = 0.582 m
NOW = DriveInput(torque=120.0, direction=-1, load=15.0)
BAD_NUMBERS = [math.nan, math.inf, -math.inf, None, 'ten', True]


def test_the_input_topics_and_types_are_the_spec_table():
    assert INPUT_TOPICS == {'cmd_torque': 'std_msgs/msg/Float64',
                            'cmd_direction': 'std_msgs/msg/Int8',
                            'cmd_effort': 'std_msgs/msg/Float64MultiArray',
                            'load_torque': 'std_msgs/msg/Float64',
                            'joint_commands': 'sensor_msgs/msg/JointState'}


@pytest.mark.parametrize('value', [0.0, 0, 0.5, 399.999, 400.0])
def test_torque_within_0_and_max_is_taken_and_nothing_else_changes(value):
    assert apply_command(NOW, 'cmd_torque', value, P) == DriveInput(float(value), -1, 15.0)


@pytest.mark.parametrize('value', [-1e-12, -5.0, 400.0000001, 1e9, *BAD_NUMBERS])
def test_torque_outside_the_rule_is_rejected_naming_topic_and_value(value):
    with pytest.raises(InputRejected) as info:
        apply_command(NOW, 'cmd_torque', value, P)
    text = str(info.value)
    assert text.startswith('cmd_torque: rejected ') and repr(value) in text
    assert 'stays in force' in text


def test_max_torque_is_the_parameter_in_force():
    assert apply_command(NOW, 'cmd_torque', 40.0, P.replace(max_torque=50.0)).torque == 40.0
    with pytest.raises(InputRejected, match='50'):
        apply_command(NOW, 'cmd_torque', 60.0, P.replace(max_torque=50.0))
    with pytest.raises(InputRejected):
        apply_torque(NOW, 60.0, 50.0)


@pytest.mark.parametrize('value', [1, -1])
def test_direction_plus_or_minus_one_is_taken(value):
    assert apply_command(NOW, 'cmd_direction', value, P) == DriveInput(120.0, value, 15.0)


@pytest.mark.parametrize('value', [0, 2, -2, 127, -128, True, 0.5, math.nan, None])
def test_any_other_direction_is_rejected(value):
    with pytest.raises(InputRejected, match=r'^cmd_direction: rejected .*\+1 or -1'):
        apply_direction(NOW, value)


@pytest.mark.parametrize('effort, torque, direction', [
    ([250.0], 250.0, 1), ([-250.0], 250.0, -1), ([-400.0], 400.0, -1), ([3], 3.0, 1),
])
def test_effort_sign_sets_direction_and_magnitude_the_torque(effort, torque, direction):
    assert apply_command(NOW, 'cmd_effort', effort, P) == DriveInput(torque, direction, 15.0)


def test_zero_effort_means_no_torque_and_keeps_the_direction():
    assert apply_effort(NOW, [0.0], 400.0) == DriveInput(0.0, -1, 15.0)
    assert apply_effort(NOW, [-0.0], 400.0) == DriveInput(0.0, -1, 15.0)


@pytest.mark.parametrize('topic', ['cmd_effort', 'joint_commands'])
def test_an_effort_within_the_deadband_is_no_torque_and_no_reversal(topic):
    band = P.effort_deadband
    assert 0.0 < band < 1e-3 * P.max_torque
    value = (lambda e: [e]) if topic == 'cmd_effort' else (
        lambda e: JointCommand(('pinion_1',), effort=(e,)))
    for effort in (band, -band, 1e-14, -1e-14, 0.0, -0.0):
        assert apply_command(NOW, topic, value(effort), P) == DriveInput(0.0, -1, 15.0)
    # just outside it the sign is a direction again
    assert apply_command(NOW, topic, value(2.0 * band), P) == DriveInput(2.0 * band, 1, 15.0)
    # a deadband of 0 keeps only an exact zero
    exact = P.replace(effort_deadband=0.0)
    assert apply_command(NOW, topic, value(1e-14), exact) == DriveInput(1e-14, 1, 15.0)


@pytest.mark.parametrize('topic', ['cmd_effort', 'joint_commands'])
def test_a_reversal_needs_an_effort_beyond_the_direction_hysteresis(topic):
    """A Schmitt trigger on the effort: against the direction in force (reverse, −1),
    an effort up to the hysteresis is no torque and keeps the path; beyond it, it
    reverses; along the direction in force every effort drives."""
    hysteresis = 20.0
    params = P.replace(direction_hysteresis=hysteresis)
    value = (lambda e: [e]) if topic == 'cmd_effort' else (
        lambda e: JointCommand(('pinion_1',), effort=(e,)))
    for effort in (1e-3, 5.0, hysteresis):
        assert apply_command(NOW, topic, value(effort), params) == DriveInput(0.0, -1, 15.0)
        assert apply_command(NOW, topic, value(-effort), params) == \
            DriveInput(effort, -1, 15.0)
    assert apply_command(NOW, topic, value(20.5), params) == DriveInput(20.5, 1, 15.0)
    forward = DriveInput(120.0, 1, 15.0)
    assert apply_command(forward, topic, value(-20.0), params) == DriveInput(0.0, 1, 15.0)
    assert apply_command(forward, topic, value(-20.5), params) == DriveInput(20.5, -1, 15.0)
    # the declared default is no hysteresis: the paper's law, every sign a direction
    assert TableParams.direction_hysteresis == 0.0
    assert apply_command(NOW, topic, value(5.0), P) == DriveInput(5.0, 1, 15.0)


def test_a_controller_at_rest_flipping_its_sign_by_rounding_noise_reverses_nothing():
    # the effort of a PD controller holding the table, rounding noise of either sign,
    # then silence past command_timeout: no reversal, and the timeout says nothing of a
    # 1e-14 N·m drive torque (there was none)
    from screwgear_ros.params.table import SimSettings
    from screwgear_ros.sim.events import Command
    from screwgear_ros.sim.session import Session
    session = Session(P, SimSettings(command_timeout=0.05))
    reversals, notices = 0, []
    for k in range(40):
        session.submit(Command('cmd_effort', [(-1.0) ** k * 1e-14]))
        tick = session.tick()
        reversals += tick.reversal
        assert tick.drive.torque == 0.0 and not tick.rejected
    for _ in range(100):                            # 0.1 s without a command
        tick = session.tick()
        reversals += tick.reversal
        notices += tick.notices
    assert reversals == 0 and session.timed_out
    assert not any('e-14' in n for n in notices), notices


@pytest.mark.parametrize('target', [0.02, -0.03])
def test_a_pd_loop_holding_its_target_reverses_nothing(target):
    """A user's PD law (the README quick start's gains) closed in the node's own loop on
    the paper's table: one braking reversal during the step, then none while it holds
    the target, although its effort there is rounding noise of either sign (without the
    deadband, hundreds of reversals from about 4 s on)."""
    from screwgear_ros import Simulation
    sim = Simulation.from_yaml(ROOT / 'config' / 'paper.yaml')

    def pd(o):
        effort = 2000.0 * (target - o.position[1]) - 300.0 * o.velocity[1]
        return max(-300.0, min(300.0, effort))

    run = sim.run(pd, 10.0)
    held = run.time >= 1.0
    assert abs(run.position[held, 1] - target).max() < 0.01 * abs(target)   # it holds
    assert len(set(run.direction[held].tolist())) == 1, 'a reversal while holding'
    assert len(set(run.active_path[held].tolist())) == 1


@pytest.mark.parametrize('effort', [[], [1.0, 2.0], [0.0, 0.0, 0.0], [math.nan], [math.inf],
                                    [-math.inf], [400.5], [-401.0], ['x']])
def test_effort_of_the_wrong_length_or_value_is_rejected(effort):
    with pytest.raises(InputRejected, match=r'^cmd_effort: rejected '):
        apply_command(NOW, 'cmd_effort', effort, P)


def test_load_is_signed_and_bounded_by_ten_times_what_the_drive_can_hold():
    limit = 10.0 * 400.0 * 0.582 / 0.078            # N·m at the table
    assert load_limit(400.0, 0.078, 0.582) == pytest.approx(limit)
    assert apply_command(NOW, 'load_torque', -2500.0, P) == DriveInput(120.0, -1, -2500.0)
    assert apply_command(NOW, 'load_torque', limit * 0.999, P).load == limit * 0.999
    for value in (limit * 1.001, -limit * 1.001, *BAD_NUMBERS):
        with pytest.raises(InputRejected, match=r'^load_torque: rejected '):
            apply_command(NOW, 'load_torque', value, P)
    with pytest.raises(InputRejected):
        apply_load(NOW, 11.0, 10.0)


def test_an_unknown_topic_is_rejected():
    with pytest.raises(InputRejected, match='unknown input topic'):
        apply_command(NOW, 'cmd_speed', 1.0, P)


def test_folding_a_stream_keeps_the_last_valid_command_through_rejections():
    stream = [('cmd_direction', 1), ('cmd_torque', 100.0), ('cmd_torque', math.nan),
              ('cmd_direction', 0), ('load_torque', 30.0), ('cmd_effort', [1.0, 2.0]),
              ('cmd_torque', 500.0), ('cmd_effort', [-80.0]), ('cmd_direction', 3)]
    drive, rejected = DriveInput(), []
    for topic, value in stream:
        try:
            drive = apply_command(drive, topic, value, P)
        except InputRejected:
            rejected.append(topic)
    assert drive == DriveInput(torque=80.0, direction=-1, load=30.0)
    assert rejected == ['cmd_torque', 'cmd_direction', 'cmd_effort', 'cmd_torque',
                        'cmd_direction']


def test_the_node_subscribes_each_input_with_the_type_the_core_declares():
    from screwgear_ros.bag.cdr import type_name
    from screwgear_ros.interface import ANSWER_TOPICS
    from screwgear_ros.ros.messages import INPUT_TYPES, input_message
    assert {topic: type_name(kind) for topic, kind in INPUT_TYPES.items()} == INPUT_TOPICS
    assert set(ANSWER_TOPICS) <= set(INPUT_TOPICS)
    assert {'cmd_effort', 'joint_commands'} <= set(ANSWER_TOPICS)
    assert list(input_message('cmd_effort', [-3]).data) == [-3.0]
    assert input_message('cmd_direction', -1).data == -1


# ---------------------------------------------------------------- joint_commands
# What ros2_control's joint_state_topic_hardware_interface/JointStateTopicSystem publishes
# for urdf/screwgear_table.urdf: every joint of the <ros2_control> block named, only the
# arrays of existing command interfaces filled (pinion_1/effort), NaN before a controller
# wrote the interface.

JOINTS = ('pinion_1', 'table', 'pinion_3')


def plugin(*effort: float, name: tuple[str, ...] = JOINTS, **arrays) -> JointCommand:
    return JointCommand(name, effort=tuple(effort), **arrays)


def test_pinion_1_is_the_commanded_joint():
    assert JOINTS[COMMANDED_JOINT] == 'pinion_1'


@pytest.mark.parametrize('effort', [250.0, -250.0, -400.0, 400.0, 3.0, 0.0, -0.0])
def test_the_plugins_effort_folds_exactly_like_cmd_effort(effort):
    assert apply_command(NOW, 'joint_commands', plugin(effort), P) == \
        apply_command(NOW, 'cmd_effort', [effort], P)


def test_any_order_of_names_and_custom_joint_names_work():
    names = ('p1', 'bed', 'p3')
    command = plugin(-20.0, name=('bed', 'p3', 'p1'))
    assert apply_command(NOW, 'joint_commands', command, P, names) == DriveInput(20.0, -1, 15.0)
    with pytest.raises(InputRejected, match='joint_states does not have'):
        apply_command(NOW, 'joint_commands', command, P)        # default names: pinion_1, ...


@pytest.mark.parametrize('command, why', [
    (plugin(1.0, 2.0), 'exactly one effort value'),
    (plugin(), 'exactly one effort value'),
    (plugin(1.0, 2.0, 3.0), 'exactly one effort value'),
    (plugin(10.0, position=(0.5,)), 'position and velocity must be empty'),
    (plugin(10.0, velocity=(0.5, 0.5, 0.5)), 'position and velocity must be empty'),
    (plugin(10.0, name=('table', 'pinion_3')), 'must name pinion_1'),
    (plugin(10.0, name=('joint_1', 'pinion_1')), "['joint_1']"),
    (plugin(math.inf), 'finite'), (plugin(-math.inf), 'finite'),
    (plugin(math.nan), 'finite'),
    (plugin(400.5), '400 N·m (max_torque)'), (plugin(-401.0), 'max_torque'),
    ({'name': list(JOINTS), 'effort': [1.0]}, 'JointState'),
])
def test_a_joint_command_the_table_cannot_take_is_rejected_saying_why(command, why):
    with pytest.raises(InputRejected) as info:
        apply_command(NOW, 'joint_commands', command, P)
    text = str(info.value)
    assert text.startswith('joint_commands: rejected ') and why in text
    assert text.endswith('the last valid command stays in force')


def test_the_rejection_shows_the_message_compactly():
    with pytest.raises(InputRejected) as info:
        apply_command(NOW, 'joint_commands', plugin(500.0), P)
    assert "JointState(name=['pinion_1', 'table', 'pinion_3'], effort=[500.0])" in str(info.value)


def test_nan_before_the_first_command_carries_no_command():
    assert carries_no_command('joint_commands', plugin(math.nan))
    assert carries_no_command('joint_commands', plugin(math.nan, name=('pinion_1',)))
    assert not carries_no_command('joint_commands', plugin(0.0))
    assert not carries_no_command('joint_commands', plugin(math.nan, 1.0))
    assert not carries_no_command('joint_commands', plugin())       # nothing: a bad message
    assert not carries_no_command('cmd_effort', [math.nan])         # a bad cmd_effort stays bad
    assert not carries_no_command('cmd_torque', math.nan)


@pytest.mark.parametrize('command', [
    plugin(math.nan, math.nan), plugin(math.nan, math.nan, math.nan),
    plugin(math.nan, position=(math.nan,)), plugin(math.nan, name=('table', 'pinion_3')),
    plugin(math.nan, name=('pinion_1', 'joint_1')),
])
def test_a_malformed_nan_message_is_refused_as_its_finite_twin_is(command):
    """NaN in a message the plugin could not send is no "not yet commanded": it is
    refused with the reason its finite twin gets."""
    assert not carries_no_command('joint_commands', command)
    finite = replace(command, effort=tuple(1.0 for _ in command.effort),
                     position=tuple(1.0 for _ in command.position))
    with pytest.raises(InputRejected) as nan_info:
        apply_command(NOW, 'joint_commands', command, P)
    with pytest.raises(InputRejected) as finite_info:
        apply_command(NOW, 'joint_commands', finite, P)
    rules = [str(info.value).replace(repr(info.value.value), '')
             for info in (nan_info, finite_info)]
    assert rules[0] == rules[1]


def test_nan_from_the_plugin_with_other_joint_names_carries_no_command():
    names = ('drive', 'turntable', 'backup')
    assert carries_no_command('joint_commands', plugin(math.nan, name=names), names)
    assert not carries_no_command('joint_commands', plugin(math.nan, name=names))


def test_message_and_value_convert_both_ways_for_live_and_recorded_messages():
    """The node's command_value of a live message, the recording's input_message, and the
    bag reader's command_value of the decoded recording all agree."""
    from screwgear_ros.bag.format import typestore
    from screwgear_ros.bag.messages import input_message as recorded
    from screwgear_ros.ros.messages import input_message
    value = plugin(-12.5)
    msg = input_message('joint_commands', value, 1_500_000_000)
    assert (list(msg.name), list(msg.position), list(msg.velocity), list(msg.effort)) == (
        list(JOINTS), [], [], [-12.5])
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (1, 500_000_000)
    assert command_value('joint_commands', msg) == value
    decoded = typestore().deserialize_cdr(recorded('joint_commands', value, 1_500_000_000),
                                         'sensor_msgs/msg/JointState')
    assert command_value('joint_commands', decoded) == value
    effort = input_message('cmd_effort', [4.0])
    assert command_value('cmd_effort', effort) == [4.0]
    assert command_value('cmd_effort', typestore().deserialize_cdr(
        recorded('cmd_effort', [4.0]), 'std_msgs/msg/Float64MultiArray')) == [4.0]


def test_a_plain_float_effort_folds_exactly_as_any_other_number_of_its_value():
    """A plain float within max_torque is taken without the full checks; a float
    subclass (numpy's) gets them. Both give the same input, bit for bit, and the same
    refusal, over a seeded spread of efforts around the limits and the deadband."""
    import numpy as np
    rng = np.random.default_rng(28)
    band, top = P.effort_deadband, P.max_torque
    efforts = [0.0, -0.0, band, -band, 2.0 * band, top, -top, np.nextafter(top, np.inf),
               -np.nextafter(top, np.inf), math.nan, math.inf, -math.inf,
               *rng.uniform(-1.2 * top, 1.2 * top, 200), *(rng.uniform(-3, 3, 50) * band)]

    def fold(value):
        try:
            return apply_command(NOW, 'cmd_effort', [value], P)
        except InputRejected as error:
            return str(error).replace(repr(value), '<value>')

    for effort in efforts:
        plain = fold(float(effort))
        assert plain == fold(np.float64(effort))
        if isinstance(plain, DriveInput):
            assert math.copysign(1.0, plain.torque) == 1.0 and plain.torque == abs(effort) or (
                plain.torque == 0.0 and abs(effort) <= band)
