"""One declaration of the node's interface (screwgear_ros/interface.py): docs/topics.md's
topic table is generated from it, and what the node subscribes, publishes and records,
and the bag contract the readers enforce, all name the types it declares."""

from __future__ import annotations

from readme_blocks import generated_block
from rosbags.typesys import Stores, get_typestore

from screwgear_ros import interface
from screwgear_ros.bag.cdr import type_name
from screwgear_ros.bag.reader import OUTPUT_TOPICS
from screwgear_ros.ros.messages import INFO_TYPES, INPUT_TYPES, OUTPUT_TYPES
from screwgear_ros.sim.commands import INPUT_TOPICS


def test_the_readme_table_is_generated_from_the_declaration():
    assert generated_block('topics') == interface.topic_table(), \
        'docs/topics.md table is stale: python -m screwgear_ros.interface'


def test_every_declared_type_is_a_real_ros_type():
    store = get_typestore(Stores.ROS2_JAZZY)
    for topic in interface.TOPICS:
        if topic.direction is not interface.Direction.SERVICE:
            assert topic.type in store.types, topic
    classes = {**INPUT_TYPES, **INFO_TYPES, **{k: cls for k, (_, cls) in OUTPUT_TYPES.items()}}
    assert {k: type_name(cls) for k, cls in classes.items()} == {
        t.key: t.type for t in interface.TOPICS
        if t.direction in (interface.Direction.IN, interface.Direction.INFO,
                           interface.Direction.OUT)
        and t.key != interface.TICK_TOPIC}


def test_the_derived_tables_agree():
    assert {t.key: t.type for t in interface.TOPICS
                            if t.direction is interface.Direction.IN and not t.private} == INPUT_TOPICS
    assert set(OUTPUT_TOPICS) <= set(interface.OUTPUT_TOPICS)
    assert set(interface.CONTRACT) == {*INPUT_TOPICS, *INFO_TYPES, *OUTPUT_TOPICS}
    assert not set(interface.INFO_TOPICS) & set(INPUT_TOPICS)   # recorded, never a command
    assert set(interface.ANSWER_TOPICS) <= set(INPUT_TOPICS)
    assert set(interface.OUTPUT_TOPICS) >= interface.LATCHED_OUTPUTS
    names = interface.topic_names('/ns', 'sim')
    assert names['clock'] == '/clock' and names['joint_states'] == '/ns/joint_states'
    assert names['run_parameters'] == '/ns/sim/run_parameters'
    assert names['setpoint'] == '/ns/setpoint'
    assert 'clock' not in interface.topic_names(clock=False)
    assert 'true_joint_states' not in interface.topic_names()       # ideal sensors
    assert interface.topic_names('/ns', 'sim', true_states=True)['true_joint_states'] == \
        '/ns/sim/true_joint_states'
