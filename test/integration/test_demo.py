"""The demo holds its targets quietly and tracks its profile cleanly, read from recordings.

Each drive path pushes one way only, so a step of the demo profile accelerates on one
path and brakes on the other, and the braking path is the one the next step back
starts on: at most one path switch per target step (every step of the back-and-forth
profile reverses the target's motion), and none while the table holds a target, i.e.
within the law's hold band (``DemoGains.hold_error`` of the target, under
``DemoGains.hold_speed``). The recordings are read with rosbags (a second reader, not
the package's): joint_states and the latched active_path, by log time (simulation time).

Tracking (screwgear_ros.inprocess.metrics on the recorded table angle): the design is critically
damped at ω_n = 20 rad/s, whose 2 % settling time is about 5.8/ω_n = 0.29 s with no
overshoot; the bounds below leave room for the mesh ripple and the torque limit.
Lockstep (table_sim ``lockstep:=true``, real_time_factor 0, with demo_controller over
DDS) makes the run independent of the machine's load, so the same bounds hold with two
busy loops beside it; the only wall-clock limits are generous timeouts.
"""

from __future__ import annotations

import signal
import subprocess
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from paths import ROOT
from ros_procs import STARTUP_TIMEOUT, Peer, assert_clean_exit, stamp_ns, start_process
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore
from rosgraph_msgs.msg import Clock

from screwgear_ros import Simulation
from screwgear_ros.inprocess.metrics import run_metrics
from screwgear_ros.sim.control import DemoController, DemoGains

CONFIG = ROOT / 'config' / 'paper.yaml'
STORE = get_typestore(Stores.ROS2_JAZZY)
GAINS = DemoGains()
MAX_OVERSHOOT = 0.01      # of the step
MAX_SETTLING = 0.5        # s of simulation time into 2 % of the step
RUN_TIMEOUT = 300.0       # s of wall time for a few s of lockstep simulation, under load


@dataclass
class Recorded:
    """A recording read with rosbags: joint_states samples and the path switches."""

    time: np.ndarray          # s: joint_states log times
    angle: np.ndarray         # rad: the table joint
    speed: np.ndarray         # rad/s
    switches: list[float]     # s: log times at which active_path changed
    paths: set[int]           # every active path seen


def read_bag(bag: Path) -> Recorded:
    time, angle, speed, switches, paths, last = [], [], [], [], set(), None
    with Reader(bag) as reader:
        for conn, t, raw in reader.messages():
            if conn.topic.endswith('/joint_states'):
                msg = STORE.deserialize_cdr(raw, conn.msgtype)
                i = list(msg.name).index(GAINS.joint)
                time.append(t * 1e-9)
                angle.append(msg.position[i])
                speed.append(msg.velocity[i])
            elif conn.topic.endswith('/active_path'):
                path = int(STORE.deserialize_cdr(raw, conn.msgtype).data)
                if last is not None and path != last:
                    switches.append(t * 1e-9)
                paths.add(path)
                last = path
    order = np.argsort(time, kind='stable')
    return Recorded(np.array(time)[order], np.array(angle)[order], np.array(speed)[order],
                    switches, paths)


def target(t: float) -> float:
    """The demo profile's target at t s of simulation time from the first answer."""
    return GAINS.targets[int(t // GAINS.dwell) % len(GAINS.targets)]


def assert_quiet_hold(rec: Recorded) -> None:
    """No path switch decided while the table held its target, and at most one switch
    per target step of the run; the table was driven both ways."""
    t0 = rec.time[0]
    for at in rec.switches:
        # the state the controller answered: the last sample before the switch took effect
        k = int(np.searchsorted(rec.time, at)) - 1
        error = target(rec.time[k] - t0) - rec.angle[k]
        assert not (abs(error) <= GAINS.hold_error and abs(rec.speed[k]) <= GAINS.hold_speed), (
            f'path switch at {at - t0:.3f} s while holding the target: error '
            f'{error * 1e3:+.3f} mrad, speed {rec.speed[k] * 1e3:+.2f} mrad/s')
    steps = int((rec.time[-1] - t0) // GAINS.dwell) + 1
    assert len(rec.switches) <= steps, (
        f'{len(rec.switches)} path switches for {steps} target steps at '
        f'{[round(s - t0, 3) for s in rec.switches]} s')
    assert rec.paths == {1, 3}, f'the table was not driven both ways: paths {rec.paths}'


@dataclass
class AngleRun:
    """What run_metrics reads of a run, for the table angle recorded in a bag."""

    time: np.ndarray
    position: np.ndarray

    def __post_init__(self) -> None:
        n = len(self.time)
        self.mesh_force = np.zeros((n, 2))
        self.transmission_error = np.zeros(n)
        self.direction = np.ones(n, dtype=np.int8)   # reversals are not measured here
        self.fault = None

    def __len__(self) -> int:
        return len(self.time)

    @property
    def true_position(self) -> np.ndarray:
        # the demo's sensors are ideal: joint_states carries the exact state
        return self.position


def assert_tracks(rec: Recorded) -> None:
    """Overshoot and settling of every step the run completed, within the bounds."""
    end = rec.time[-1] - rec.time[0]
    jumps = [(k * GAINS.dwell, target((k - 1) * GAINS.dwell), target(k * GAINS.dwell))
             for k in range(1, int(end // GAINS.dwell) + 1)
             if end - k * GAINS.dwell > MAX_SETTLING + 0.1]
    run = AngleRun(rec.time, np.column_stack([rec.angle]))
    m = run_metrics(run, target, joint=0, jumps=jumps)
    assert len(m.steps) == len(jumps) + 1 >= 2, m.steps
    for s in m.steps:
        assert s.overshoot <= MAX_OVERSHOOT * abs(s.size), s
        assert s.settling_time is not None and s.settling_time <= MAX_SETTLING, s


def test_in_process_demo_holds_quietly_and_tracks(tmp_path):
    """The demo law in the node's own loop (Simulation.run), recorded as table_sim
    records: three target steps with their holds."""
    sim = Simulation.from_yaml(CONFIG, real_time_factor=0.0)
    bag = tmp_path / 'demo'
    sim.run(DemoController(GAINS, dt=sim.settings.dt), 3 * GAINS.dwell, record=bag)
    rec = read_bag(bag)
    assert rec.time[-1] - rec.time[0] >= 3 * GAINS.dwell - 0.01
    assert_quiet_hold(rec)
    assert_tracks(rec)


@pytest.mark.ros
def test_lockstep_demo_with_busy_loops_holds_quietly_and_tracks(tmp_path):
    """table_sim and demo_controller as processes, lockstep, with two busy loops
    beside them: the same quiet hold and the same tracking bounds."""
    busy = [subprocess.Popen(['sh', '-c', 'while :; do :; done']) for _ in range(2)]
    sim = ctl = None
    bag = tmp_path / 'bag'
    until = 2 * GAINS.dwell + MAX_SETTLING + 0.2
    try:
        sim = start_process('table_sim', params_file=CONFIG,
                            params={'lockstep': True, 'real_time_factor': 0.0,
                                    'record': str(bag)}, workdir=tmp_path / 'sim')
        with Peer('test_demo') as peer:
            clock = peer.subscribe('/clock', Clock, qos=10, transform=stamp_ns)
            ctl = start_process('demo_controller', workdir=tmp_path / 'ctl')
            clock.wait_for(lambda ns: ns >= until * 1e9, STARTUP_TIMEOUT + RUN_TIMEOUT,
                           f'{until} s of simulation time on /clock')
        assert_clean_exit(sim, signal.SIGINT)      # closes the bag
        assert_clean_exit(ctl, signal.SIGINT)
    finally:
        for p in busy:
            p.kill()
            p.wait(timeout=10)
        for proc in (sim, ctl):
            if proc is not None:
                proc.kill()
    rec = read_bag(bag)
    assert rec.time[-1] - rec.time[0] >= until - 0.1
    assert_quiet_hold(rec)
    assert_tracks(rec)
    assert np.isfinite(rec.angle).all()


@pytest.mark.ros
def test_demo_controller_duration_stops_a_lockstep_run_at_exactly_that_stamp(tmp_path):
    """``demo_controller --duration S`` answers no joint_states stamped at or after S
    simulated seconds and exits 0; table_sim in lockstep integrates no tick without an
    answer, so its recording ends at exactly S."""
    duration = 0.4
    bag = tmp_path / 'bag'
    sim = ctl = None
    try:
        sim = start_process('table_sim', params_file=CONFIG,
                            params={'lockstep': True, 'real_time_factor': 0.0,
                                    'record': str(bag)}, workdir=tmp_path / 'sim')
        ctl = start_process('demo_controller', args=['--duration', str(duration)],
                            workdir=tmp_path / 'ctl')
        assert ctl.popen.wait(timeout=STARTUP_TIMEOUT + RUN_TIMEOUT) == 0, ctl.output()
        assert 'stop time' in ctl.output()[1] + ctl.output()[0]
        assert_clean_exit(sim, signal.SIGINT)      # closes the bag
    finally:
        for proc in (sim, ctl):
            if proc is not None:
                proc.kill()
    rec = read_bag(bag)
    assert round(rec.time[-1] * 1e9) == round(duration * 1e9), rec.time[-1]
