"""Reading recordings: a plain bag (joint_states + cmd_effort, sqlite3, no run_parameters)
holds the same samples and commands as the node's own recording, the re-simulation of
either at the true parameters is the node's run, a lost or repeated sample is reported
and changes nothing else, and bad bags are refused."""

from __future__ import annotations

import math

import numpy as np
import pytest
from identify_truth import PRESET, copy_topics, truth_simulation

from screwgear_ros.bag.reader import read_run
from screwgear_ros.errors import ScrewgearError
from screwgear_ros.identification.adapter import simulate
from screwgear_ros.identification.errors import RecordingError
from screwgear_ros.identification.recording import parse_joints, read_recording
from screwgear_ros.inprocess.simulation import file_values
from screwgear_ros.interface import Input


def test_a_plain_bag_gives_the_ticks_of_the_node_recording(recordings):
    node, plain = read_recording(recordings['node']), read_recording(recordings['plain'])
    assert node.samples == plain.samples == 3001
    np.testing.assert_array_equal(node.position, plain.position)
    assert node.inputs == plain.inputs
    assert all(topic is Input.CMD_EFFORT for _, topic, _ in node.inputs)
    # the controller answered every sample but the last, from that sample's time on
    assert [t for t, _, _ in node.inputs] == [k * 1_000_000 for k in range(3000)]
    assert node.reversals == plain.reversals == 3       # +bias, −bias, +slow, −slow


def test_the_resimulation_at_the_truth_is_the_recorded_run(recordings):
    """Independent of the reader's tick rule: the exact joint states the node recorded
    (~/true_joint_states) are what the re-simulation makes with ideal sensors."""
    exact = read_run(recordings['node']).true_joint_states.values
    ideal = {name: 0 for name in file_values(PRESET) if name.startswith(
        ('encoder_counts', 'measurement_delay'))}
    ideal.update({name: 0.0 for name in file_values(PRESET) if name.startswith(
        ('position_noise', 'velocity_filter'))})
    simulation = truth_simulation(**ideal)
    values = {**simulation.params.as_dict(), **simulation.settings.as_dict()}
    out = simulate(values, read_recording(recordings['plain']))
    assert out.tobytes() == exact[:, :6].tobytes()


def test_an_input_delay_moves_every_command_by_its_ticks(recordings):
    delayed = read_recording(recordings['plain'], input_delay=2.5)
    assert [t for t, _, _ in delayed.inputs] == [k * 1_000_000 + 2_500_000
                                                 for k in range(2998)]


def test_joint_names_are_mapped(recordings, tmp_path):
    def rename(topic, message):
        if topic == 'joint_states':
            message.name = ['motor_a', 'axis', 'motor_b']
        return message
    bag = copy_topics(recordings['node'], tmp_path / 'renamed', ['joint_states', 'cmd_effort'],
                      storage='mcap', change=rename)
    with pytest.raises(RecordingError, match='--joints'):
        read_recording(bag)
    mapped = read_recording(bag, parse_joints('pinion_1=motor_a,table=axis,pinion_3=motor_b'))
    np.testing.assert_array_equal(mapped.position, read_recording(recordings['plain']).position)


@pytest.mark.parametrize('keep, problem', [(['joint_states'], 'no commands'),
                                           (['cmd_effort'], 'no joint_states')])
def test_a_bag_without_commands_or_joint_states_is_refused(recordings, tmp_path, keep, problem):
    bag = copy_topics(recordings['node'], tmp_path / 'part', keep)
    with pytest.raises(RecordingError, match=problem) as caught:
        read_recording(bag)
    assert isinstance(caught.value, ScrewgearError) and str(bag) in str(caught.value)


def test_values_that_are_not_finite_are_refused(recordings, tmp_path):
    def spoil(topic, message):
        if topic == 'joint_states' and message.header.stamp.nanosec == 500_000_000:
            position = message.position.copy()
            position[1] = math.nan
            message.position = position
        return message
    bag = copy_topics(recordings['node'], tmp_path / 'nan', ['joint_states', 'cmd_effort'],
                      change=spoil)
    with pytest.raises(RecordingError, match='sample 500 .*not finite'):
        read_recording(bag)


def test_lost_samples_are_reported_and_change_nothing_else(recordings, tmp_path):
    plain = read_recording(recordings['plain'])
    gone = {700_000_000, 701_000_000, 1_200_000_000}

    def lose(topic, message):
        stamp = message.header.stamp.sec * 10 ** 9 + message.header.stamp.nanosec \
            if topic == 'joint_states' else None
        if stamp in gone:
            return None
        return message
    bag = copy_topics(recordings['node'], tmp_path / 'lost', ['joint_states', 'cmd_effort'],
                      change=lose)
    lossy = read_recording(bag)
    assert lossy.samples == plain.samples - 3 and lossy.inputs == plain.inputs
    assert any('3 samples lost' in line for line in lossy.timing), lossy.timing
    keep = ~np.isin(plain.times, list(gone))
    np.testing.assert_array_equal(lossy.position, plain.position[keep])
    from identify_truth import write_base

    from screwgear_ros.identification.adapter import base_values
    base = base_values(write_base(tmp_path / 'base.yaml', []))
    np.testing.assert_array_equal(simulate(base, lossy), simulate(base, plain)[keep])


def test_a_path_that_is_no_bag_and_bad_joint_maps_are_refused(tmp_path):
    with pytest.raises(RecordingError, match='cannot read'):
        read_recording(tmp_path)
    with pytest.raises(RecordingError, match='NODE=BAG'):
        parse_joints('wheel=axis')
