"""The checked-in bags (written by table_sim through RunRecorder with ``mcap``) read back
with other libraries, and the project's reader agrees with them.

- ``rosbags`` (rosbag2 directory reader: metadata.yaml, MCAP index, its own CDR
  codec) decodes every message, and its counts match metadata.yaml and the MCAP
  statistics;
- ``mcap_ros2`` decodes every message with decoders built from the embedded schemas
  (what Foxglove does);
- ``runs.bagread.read_run`` (file order through ``mcap``'s stream reader) yields the
  same joint states, transmission errors and commands as rosbags, in the same order.
"""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from bag_runs import BAGS
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from paths import DATA
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore

from screwgear_ros.bag.reader import Command, ParameterChange, Reset, read_run

STORE = get_typestore(Stores.ROS2_JAZZY)


@pytest.mark.parametrize('name', BAGS)
def test_rosbags_and_mcap_ros2_decode_every_message(name: str) -> None:
    bag = DATA / name
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    with Reader(bag) as reader:
        decoded = [(c.topic, t, STORE.deserialize_cdr(raw, c.msgtype))
                   for c, t, raw in reader.messages()]
        assert {c.topic: c.msgcount for c in reader.connections} == {
            t['topic_metadata']['name']: t['message_count']
            for t in info['topics_with_message_count']}
    assert len(decoded) == info['message_count']
    mcap_file, = bag.glob('*.mcap')
    with open(mcap_file, 'rb') as stream:
        mcap = make_reader(stream, decoder_factories=[DecoderFactory()])
        n = sum(1 for _ in mcap.iter_decoded_messages(log_time_order=False))
        assert n == mcap.get_summary().statistics.message_count == len(decoded)

    run = read_run(bag)
    assert run.message_count == len(decoded)
    ordered = sorted(decoded, key=lambda d: d[1])   # rosbags: log-time order
    joints = [m for topic, _, m in ordered if topic.endswith('/joint_states')]
    names = list(run.parameters.settings.joint_names)
    assert [list(m.name) for m in joints] == [names] * len(joints)
    expected = np.array([[*m.position, *m.velocity, *m.effort] for m in joints])
    assert np.array_equal(run.joint_states.values, expected)
    te = [m.data for topic, _, m in ordered if topic.endswith('/transmission_error')]
    assert np.array_equal(run.transmission_error.values[:, 0], te)
    commands = [(topic.rsplit('/', 1)[1], t, m) for topic, t, m in decoded
                if topic.rsplit('/', 1)[1].startswith(('cmd_', 'load_'))]
    ours = [e for _, e in run.events if isinstance(e, Command)]
    assert [(c.topic, c.step * 50_000) for c in ours] == [(k, t) for k, t, _ in commands]


def test_the_scenarios_are_in_the_bags() -> None:
    """Each bag holds what its scenario promises (so the tests on them mean something)."""
    runs = {name: read_run(DATA / name) for name in BAGS}
    for run in runs.values():
        assert run.parameters.params.table_damping == 8867.0
        assert run.parameters.settings.publish_rate == 200.0 and run.dt == 50e-6
        assert run.end_step * run.dt >= 4.0
    speed = runs['steady_drive'].joint_states.values[:, 4]
    assert abs(speed[-1] - 0.337) < 0.01                     # the paper's table speed
    for name in ('reversals_anti_backlash', 'reversals_conventional'):
        run = runs[name]
        speed = run.joint_states.values[:, 4]
        assert speed.max() > 0.3 and speed.min() < -0.3
        assert sum(isinstance(e, Command) and e.topic == 'cmd_direction'
                   for _, e in run.events) == 3
        assert set(run.active_path.values[:, 0]) == (
            {1.0, 3.0} if name.endswith('anti_backlash') else {1.0})
    assert runs['reversals_conventional'].parameters.params.mode == 'conventional'
    events = [e for _, e in runs['load_steps_parameter_changes'].events]
    assert sum(isinstance(e, Reset) for e in events) == 1
    changes = [e.params for e in events if isinstance(e, ParameterChange)]
    assert {p.mesh_damping for p in changes} > {717.4777661364236}
    assert {p.table_damping for p in changes} == {8867.0, 12000.0}
    loads = [e.value for e in events if isinstance(e, Command) and e.topic == 'load_torque']
    assert loads == [500.0, -300.0]
