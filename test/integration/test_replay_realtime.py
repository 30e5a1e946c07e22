"""A real-time demo recording replays exactly: lockstep replay_run --compare over DDS.

table_sim at real_time_factor 1 with demo_controller beside it is what users record. Its
commands arrive when the transport delivers them, so some ticks apply several (the
controller answered late samples in a burst), and the replay must send them all before
it lets the node integrate. The joint_states of both bags are read with rosbags, a
reader independent of the package's own, and must be equal bit for bit, stamps
included.

``test/data/realtime_demo`` was recorded that way by ``scripts/record_test_bags.sh
realtime_demo`` and is known to hold ticks with several commands; the live test records
a fresh one each run (how many commands share a tick then depends on the machine).
"""

from __future__ import annotations

import signal
import time
from collections import Counter
from pathlib import Path

import pytest
from bag_runs import installed
from paths import DATA, ROOT
from ros_procs import STARTUP_TIMEOUT, Peer, start_process
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore
from std_msgs.msg import Float64MultiArray

from screwgear_ros.bag.reader import read_run
from screwgear_ros.runs.lockstep_plan import plan_from_run
from screwgear_ros.sim.events import Command

CONFIG = ROOT / 'config' / 'paper.yaml'
TOOL_TIMEOUT = 600.0
LIVE_SECONDS = 2.0       # s of wall time the live recording runs with the controller


def joint_states(bag: Path) -> list[tuple[int, tuple, tuple, tuple]]:
    """(stamp ns, position, velocity, effort) of every joint_states in ``bag``, by rosbags."""
    store = get_typestore(Stores.ROS2_JAZZY)
    out = []
    with Reader(bag) as reader:
        connections = [c for c in reader.connections if c.topic.endswith('/joint_states')]
        assert connections, f'{bag} has no joint_states'
        for connection, _, raw in reader.messages(connections=connections):
            msg = store.deserialize_cdr(raw, connection.msgtype)
            stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
            out.append((stamp, tuple(msg.position), tuple(msg.velocity), tuple(msg.effort)))
    return out


def commands_per_tick(bag: Path) -> Counter:
    """How many ticks applied how many commands."""
    plan = plan_from_run(read_run(bag))
    per_tick = Counter(tick for tick, event in plan.events if isinstance(event, Command))
    return Counter(per_tick.values())


def replay_exactly(bag: Path, tmp_path: Path) -> None:
    new = tmp_path / 'replayed'
    result = installed('replay_run', bag, '--record', new, '--compare', timeout=TOOL_TIMEOUT)
    assert 'Traceback' not in result.stdout + result.stderr, result.stdout + result.stderr
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'IDENTICAL' in result.stdout, result.stdout
    original, replayed = joint_states(bag), joint_states(new)
    assert len(original) > 100
    assert replayed == original          # floats compared exactly, stamps included


@pytest.mark.ros
def test_the_checked_in_real_time_recording_replays_bit_for_bit(tmp_path: Path) -> None:
    several = commands_per_tick(DATA / 'realtime_demo')
    assert max(several) >= 2, several    # what a real-time recording has and lockstep must keep
    replay_exactly(DATA / 'realtime_demo', tmp_path)


def record_real_time_demo(bag: Path, workdir: Path, seconds: float) -> None:
    """table_sim (paper parameters, real time) recording to ``bag`` with demo_controller
    driving it for ``seconds`` of wall time from its first command; both stopped with
    SIGINT. The controller starts first, so the recording holds little before it."""
    bag = bag.resolve()
    with Peer('watch_the_controller') as peer:
        efforts = peer.subscribe('cmd_effort', Float64MultiArray)
        controller = start_process('demo_controller', workdir=workdir / 'controller')
        sim = start_process('table_sim', params_file=CONFIG,
                            params={'record': str(bag), 'real_time_factor': 1.0},
                            workdir=workdir / 'sim')
        try:
            efforts.wait_for(lambda m: True, STARTUP_TIMEOUT, 'the controller\'s first command')
            time.sleep(seconds)
            assert controller.alive() and sim.alive(), sim.output()
            controller.stop(signal.SIGINT, timeout=30.0)
            code, _ = sim.stop(signal.SIGINT, timeout=30.0)
            assert code == 0, sim.output()
        finally:
            controller.kill()
            sim.kill()


@pytest.mark.ros
def test_a_fresh_real_time_demo_recording_replays_bit_for_bit(tmp_path: Path) -> None:
    bag = tmp_path / 'realtime'
    record_real_time_demo(bag, tmp_path, LIVE_SECONDS)
    run = read_run(bag)
    assert run.truncated is None
    assert sum(isinstance(e, Command) for _, e in run.events) > 10
    replay_exactly(bag, tmp_path)


if __name__ == '__main__':
    # scripts/record_test_bags.sh realtime_demo: python test/test_replay_realtime.py BAG SECONDS
    import sys
    import tempfile
    target, seconds = Path(sys.argv[1]), float(sys.argv[2])
    record_real_time_demo(target, Path(tempfile.mkdtemp(prefix='realtime_demo_')), seconds)
    counts = commands_per_tick(target)
    print(f'{target}: ticks by the number of commands they applied: {dict(sorted(counts.items()))}')
    sys.exit(0 if max(counts, default=0) >= 2 else 1)   # 1: no tick applied several; again
