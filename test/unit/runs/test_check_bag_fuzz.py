"""Seeded fuzz of check_run's verdict on edited bags of a run with non-ideal sensors: a
joint_states message duplicated, dropped or moved to another topic is a damaged bag
(InvalidBag: exit 2 with what is wrong), never a physics FAIL; and an edit the in-process
replay of the recorded inputs sees is a finding (not ok), whatever the tolerance allows."""

from __future__ import annotations

import random
import time
from pathlib import Path

import pytest
from bag_runs import bag_messages, write_bag
from rosbags.typesys import Stores, get_typestore

from screwgear_ros.bag import TopicSpec
from screwgear_ros.bag.errors import BagError, InvalidBag
from screwgear_ros.bag.reader import read_run
from screwgear_ros.inprocess.simulation import Simulation
from screwgear_ros.runs.check import check_run
from screwgear_ros.runs.check.verdict import require_samples

SEED = 3716
CASES = 120
BUDGET = 300.0
STORE = get_typestore(Stores.ROS2_JAZZY)


@pytest.fixture(scope='module')
def noisy_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A short recorded run whose joint sensors are not ideal."""
    bag = tmp_path_factory.mktemp('noisy') / 'run'
    sim = Simulation.from_values(publish_rate=1000.0, position_noise_table=1e-6,
                                 encoder_counts_table=2**20)
    sim.run(lambda _o: 200.0, 0.03, record=bag)
    return bag


def test_a_damaged_joint_states_stream_is_a_damaged_bag(noisy_bag: Path, tmp_path: Path) -> None:
    channels, messages = bag_messages(noisy_bag)
    joint_states = [i for i, (c, _, _) in enumerate(messages)
                    if channels[c].name.endswith('/joint_states')]
    assert len(joint_states) > 20
    rng = random.Random(SEED)
    started = time.monotonic()
    for case in range(CASES):
        kind = rng.choice(('duplicate', 'drop', 'rename'))
        k = joint_states[rng.randrange(1, len(joint_states))]
        specs = list(channels.values())
        out = [(channels[c].name, t, d) for c, t, d in messages]
        topic, log_time, data = out[k]
        if kind == 'duplicate':
            out.insert(k + 1, (topic, log_time, data))
        elif kind == 'drop':
            del out[k]
        else:
            other = topic.replace('joint_states', rng.choice(('joint_statez', 'js', 'joint')))
            specs.append(TopicSpec(other, channels[messages[k][0]].msgtype, False))
            out[k] = (other, log_time, data)
        bag = write_bag(tmp_path / f'b{case}', specs, out)
        try:
            require_samples(read_run(bag))
        except BagError as exc:
            assert isinstance(exc, BagError), f'seed {SEED} case {case} ({kind})'
        except Exception as exc:  # noqa: BLE001 - the finding: anything undocumented
            pytest.fail(f'seed {SEED} case {case} ({kind}): {type(exc).__name__}: {exc}')
        else:
            pytest.fail(f'seed {SEED} case {case} ({kind} joint_states message {k}): taken '
                        'as a whole bag')
        assert time.monotonic() - started < BUDGET, f'seed {SEED}: over budget at {case}'
    channels_out = [*channels.values()]
    doubled = [(channels[c].name, t, d) for c, t, d in messages]
    doubled.insert(joint_states[5] + 1, doubled[joint_states[5]])
    with pytest.raises(InvalidBag, match='missing, extra or on another topic'):
        require_samples(read_run(write_bag(tmp_path / 'doubled', channels_out, doubled)))


def test_a_recording_its_inputs_do_not_make_is_not_passed(noisy_bag: Path,
                                                         tmp_path: Path) -> None:
    """An edit of the table's recorded effort (true_joint_states) by -0.01 N·m at one
    sample: within the reference's tolerance, but not what the recorded inputs make."""
    channels, messages = bag_messages(noisy_bag)
    rng = random.Random(SEED + 1)
    exact = [i for i, (c, _, _) in enumerate(messages)
             if channels[c].name.endswith('/true_joint_states')]
    for case in range(3):
        k = exact[rng.randrange(1, len(exact))]
        out = [(channels[c].name, t, d) for c, t, d in messages]
        topic, log_time, data = out[k]
        msgtype = channels[messages[k][0]].msgtype
        msg = STORE.deserialize_cdr(data, msgtype)
        effort = msg.effort.copy()
        effort[1] -= 0.01
        msg.effort = effort
        out[k] = (topic, log_time, bytes(STORE.serialize_cdr(msg, msgtype)))
        report = check_run(read_run(write_bag(tmp_path / f'e{case}', list(channels.values()), out)),
                           parallel=False)
        assert not report.replay_identical, f'seed {SEED + 1} case {case}'
        assert not report.ok and not report.undecided, f'seed {SEED + 1} case {case}'
