"""The joint sensors (screwgear_ros/physics/sensors.py) against closed forms and second readers.

- every published position is a whole number of counts (read back with rosbags), and
  a joint with counts only reports the backward difference of its counts over the tick;
- the noise over 10⁵ samples has the declared σ within 2 %, is normal (kurtosis),
  uncorrelated between joints and between angle and speed, and a pure function of
  (seed, step, joint): measured in any order, in any chain, it is the same;
- a delay of k ticks shifts the measured signal by exactly k ticks against the true
  one (and against the undelayed measurement, noise included); the physics is untouched;
- with every sensor ideal joint_states is the exact state and no ~/true_joint_states
  is recorded; an ideal joint beside non-ideal ones publishes its exact state;
- a reset restarts the sensors' chain (no speed across it, the delay line refilled);
- the same seed gives a bit-identical bag (wall-clock paced topics aside), another seed
  other joint_states only;
- check_run passes a sensor run with a reset, and refuses (FAIL, naming the topic and
  the tick) a copy, written with the mcap library, whose one measured value was altered;
- plot_run draws the measurement over the exact state;
- over DDS, a lockstep node replays a sensor run (replay_run --record --compare) and
  reproduces its noise bit for bit.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from bag_runs import installed, installed_check_run
from mcap.reader import make_reader
from mcap.writer import Writer
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from screwgear_ros.inprocess.simulation import Simulation
from screwgear_ros.physics.sensors import JointSensor, SensorChain, SensorConfig
from screwgear_ros.sim.events import Reset

STORE = get_typestore(Stores.ROS2_JAZZY)
COUNTS = (4096, 1 << 20, 1000)          # a power of two, a 20-bit encoder, a round number
NOISY = {'encoder_counts_pinion_1': COUNTS[0], 'encoder_counts_table': COUNTS[1],
             'encoder_counts_pinion_3': COUNTS[2], 'position_noise_table': 2e-6,
             'velocity_noise_pinion_1': 1e-3, 'velocity_noise_table': 3e-4,
             'measurement_delay_pinion_3': 2, 'velocity_filter_cutoff_table': 150.0,
             'sensor_seed': 1234}


def drive(observation) -> float:
    """An open loop: the effort depends on the step only, so every sensor setting sees
    the same physics."""
    return 300.0 if (observation.step // 2000) % 2 == 0 else -250.0


def messages(bag: Path, suffix: str) -> list:
    """(log time, message) of the topic ending in ``suffix``, read with rosbags."""
    with AnyReader([bag], default_typestore=STORE) as reader:
        connections = [c for c in reader.connections if c.topic.endswith(suffix)]
        return [(t, reader.deserialize(raw, c.msgtype))
                for c, t, raw in reader.messages(connections=connections)]


def test_published_positions_are_whole_counts_and_speeds_their_difference(tmp_path):
    values = dict(NOISY, velocity_noise_pinion_1=0.0, position_noise_pinion_1=0.0)
    sim = Simulation.from_values(values)
    sim.run(drive, 0.3, record=tmp_path / 'bag')
    published = messages(tmp_path / 'bag', '/joint_states')
    assert len(published) == 301
    positions = np.array([m.position for _, m in published])
    velocities = np.array([m.velocity for _, m in published])
    for j, counts in enumerate(COUNTS):
        x = positions[:, j] * counts / (2.0 * math.pi)
        # whole counts, up to the rounding of the product count·2π/N and of this one
        assert np.all(np.abs(x - np.rint(x)) <= 8 * np.finfo(float).eps * np.maximum(1, abs(x)))
        assert len(np.unique(np.rint(x))) > 10, 'the joint moved over many counts'
    # pinion 1 has counts only: its speed is the backward difference over the tick
    tick = sim.tick_period
    np.testing.assert_allclose(velocities[1:, 0], np.diff(positions[:, 0]) / tick,
                               rtol=1e-12, atol=1e-9)
    assert velocities[0, 0] == 0.0          # no previous count at the start
    true = np.array([m.position for _, m in messages(tmp_path / 'bag', 'true_joint_states')])
    # the count is the floor: never above the exact angle, less than a count below it
    # (pinion 1, noiseless; pinion 3 is delayed)
    below = true[:, 0] - positions[:, 0]
    assert np.all(below >= 0) and np.all(below < 2 * math.pi / COUNTS[0] * (1 + 1e-9))


def test_noise_has_the_declared_sigma_is_normal_and_a_function_of_seed_step_joint():
    sigmas = ((1e-4, 2e-2), (3e-7, 5e-3), (2e-3, 1.0))
    config = SensorConfig(tuple(JointSensor(position_noise=p, velocity_noise=v)
                                for p, v in sigmas), seed=99)
    chain = SensorChain(config, 50e-6)
    n = 100_000
    steps = 20 * np.arange(n)          # one tick = 20 steps of 50 µs
    out = np.empty((n, 6))
    zero = (0.0, 0.0, 0.0)
    for i, step in enumerate(steps.tolist()):
        position, velocity = chain.measure_values(step, zero, zero)
        out[i] = (*position, *velocity)
    declared = np.array([p for p, _ in sigmas] + [v for _, v in sigmas])
    sigma = out.std(axis=0)
    assert np.all(np.abs(sigma / declared - 1.0) < 0.02), sigma / declared
    assert np.all(np.abs(out.mean(axis=0)) < 5 * declared / math.sqrt(n))
    z = out / declared
    kurtosis = np.mean(z ** 4, axis=0) / np.mean(z ** 2, axis=0) ** 2
    assert np.all(np.abs(kurtosis - 3.0) < 0.1), kurtosis       # normal, not uniform (1.8)
    corr = np.corrcoef(z.T) - np.eye(6)
    assert np.max(np.abs(corr)) < 0.02, corr
    # a pure function of (seed, step, joint): a fresh chain, steps in reverse order
    again = SensorChain(config, 50e-6)
    for i in (n - 1, 7, 0, 12345):
        position, velocity = again.measure_values(int(steps[i]), zero, zero)
        assert (*position, *velocity) == tuple(out[i])
    other = SensorChain(SensorConfig(config.joints, seed=100), 50e-6)
    position, velocity = other.measure_values(int(steps[5]), zero, zero)
    assert all(x != y for x, y in zip((*position, *velocity), out[5], strict=False))


@pytest.mark.parametrize('k', [1, 3])
def test_a_delay_of_k_ticks_shifts_the_measurement_by_k_ticks(k):
    base = dict(NOISY, measurement_delay_pinion_3=0)
    undelayed = Simulation.from_values(base).run(drive, 0.15)
    delayed = Simulation.from_values(
        base, measurement_delay_pinion_1=k, measurement_delay_table=k,
        measurement_delay_pinion_3=k).run(drive, 0.15)
    ideal_delayed = Simulation.from_values(measurement_delay_table=k).run(drive, 0.15)
    # the sensors do not touch the physics
    assert np.array_equal(undelayed.observed, delayed.observed)
    assert np.array_equal(undelayed.observed, ideal_delayed.observed)
    # measured(delay k)[i] = measured(no delay)[i − k], noise and counts included
    assert np.array_equal(delayed.measured[k:], undelayed.measured[:-k])
    # the first k samples repeat the chain's first measurement
    assert np.array_equal(delayed.measured[:k], np.repeat(undelayed.measured[:1], k, axis=0))
    # an ideal but late table: its exact state, k ticks late; the pinions untouched
    true = ideal_delayed.observed
    assert np.array_equal(ideal_delayed.measured[k:, [1, 4]], true[:-k, [1, 4]])
    assert np.array_equal(ideal_delayed.measured[:, [0, 2, 3, 5]], true[:, [0, 2, 3, 5]])
    assert not np.array_equal(ideal_delayed.measured[:, 1], true[:, 1])


def test_ideal_sensors_publish_the_exact_state_and_record_no_true_states(tmp_path):
    sim = Simulation.from_values()
    run = sim.run(drive, 0.05, record=tmp_path / 'ideal')
    assert run.measured is None
    with open(next((tmp_path / 'ideal').glob('*.mcap')), 'rb') as stream:
        topics = {c.topic for c in make_reader(stream).get_summary().channels.values()}
    assert '/joint_states' in topics and not any('true_joint_states' in t for t in topics)
    published = messages(tmp_path / 'ideal', '/joint_states')
    values = np.array([(*m.position, *m.velocity) for _, m in published])
    assert np.array_equal(values, run.observed[:, :6])
    # one non-ideal joint: the other two publish their exact state, bit for bit
    sim = Simulation.from_values(encoder_counts_table=1 << 16)
    run = sim.run(drive, 0.05, record=tmp_path / 'table')
    measured = np.array([(*m.position, *m.velocity)
                         for _, m in messages(tmp_path / 'table', '/joint_states')])
    true = np.array([(*m.position, *m.velocity)
                     for _, m in messages(tmp_path / 'table', '/table_sim/true_joint_states')])
    assert np.array_equal(true, run.observed[:, :6])
    assert np.array_equal(measured[:, [0, 2, 3, 5]], true[:, [0, 2, 3, 5]])
    assert not np.array_equal(measured[:, 1], true[:, 1])


#: Paced by the wall clock, not by simulation time: never the same twice.
WALL_TIME = ('/table_markers', '/diagnostics')


def _records(bag: Path) -> list[tuple[str, int, bytes]]:
    """(topic, log time, CDR) of every message in file order, wall-time topics aside; the
    CDR re-encoded by rosbags from its decoding (rclpy leaves the alignment padding
    uninitialized: those bytes are no part of the message)."""
    with open(next(bag.glob('*.mcap')), 'rb') as stream:
        return [(channel.topic, message.log_time, bytes(STORE.serialize_cdr(
                    STORE.deserialize_cdr(message.data, schema.name), schema.name)))
                for schema, channel, message in make_reader(stream).iter_messages(
                    log_time_order=False) if channel.topic not in WALL_TIME]


def test_the_same_seed_gives_a_bit_identical_bag(tmp_path):
    for name, seed in (('a', 7), ('b', 7), ('c', 8)):
        Simulation.from_values(NOISY, sensor_seed=seed).run(drive, 0.1, record=tmp_path / name)
    a, b, c = (_records(tmp_path / name) for name in 'abc')
    assert a == b and len(a) > 400
    differ = {topic for (topic, _, x), (_, _, y) in zip(a, c, strict=False) if x != y}
    # another seed: other measurements, the same physics (run_parameters names the seed)
    assert differ == {'/joint_states', '/table_sim/run_parameters'}


def _altered_copy(src: Path, dst: Path, tick: int) -> None:
    """``src``'s MCAP file rewritten with the mcap library, the table's measured speed at
    sample ``tick`` of joint_states one unit in the last place larger."""
    dst.mkdir()
    source = next(src.glob('*.mcap'))
    with open(source, 'rb') as stream, open(dst / 'altered.mcap', 'wb') as out:
        writer = Writer(out)
        writer.start(profile='ros2', library='test_sensors')
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        seen = 0
        for schema, channel, message in make_reader(stream).iter_messages(
                log_time_order=False):
            if schema.id not in schemas:
                schemas[schema.id] = writer.register_schema(schema.name, schema.encoding,
                                                            schema.data)
            if channel.id not in channels:
                channels[channel.id] = writer.register_channel(
                    channel.topic, channel.message_encoding, schemas[schema.id],
                    dict(channel.metadata))
            data = message.data
            if channel.topic == '/joint_states':
                if seen == tick:
                    msg = STORE.deserialize_cdr(data, schema.name)
                    msg.velocity = msg.velocity.copy()
                    msg.velocity[1] = np.nextafter(msg.velocity[1], np.inf)
                    data = bytes(STORE.serialize_cdr(msg, schema.name))
                seen += 1
            writer.add_message(channels[channel.id], message.log_time, data,
                               message.publish_time, message.sequence)
        writer.finish()


@pytest.mark.ros
def test_check_run_checks_the_measurement_and_refuses_altered_noise(tmp_path):
    sim = Simulation.from_values(NOISY)
    reset = Reset(step=40 * sim.settings.steps_per_publish)
    sim.run(drive, 0.1, record=tmp_path / 'bag', events=[reset])
    result = installed_check_run(tmp_path / 'bag')
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'measured joint_states: 101 samples follow from true_joint_states' in result.stdout
    _altered_copy(tmp_path / 'bag', tmp_path / 'altered', 57)
    result = installed_check_run(tmp_path / 'altered' / 'altered.mcap')
    assert result.returncode == 1, result.stdout + result.stderr
    assert 'Traceback' not in result.stdout + result.stderr
    line = next(x for x in result.stdout.splitlines() if 'measured joint_states' in x)
    assert 'FAIL' in line and '/joint_states' in line and 'from tick 57 on' in line, line
    assert 'table velocity' in line and '(1 of 101 samples differ)' in line, line
    assert 'RESULT: FAIL' in result.stdout and 'true_joint_states' in result.stdout


@pytest.mark.ros
def test_a_lockstep_node_replays_the_sensor_noise_bit_for_bit(tmp_path):
    """One DDS test: replay_run starts table_sim in lockstep with the bag's parameters
    (the sensors' among them) and compares its recording with the original."""
    sim = Simulation.from_values(NOISY)
    sim.run(drive, 0.1, record=tmp_path / 'bag',
            events=[Reset(step=30 * sim.settings.steps_per_publish)])
    result = installed('replay_run', tmp_path / 'bag', '--record', tmp_path / 'again',
                       '--compare')
    assert 'Traceback' not in result.stdout + result.stderr, result.stdout + result.stderr
    assert result.returncode == 0 and 'IDENTICAL' in result.stdout, \
        result.stdout + result.stderr
    for suffix in ('/joint_states', '/table_sim/true_joint_states'):
        original = [(t, tuple(m.position), tuple(m.velocity))
                    for t, m in messages(tmp_path / 'bag', suffix)]
        replayed = [(t, tuple(m.position), tuple(m.velocity))
                    for t, m in messages(tmp_path / 'again', suffix)]
        assert len(original) == 101 and replayed[:len(original)] == original, suffix


def test_a_reset_restarts_the_sensors():
    """A reset moves the table without its encoders turning: the chain starts again at the
    reset tick's sample (speed 0 from the counts, the delay line refilled from it)."""
    sim = Simulation.from_values(encoder_counts_pinion_1=4096, measurement_delay_table=3)
    at = 60
    run = sim.run(drive, 0.1, events=[Reset(step=at * sim.settings.steps_per_publish)])
    assert run.step[at + 1] > run.step[at]                 # sample at + 1: the reset tick's
    assert run.measured[at + 1, 3] == 0.0                  # no difference across the reset
    assert run.measured[at, 3] != 0.0 and run.measured[at + 2, 3] != 0.0
    # the table's delay line starts again: its first 3 samples repeat the reset tick's
    assert np.all(run.measured[at + 1:at + 4, 1] == run.observed[at + 1, 1])
    assert np.array_equal(run.measured[at + 4:, 1], run.observed[at + 1:-3, 1])


def test_plot_run_draws_the_measurement_over_the_exact_state(tmp_path):
    from screwgear_ros.bag.reader import read_run
    from screwgear_ros.runs.plot import Mark, Panel, plt, run_figure
    Simulation.from_values(NOISY).run(drive, 0.05, record=tmp_path / 'bag')
    Simulation.from_values().run(drive, 0.05, record=tmp_path / 'ideal')
    published = messages(tmp_path / 'bag', '/joint_states')
    true = messages(tmp_path / 'bag', 'true_joint_states')
    fig = run_figure(read_run(tmp_path / 'bag'))
    try:
        axes = {ax.get_label(): ax for ax in fig.axes}
        for panel, column, field in ((Panel.TABLE_ANGLE, 1, 'position'),
                                     (Panel.TABLE_SPEED, 1, 'velocity')):
            lines = [a for a in axes[panel].get_children() if a.get_gid() == Mark.MEASURED]
            exact = [a for a in axes[panel].get_lines() if a.get_gid() != Mark.MEASURED]
            assert len(lines) == 1, panel
            assert np.array_equal(lines[0].get_ydata(),
                                  [getattr(m, field)[column] for _, m in published])
            assert np.array_equal(exact[0].get_ydata(),
                                  [getattr(m, field)[column] for _, m in true])
    finally:
        plt.close(fig)
    fig = run_figure(read_run(tmp_path / 'ideal'))
    try:
        assert not [a for ax in fig.axes for a in ax.get_children()
                    if a.get_gid() == Mark.MEASURED]
    finally:
        plt.close(fig)
