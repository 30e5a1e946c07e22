"""RunIO off the pacing thread: a parameter change's run_parameters YAML and URDF are
rendered by the executor (RunIO.prepare) and only taken when the change takes effect.
The bag is the same message for message as when the pacing thread renders them."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from bag_runs import record_session
from mcap.reader import make_reader

from screwgear_ros.bag.format import typestore
from screwgear_ros.bag.reader import read_run
from screwgear_ros.interface import topic_names
from screwgear_ros.params.table import SimSettings, TableParams
from screwgear_ros.runs.replay_in_process import replay_in_process
from screwgear_ros.runs.run_io import RunIO
from screwgear_ros.sim.events import Command, ParameterChange, Reset
from screwgear_ros.sim.schedule import Schedule
from screwgear_ros.sim.session import Session


def schedule() -> Schedule:
    p, s = TableParams(table_damping=8867.0), SimSettings(publish_rate=500.0)
    return Schedule(p, s, [
        Command('cmd_torque', 300.0, 0),
        ParameterChange(p.replace(mesh_damping=900.0), s, 400),
        ParameterChange(p.replace(mesh_damping=900.0, radius_table=0.62), s, 800),  # a new URDF
        ParameterChange(p.replace(mesh_damping=900.0, radius_table=0.62),
                        SimSettings(publish_rate=250.0), 1200)], end_step=2000)


def messages(bag: Path) -> list[tuple[str, int, str]]:
    """Every message but table_markers (paced by wall time), decoded by rosbags: rclpy
    leaves CDR padding bytes uninitialized, so raw bytes of its messages may differ."""
    store = typestore()
    mcap_file, = bag.glob('*.mcap')
    with open(mcap_file, 'rb') as stream:
        return [(channel.topic, message.log_time,
                 repr(store.deserialize_cdr(bytes(message.data), schema.name)))
                for schema, channel, message in make_reader(stream).iter_messages(
                    log_time_order=False) if channel.topic != '/table_markers']


def test_prepared_parameter_texts_record_the_same_bag(tmp_path):
    plain = messages(Path(record_session(tmp_path / 'plain', schedule()).path))
    prepared = messages(Path(record_session(tmp_path / 'prepared', schedule(),
                                            prepare=True).path))
    assert prepared == plain
    topics = [t for t, _, _ in plain]
    assert topics.count('/table_sim/run_parameters') == 4      # the start and three changes
    assert topics.count('/robot_description') == 2             # the start and the new radius


def test_a_prepared_change_is_taken_by_the_tick_that_applies_it(tmp_path):
    p, s = TableParams(), SimSettings()
    session = Session(p, s)
    io = RunIO(topic_names(), s.joint_names)
    recorder = io.open_recorder(tmp_path / 'bag')
    io.start(session)
    changed = p.replace(mesh_damping=900.0)
    io.prepare(session, changed, s)
    assert list(io._rendered) == [(changed, s)]
    session.submit(ParameterChange(changed, s))
    io.tick(session, session.tick())
    assert io._rendered == {}
    recorder.close()


def test_several_changes_in_one_tick_record_each_its_own_parameters(tmp_path):
    """rclpy calls the parameter callback once per parameter, so one request can put
    several changes (and a reset) into one tick: each run_parameters records its own
    change, so the bag replays bit for bit."""
    p, s = TableParams(table_damping=8867.0), SimSettings(publish_rate=500.0)
    a = p.replace(mesh_damping=900.0, preload_torque=300.0)
    b = a.replace(preload_torque=250.0)
    schedule = Schedule(p, s, [Command('cmd_torque', 300.0, 0), ParameterChange(a, s, 400),
                               Reset(400), ParameterChange(b, s, 400)], end_step=1200)
    run = read_run(record_session(tmp_path / 'bag', schedule, prepare=True).path)
    recorded = [e.params.preload_torque for _, e in run.events
                if isinstance(e, ParameterChange)]
    assert recorded == [300.0, 250.0]               # a, then b, in order
    replayed = replay_in_process(run)
    assert np.array_equal(replayed.joint_states, run.joint_states.values)


def test_a_subscriber_that_comes_mid_run_gets_every_tick_from_its_match_on():
    """RunIO publishes a tick's topic only once a subscription has matched it (the
    run_io module docstring): over real DDS between two in-process nodes, a subscriber
    that comes after the run started gets every tick's message on each of the four
    topics from its match on. Lockstep with this test: each tick waits for its messages."""
    from ros_procs import Peer, stamp_ns, wait_until
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64

    from screwgear_ros.ros.messages import OUTPUT_TYPES
    from screwgear_ros.sim.simtime import sim_time_ns

    keys = ('clock', 'joint_states', 'mesh_state', 'transmission_error')
    topics = topic_names(namespace='/mid_run')
    p, s = TableParams(), SimSettings()
    session = Session(p, s)
    session.submit(Command('cmd_torque', 5.0))     # moving: every tick's values differ
    with Peer('run_io_publisher') as source:
        publishers = {k: source.node.create_publisher(OUTPUT_TYPES[k][1], topics[k], 10)
                      for k in keys}
        io = RunIO(topics, s.joint_names, publishers)
        io.start(session)
        for _ in range(20):                       # nobody listens yet
            io.tick(session, session.tick())
        with Peer('run_io_subscriber') as sink:
            inboxes = {
                'clock': sink.subscribe(topics['clock'], Clock,
                                        transform=stamp_ns),
                'joint_states': sink.subscribe(topics['joint_states'], JointState,
                                               transform=lambda m: (stamp_ns(m),
                                                                    tuple(m.position))),
                'mesh_state': sink.subscribe(topics['mesh_state'], JointState,
                                             transform=lambda m: (stamp_ns(m),
                                                                  tuple(m.position))),
                'transmission_error': sink.subscribe(topics['transmission_error'], Float64,
                                                     transform=lambda m: m.data)}
            for k in keys:
                wait_until(lambda k=k: publishers[k].get_subscription_count() > 0, 10.0,
                           f'the subscriber matching {topics[k]}')
                wait_until(lambda k=k: sink.node.count_publishers(topics[k]) > 0, 10.0,
                           f'the publisher of {topics[k]} seen by the subscriber')
            expected: dict[str, list] = {k: [] for k in keys}
            for n in range(1, 31):
                tick = session.tick()
                io.tick(session, tick)
                out, t_ns = tick.outputs, sim_time_ns(tick.outputs.step, s.dt)
                expected['clock'].append(t_ns)
                expected['joint_states'].append((t_ns, out.position))
                expected['mesh_state'].append((t_ns, out.delta))
                expected['transmission_error'].append(out.transmission_error)
                for k in keys:
                    wait_until(lambda k=k, n=n: len(inboxes[k].snapshot()) >= n, 10.0,
                               f'message {n} on {topics[k]}')
            for k in keys:
                assert inboxes[k].snapshot() == expected[k], k


def test_an_in_process_run_waits_for_the_recorder_instead_of_dropping(tmp_path, monkeypatch):
    """RunIO.tick is lossless unless told otherwise (only the node in real time has a
    deadline): 2000 ticks recorded in-process through a queue of 40 messages lose
    nothing, and the bag holds every tick's outputs."""
    from screwgear_ros.bag import recorder as recording
    monkeypatch.setattr(recording, 'ROOM_TIMEOUT', 60.0)    # a margin, not a measurement
    p, s = TableParams(), SimSettings()
    recorder = record_session(tmp_path / 'bag', Schedule(
        p, s, [Command('cmd_torque', 300.0, 0)], end_step=2000 * s.steps_per_publish),
        queue_size=40)
    assert (recorder.dropped, recorder.error) == (0, None)
    steps = read_run(tmp_path / 'bag').joint_states.steps    # the start and every tick
    assert list(steps) == [k * s.steps_per_publish for k in range(2001)]
