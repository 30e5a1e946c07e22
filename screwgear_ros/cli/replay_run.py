"""replay_run BAG: play a recorded run's inputs into a live table_sim, paced by its /clock.

Like ``ros2 bag play`` for the command topics only, but on simulation time: every
recorded input command is published, every recorded parameter change is set and
every reset is called when the node's /clock reaches the step it took effect at
in the recording (one publish tick ahead, since the node applies what arrived
during a tick at the start of the next one), whatever the node's real-time factor.

* ``replay_run BAG``: into a running node (``--ros-args -r __ns:=/axis_c`` picks
  the table; ``--node`` its name); the run is shifted to start at the next tick.
* ``replay_run BAG --record NEW``: starts a fresh ``table_sim`` with the bag's
  initial parameters and ``record:=NEW``, replays, stops it with SIGINT.
  ``--compare`` then reports event timing and trajectory differences of NEW
  against BAG (exit 1 if outside the tolerance the timing explains).
* ``--script SCENARIO.yaml`` instead of BAG plays a scripted scenario (this is how
  the test bags are recorded: scripts/record_test_bags.sh).

The fresh node starts slow (real-time factor ``START_FACTOR``) and is brought to
``--rate`` once the replay is connected, so DDS discovery never eats the start of
the run.
"""

from __future__ import annotations

import argparse
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import rclpy
import rclpy.executors
import yaml
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from rclpy.signals import SignalHandlerOptions
from rclpy.utilities import remove_ros_args
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Float64, Float64MultiArray, Int8
from std_srvs.srv import Trigger

from ..ros.shutdown import stop_on_signals
from ..runs.bagread import BagError, read_run
from ..runs.compare import compare_runs, format_comparison
from ..runs.replay import Action, Schedule, load_scenario, schedule_from_run

INPUT_TYPES = {'cmd_torque': Float64, 'cmd_direction': Int8, 'cmd_effort': Float64MultiArray,
               'load_torque': Float64}
START_FACTOR = 0.01          # real-time factor of a fresh node until the replay is connected
CONNECT_TIMEOUT = 60.0       # s: a first start compiles the numba core
EXIT_OK, EXIT_DIFFERENT, EXIT_ERROR = 0, 1, 2


class ReplayError(RuntimeError):
    """Something that stops a replay; the message says what."""


class Replayer:
    """The replay node: input publishers, parameter and reset clients, /clock follower."""

    def __init__(self, node_name: str, ros_args: list[str] | None) -> None:
        self.context = rclpy.Context()
        rclpy.init(args=ros_args, context=self.context,
                   signal_handler_options=SignalHandlerOptions.NO)
        self.node = Node('replay_run', context=self.context)
        self.target = node_name
        self._cond = threading.Condition()
        self.clock_step: int | None = None
        self._dt_ns = 0.0
        self.publishers = {topic: self.node.create_publisher(kind, topic, 10)
                           for topic, kind in INPUT_TYPES.items()}
        self.node.create_subscription(Clock, '/clock', self._on_clock, 10)
        self.params = AsyncParameterClient(self.node, node_name)
        self.reset = self.node.create_client(Trigger, f'{node_name}/reset')
        self.executor = rclpy.executors.SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        try:
            self.executor.spin()
        except rclpy.executors.ExternalShutdownException:
            pass

    def close(self) -> None:
        """Stop spinning, join the spin thread, then destroy the node and shut the context
        down: no thread is inside rcl when its node or context goes away."""
        self.executor.shutdown(timeout_sec=2.0)
        self._thread.join(timeout=5.0)
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)

    # ------------------------------------------------------------------ time

    def set_dt(self, dt: float) -> None:
        self._dt_ns = dt * 1e9

    def _on_clock(self, msg: Clock) -> None:
        ns = msg.clock.sec * 1_000_000_000 + msg.clock.nanosec
        with self._cond:
            self.clock_step = round(ns / self._dt_ns)
            self._cond.notify_all()

    def wait_clock(self, step: int, stop: threading.Event, timeout: float | None = None) -> int:
        """Block until the node's simulation reaches ``step``; the step it is at."""
        deadline = None if timeout is None else time.monotonic() + timeout
        with self._cond:
            while self.clock_step is None or self.clock_step < step:
                if stop.is_set():
                    raise ReplayError('interrupted')
                left = None if deadline is None else deadline - time.monotonic()
                if left is not None and left <= 0:
                    raise ReplayError(f'no /clock at step {step} within {timeout} s '
                                      f'(last seen: {self.clock_step})')
                self._cond.wait(0.2 if left is None else min(0.2, left))
            return self.clock_step

    # ------------------------------------------------------------------ actions

    def connect(self, need_params: bool, need_reset: bool, stop: threading.Event) -> None:
        """Wait until the node's inputs, services and /clock are there."""
        deadline = time.monotonic() + CONNECT_TIMEOUT
        while not stop.is_set():
            ready = (all(p.get_subscription_count() > 0 for p in self.publishers.values())
                     and (not need_params or self.params.services_are_ready())
                     and (not need_reset or self.reset.service_is_ready())
                     and self.clock_step is not None)
            if ready:
                return
            if time.monotonic() > deadline:
                raise ReplayError(f'table_sim ({self.target}) not reachable within '
                                  f'{CONNECT_TIMEOUT:g} s: its inputs, parameter and reset '
                                  'services and /clock are needed (publish_clock: true)')
            time.sleep(0.05)
        raise ReplayError('interrupted')

    def set_parameters(self, values: dict[str, Any], timeout: float = 10.0) -> None:
        future = self.params.set_parameters_atomically(
            [Parameter(k, value=v) for k, v in values.items()])
        deadline = time.monotonic() + timeout
        while not future.done():
            if time.monotonic() > deadline:
                raise ReplayError(f'setting {values} on {self.target} timed out')
            time.sleep(0.001)
        result = future.result().result
        if not result.successful:
            raise ReplayError(f'{self.target} refused {values}: {result.reason}')

    def differences(self, start: dict[str, Any], timeout: float = 10.0) -> list[str]:
        """Parameters of the live node that differ from the recording's start values."""
        from rclpy.parameter import parameter_value_to_python
        names = sorted(start)
        future = self.params.get_parameters(names)
        deadline = time.monotonic() + timeout
        while not future.done():
            if time.monotonic() > deadline:
                raise ReplayError(f'reading the parameters of {self.target} timed out')
            time.sleep(0.001)
        live = [parameter_value_to_python(v) for v in future.result().values]
        return [f'{n} = {v!r} (recorded {start[n]!r})' for n, v in zip(names, live)
                if (list(v) if isinstance(v, (list, tuple)) else v)
                != (list(start[n]) if isinstance(start[n], (list, tuple)) else start[n])]

    def perform(self, action: Action) -> None:
        if action.kind in INPUT_TYPES:
            data = [float(v) for v in action.value] if action.kind == 'cmd_effort' \
                else action.value
            self.publishers[action.kind].publish(INPUT_TYPES[action.kind](data=data))
        elif action.kind == 'parameters':
            self.set_parameters(dict(action.value))
        else:
            self.reset.call_async(Trigger.Request())



def _spawn_node(schedule: Schedule, record: Path, ros_args: list[str],
                workdir: Path) -> subprocess.Popen:
    """A fresh table_sim with the schedule's start parameters, recording to ``record``."""
    exe = shutil.which('table_sim')
    if exe is None:
        raise ReplayError('table_sim is not on PATH (source the workspace or the venv)')
    values = {**schedule.start, 'record': str(record),
              'real_time_factor': START_FACTOR, 'publish_clock': True}
    values = {k: list(v) if isinstance(v, tuple) else v for k, v in values.items()}
    params_file = workdir / 'replay_params.yaml'
    params_file.write_text(yaml.safe_dump({'/**': {'ros__parameters': values}},
                                          sort_keys=False))
    log = open(workdir / 'table_sim.log', 'w')
    remaps = [a for a in ros_args if a != '--ros-args']
    return subprocess.Popen([exe, '--ros-args', *remaps, '--params-file', str(params_file)],
                            stdout=log, stderr=subprocess.STDOUT)


def _ros_args(argv: list[str]) -> list[str]:
    """The --ros-args part of the command line (remaps such as __ns)."""
    if '--ros-args' not in argv:
        return []
    return argv[argv.index('--ros-args'):]


def run_replay(schedule: Schedule, replayer: Replayer, stop: threading.Event,
               spawned: bool, rate: float, lead_ticks: int) -> int:
    """Play the schedule; returns the offset (steps) the run was shifted by."""
    replayer.set_dt(schedule.dt)
    replayer.connect(True, any(a.kind == 'reset' for a in schedule.actions), stop)
    ticks = schedule.ticks
    if spawned:
        offset = 0
        replayer.set_parameters({'real_time_factor': float(rate)})
        first = schedule.actions[0].step if schedule.actions else schedule.end_step
        now = replayer.clock_step or 0
        if now > first - lead_ticks * ticks:
            print(f'replay_run: warning: the node reached step {now} before the replay was '
                  f'connected; the first action (step {first}) will be late', file=sys.stderr)
    else:
        for line in replayer.differences(schedule.start):
            print(f'replay_run: warning: the running node has {line}; the replay will '
                  'not reproduce the recording', file=sys.stderr)
        now = replayer.wait_clock(0, stop, CONNECT_TIMEOUT)
        offset = (now // ticks + 2) * ticks
        print(f'replay_run: the node is at t = {now * schedule.dt:.6f} s; the recording is '
              f'replayed from t = {offset * schedule.dt:.6f} s on', file=sys.stderr)
    for action in schedule.actions:
        replayer.wait_clock(action.step + offset - lead_ticks * ticks, stop)
        replayer.perform(action)
    replayer.wait_clock(schedule.end_step + offset + ticks, stop)
    return offset


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = argparse.ArgumentParser(
        prog='replay_run', description='Publish the inputs recorded in a table_sim bag '
        '(commands, parameter changes, resets) into a live table_sim at their recorded '
        'simulation times, paced by its /clock.')
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument('bag', nargs='?', help='rosbag2 directory recorded by table_sim')
    source.add_argument('--script', help='a scenario YAML instead of a bag')
    parser.add_argument('--record', help='start a fresh table_sim recording to this path '
                        'and replay into it')
    parser.add_argument('--compare', action='store_true', help='with --record: compare the '
                        'new recording with BAG (timing and trajectories)')
    parser.add_argument('--node', default='table_sim', help='name of the target node')
    parser.add_argument('--rate', type=float, default=1.0,
                        help='real-time factor of the fresh node (> 0; default 1)')
    parser.add_argument('--lead-ticks', type=int, default=1,
                        help='publish this many publish ticks ahead of the recorded step '
                        '(default 1: the node applies a command at the tick after it arrives)')
    args = parser.parse_args(remove_ros_args(['replay_run', *argv])[1:])
    if args.compare and (args.record is None or args.bag is None):
        parser.error('--compare needs a BAG and --record (the new run is compared from its '
                     'own recording)')
    if args.rate <= 0:
        parser.error('--rate must be > 0: the replay follows the node\'s /clock')
    ros_args = _ros_args(argv)
    try:
        if args.bag is not None:
            original = read_run(args.bag)
            schedule = schedule_from_run(original)
        else:
            original = None
            schedule = load_scenario(args.script)
    except (BagError, ValueError, OSError, KeyError) as exc:
        print(f'replay_run: {exc}', file=sys.stderr)
        return EXIT_ERROR

    stop = stop_on_signals()
    child: subprocess.Popen | None = None
    workdir = Path(tempfile.mkdtemp(prefix='replay_run_'))
    replayer: Replayer | None = None
    try:
        if args.record is not None:
            record = Path(args.record)
            if record.exists():
                raise ReplayError(f'{record} exists; a recording never overwrites')
            child = _spawn_node(schedule, record, ros_args, workdir)
        replayer = Replayer(args.node, ['replay_run', *ros_args])
        run_replay(schedule, replayer, stop, child is not None, args.rate, args.lead_ticks)
    except ReplayError as exc:
        print(f'replay_run: {exc}', file=sys.stderr)
        return EXIT_ERROR
    finally:
        if replayer is not None:
            replayer.close()
        if child is not None:
            code = _stop_child(child)
            if code != 0:
                print(f'replay_run: table_sim ended with {code}; its log: '
                      f'{workdir / "table_sim.log"}', file=sys.stderr)
    print(f'replay_run: replayed {len(schedule.actions)} actions over '
          f'{schedule.end_step * schedule.dt:.3f} s of simulation'
          + (f' into {args.record}' if args.record else ''))
    if args.compare:
        try:
            comparison = compare_runs(original, read_run(args.record))
        except BagError as exc:
            print(f'replay_run: cannot read the new recording: {exc}', file=sys.stderr)
            return EXIT_ERROR
        print(format_comparison(comparison))
        return EXIT_OK if comparison.ok else EXIT_DIFFERENT
    return EXIT_OK


def _stop_child(child: subprocess.Popen) -> int:
    """SIGINT the spawned node (it closes its bag) and wait for it."""
    if child.poll() is None:
        child.send_signal(signal.SIGINT)
        try:
            return child.wait(timeout=20.0)
        except subprocess.TimeoutExpired:
            child.kill()
            child.wait()
            return -signal.SIGKILL
    return child.returncode


__all__ = ['Replayer', 'run_replay', 'main']


if __name__ == '__main__':
    sys.exit(main())
