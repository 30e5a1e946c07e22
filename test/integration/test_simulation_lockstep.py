"""Simulation.run and table_sim in lockstep give the same bits for the same controller.

The controller is one Python function of the observation (a PD law on a moving target,
which reverses the drive). In-process it closes the loop through
``Simulation.run(record=...)``; over DDS an rclpy node in this process answers each new
joint_states stamp of a ``table_sim`` process in lockstep with the same function, fed
with what the message carries. Both runs are recorded; the recorded joint_states are
read back with rosbags (not with the package's reader) and compared bit for bit.
"""

from __future__ import annotations

import math
import signal
from pathlib import Path

import numpy as np
import pytest
from ros_procs import (
    STARTUP_TIMEOUT,
    Peer,
    assert_clean_exit,
    record_lockstep_demo,
    stamp_ns,
    start_process,
)
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from screwgear_ros import Simulation
from screwgear_ros.inprocess.simulation import Observation

STORE = get_typestore(Stores.ROS2_JAZZY)
VALUES = {'table_damping': 8867.0, 'command_timeout': 0.0, 'publish_rate': 1000.0}
TICKS = 500                  # 0.5 s of simulation at 1 kHz
TICK_NS = 1_000_000
RUN_TIMEOUT = 300.0          # s of wall time for TICKS lockstep ticks on a loaded machine


def pd(o: Observation) -> float:
    """A PD law on a target that swings ±20 mrad at 2 Hz: the drive reverses."""
    target = 0.02 * math.sin(2.0 * math.pi * 2.0 * o.time)
    wanted = 4000.0 * (target - o.position[1]) - 250.0 * o.velocity[1]
    return max(-300.0, min(300.0, wanted))


def observation_of(msg: JointState, dt: float) -> Observation:
    """What the node's joint_states message tells a controller, as an Observation (the
    step from the stamp; what joint_states does not carry is NaN)."""
    step = stamp_ns(msg) // round(dt * 1e9)
    nan = math.nan
    return Observation(step * dt, step, tuple(msg.position), tuple(msg.velocity),
                       tuple(msg.effort), nan, (nan, nan), (nan, nan), (nan, nan), 0, None)


def recorded_joint_states(bag: Path) -> tuple[np.ndarray, np.ndarray]:
    """(stamps ns, (n, 9) θ ω effort) of every joint_states in the bag, via rosbags."""
    stamps, rows = [], []
    with Reader(bag) as reader:
        connections = [c for c in reader.connections if c.topic == '/joint_states']
        for connection, _, raw in reader.messages(connections=connections):
            msg = STORE.deserialize_cdr(raw, connection.msgtype)
            stamps.append(msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec)
            rows.append(np.concatenate([msg.position, msg.velocity, msg.effort]))
    return np.array(stamps), np.array(rows)


def lockstep_run(workdir: Path, dt: float) -> Path:
    """table_sim in lockstep, recording, closed with ``pd`` by an rclpy node here for
    TICKS ticks (the node then waits for an answer that never comes)."""
    bag = workdir / 'node'
    sim = start_process('table_sim', params={**VALUES, 'lockstep': True,
                                             'real_time_factor': 0.0, 'record': str(bag)},
                        workdir=workdir / 'sim')
    try:
        with Peer('test_simulation_lockstep') as peer:
            effort = peer.publisher('/cmd_effort', Float64MultiArray)
            answered: set[int] = set()

            def answer(msg: JointState) -> None:
                t = stamp_ns(msg)
                if t in answered or t >= TICKS * TICK_NS or effort.get_subscription_count() == 0:
                    return           # a re-send, the end of the run, nobody to answer to
                answered.add(t)
                effort.publish(Float64MultiArray(data=[float(pd(observation_of(msg, dt)))]))

            js = peer.subscribe('/joint_states', JointState, transform=stamp_ns)
            peer.node.create_subscription(JointState, '/joint_states', answer, 100)
            js.wait_for(lambda t: t == TICKS * TICK_NS, STARTUP_TIMEOUT + RUN_TIMEOUT,
                        f'{TICKS} lockstep ticks')
        assert_clean_exit(sim, signal.SIGINT)
    finally:
        sim.kill()
    return bag


@pytest.mark.ros
def test_simulation_run_and_the_lockstep_node_record_the_same_bits(tmp_path):
    simulation = Simulation.from_values(VALUES)
    bag = lockstep_run(tmp_path, simulation.settings.dt)
    run = simulation.run(pd, TICKS * 1e-3, record=tmp_path / 'in_process')
    node_stamps, node_rows = recorded_joint_states(bag)
    own_stamps, own_rows = recorded_joint_states(tmp_path / 'in_process')
    assert len(own_stamps) == TICKS + 1 == len(run)
    assert len(node_stamps) >= TICKS + 1, f'the node recorded {len(node_stamps)} ticks'
    np.testing.assert_array_equal(own_stamps, np.arange(TICKS + 1) * TICK_NS)
    np.testing.assert_array_equal(node_stamps[:TICKS + 1], own_stamps)
    differ = np.flatnonzero(np.any(node_rows[:TICKS + 1].view(np.int64)
                                   != own_rows.view(np.int64), axis=1))
    assert differ.size == 0, (f'{differ.size} of {TICKS + 1} joint_states differ, the first '
                              f'at tick {differ[0]}')
    # the run's own arrays are what it recorded, and what it gives unrecorded (a tick
    # then is the session's fast closed-loop tick, with no Tick for a recording)
    assert run.joint_states.tobytes() == own_rows.tobytes()
    assert simulation.run(pd, TICKS * 1e-3).joint_states.tobytes() == own_rows.tobytes()
    # the loop did something worth comparing: the table moved both ways, the drive reversed
    angle = run.position[:, 1]
    assert angle.max() > 5e-3 and angle.min() < -2e-3
    assert {1, 3} <= set(run.active_path.tolist())


@pytest.mark.ros
def test_the_demo_controller_gives_the_same_bits_in_process_and_as_a_node(tmp_path):
    """demo_controller (the rclpy node) around table_sim in lockstep, and the same law
    in-process (screwgear_ros.sim.control.DemoController): the same joint_states."""
    from screwgear_ros.sim.control import DemoController
    targets, dwell, ticks = [0.03, -0.03], 0.25, 600
    values = {**VALUES, 'table_damping': 0.0}     # the demo's tuning: no bearing loss
    bag = record_lockstep_demo(tmp_path, values, targets, dwell, ticks, TICK_NS,
                               'test_demo_identity')
    simulation = Simulation.from_values(values)
    controller = DemoController(targets=targets, dwell=dwell, dt=simulation.settings.dt)
    simulation.run(controller, ticks * 1e-3, record=tmp_path / 'in_process')
    node_stamps, node_rows = recorded_joint_states(bag)
    own_stamps, own_rows = recorded_joint_states(tmp_path / 'in_process')
    assert len(node_stamps) >= ticks + 1
    np.testing.assert_array_equal(node_stamps[:ticks + 1], own_stamps)
    assert node_rows[:ticks + 1].tobytes() == own_rows.tobytes()
    angle = own_rows[:, 1]
    assert angle.max() > 0.02 and angle.min() < -0.02      # it followed both targets
