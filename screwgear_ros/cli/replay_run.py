"""replay_run: play a recorded run's events (or a scripted scenario) into a live table_sim.

Each recorded event is played the way the node received it in the recording: a
command is published on its input topic, a parameter change is set through the
node's parameter service (atomically), a reset is a call of ``<node>/reset``.

**Lockstep** (the default with ``--record``, and into a running node whose
``lockstep`` parameter is true): the replay answers the node's ticks itself. For each
``joint_states`` with a new stamp (step s; a re-sent one is answered once) it sends
the events due at s, each confirmed inside the node before the next is sent (a
command: published RELIABLE, then a parameter-service round trip, which the node serves
only after taking what arrived before it; a parameter change or reset: the service
reply), then answers with one std_msgs/Empty on ``<node>/tick`` (a due ``cmd_effort``
is itself the answer, as it is for a controller). The node integrates the next tick
only then, so every event takes effect at its recorded step whatever the load of the
machine, and a replay into a fresh node reproduces the recording bit for bit.

**Free-running** (into a running node with ``lockstep: false``, or ``--record NEW
--free-running``): each event is sent when the node's /clock reaches one publish tick
(``--lead-ticks``) before its step; it lands where the wall clock puts it, usually on
its step, sometimes a tick or more late.

* ``replay_run BAG --record NEW``: starts a fresh ``table_sim`` with the bag's start
  parameters, ``record:=NEW``, ``lockstep:=true``, ``publish_clock:=true`` and real-time
  factor ``--rate`` (default 0: as fast as the replay answers), replays, stops it with
  SIGINT. ``--compare`` then compares NEW with BAG: lockstep, every event at its step
  and every output identical (exit 1 otherwise); free-running, within the tolerance
  the measured timing explains (runs.compare).
* ``replay_run BAG``: into the running node (``--ros-args -r __ns:=/axis_c`` picks the
  table, ``--node`` its name), the run shifted to start at the node's current step
  (lockstep) or two ticks after its current /clock (free-running); stderr says which.
  Nothing else may answer a lockstep node's ticks meanwhile.
* ``--script SCENARIO.yaml`` instead of BAG plays a scripted scenario (this is how the
  test bags are recorded: scripts/record_test_bags.sh).

Exit status: 0 replayed (with ``--compare``: identical, or within the tolerance); 1
``--compare`` found a difference; 2 an error, with the reason on stderr and never a
traceback: a BAG or scenario that cannot be read, NEW exists, table_sim not on PATH,
the node (its inputs, ``~/tick``, services, joint_states or /clock) not reachable within
CONNECT_TIMEOUT, the spawned node ending early or with a non-zero status, a parameter
change refused (the node's reason), a reset refused, a service reply missing after
REPLY_TIMEOUT, a lockstep node publishing no new tick for STALL_TIMEOUT after an answer
(a free-running node's /clock standing still as long), a run a lockstep replay cannot reproduce (a ``cmd_effort``, which answers the tick,
followed by another event at the same step; a run whose simulation time stood still
after a diverged model, since its ticks then share one stamp), a new recording that
cannot be read, SIGINT/SIGTERM ("interrupted").
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
from typing import Any, Callable, TypeVar

import numpy as np
import rclpy
import rclpy.executors
import yaml
from rclpy.node import Node
from rclpy.parameter import Parameter, parameter_value_to_python
from rclpy.parameter_client import AsyncParameterClient
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from rclpy.utilities import remove_ros_args
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Empty
from std_srvs.srv import Trigger

from ..events import Command, Event, ParameterChange, Reset, describe
from ..params import ANSWER_TOPICS, TICK_TOPIC
from ..ros.messages import INPUT_TYPES, input_message
from ..ros.shutdown import spin_executor_until, stop_on_signals
from ..runs.bagread import BagError, RecordedRun, read_run
from ..runs.compare import compare_runs, exact_comparison, format_comparison, format_exact
from ..runs.replay import Schedule, load_scenario, schedule_from_run

CONNECT_TIMEOUT = 60.0   # s: a first start compiles the numba core
REPLY_TIMEOUT = 30.0     # s for a service reply
STALL_TIMEOUT = 60.0     # s without a new tick (lockstep) or an advancing /clock
POLL = 0.1               # s between checks for a signal or an ended node while waiting
START_FACTOR = 0.01      # free-running fresh node: real-time factor until connected
EXIT_OK, EXIT_DIFFERENT, EXIT_ERROR = 0, 1, 2
RELIABLE = QoSProfile(depth=10, history=HistoryPolicy.KEEP_LAST,
                      reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.VOLATILE)

T = TypeVar('T')


class ReplayError(RuntimeError):
    """Something that stops a replay; the message says what."""


def _is_answer(event: Event) -> bool:
    return isinstance(event, Command) and event.topic in ANSWER_TOPICS


def lockstep_conflict(group: list[Event]) -> str | None:
    """Why events taking effect in one tick cannot be sent to a lockstep node in their
    order, or None. A command on an answer topic (``cmd_effort``) answers the tick, so it
    must come last."""
    for k, event in enumerate(group[:-1]):
        if _is_answer(event):
            return (f'{describe(event)} is followed by {describe(group[k + 1])} in the same '
                    f'tick, but in lockstep a {event.topic} message answers the tick: what '
                    'follows it would take effect a tick later (replay it with --free-running)')
    return None


def lockstep_problem(schedule: Schedule, original: RecordedRun | None) -> str | None:
    """Why a lockstep replay cannot reproduce this schedule, or None."""
    if original is not None and len(original.joint_states) > 1:
        steps = original.joint_states.steps
        still = np.nonzero(np.diff(steps) <= 0)[0]
        if len(still):
            return (f'the recorded simulation time stood still at step {steps[still[0]]} '
                    '(the model diverged and waited for a reset): its ticks share one stamp, '
                    'which a lockstep replay cannot tell apart (replay it with --free-running)')
    group: list[Event] = []
    for event in [*schedule.events, None]:
        if group and (event is None or event.step != group[0].step):
            problem = lockstep_conflict(group)
            if problem is not None:
                return f'step {group[0].step}: {problem}'
            group = []
        if event is not None:
            group.append(event)
    return None


class Replayer:
    """The replay's node: input publishers, ``<node>/tick``, parameter and reset
    clients, and what the target publishes (joint_states, mesh_state, /clock).

    Callbacks run on the spin thread and only record what arrived under ``_cond``;
    the main thread waits on it (checking for a signal and for a spawned node that
    ended every POLL s).
    """

    def __init__(self, node_name: str, ros_args: list[str], stop: threading.Event,
                 child: subprocess.Popen | None = None, child_log: Path | None = None) -> None:
        self.target = node_name
        self.stop = stop
        self.child = child
        self.child_log = child_log
        self.context = rclpy.Context()
        rclpy.init(args=ros_args, context=self.context,
                   signal_handler_options=SignalHandlerOptions.NO)
        self.node = Node('replay_run', context=self.context)
        self._cond = threading.Condition()
        self._dt_ns = 0.0
        self._stamp: int | None = None         # newest joint_states stamp, ns
        self._mesh: tuple[int | None, int] = (None, 0)  # last mesh_state stamp, how many
        self._still: int | None = None         # a stamp two ticks were published at, ns
        self._clock: int | None = None         # newest /clock, ns
        self._clock_moved = time.monotonic()   # when /clock last advanced
        self._clock_sub = None
        self.inputs = {topic: self.node.create_publisher(kind, topic, RELIABLE)
                       for topic, kind in INPUT_TYPES.items()}
        self.tick = self.node.create_publisher(Empty, f'{node_name}/{TICK_TOPIC}', RELIABLE)
        self.node.create_subscription(JointState, 'joint_states', self._on_joint_states,
                                      RELIABLE)
        self.node.create_subscription(JointState, 'mesh_state', self._on_mesh_state, RELIABLE)
        self.params = AsyncParameterClient(self.node, node_name)
        self.reset = self.node.create_client(Trigger, f'{node_name}/reset')
        self.executor = rclpy.executors.SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=spin_executor_until,
                                        args=(self.executor, self._stop, 0.05), daemon=True,
                                        name='replay_run spin')
        self._thread.start()

    def close(self) -> None:
        """Stop the spin loop and join its thread, then shut the executor down, destroy
        the node and shut the context down: no thread is inside rcl when its executor,
        node or context goes away (shutting an executor down under a spinning thread
        destroys guard conditions the spin still uses)."""
        self._stop.set()
        self._thread.join(timeout=30.0)
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)

    # ------------------------------------------------------------------ callbacks

    def set_dt(self, dt: float) -> None:
        self._dt_ns = dt * 1e9

    def step_of(self, ns: int) -> int:
        return round(ns / self._dt_ns)

    def follow_clock(self) -> None:
        if self._clock_sub is None:
            self._clock_sub = self.node.create_subscription(Clock, '/clock', self._on_clock,
                                                            RELIABLE)

    def _on_joint_states(self, msg: JointState) -> None:
        ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        with self._cond:
            if self._stamp is None or ns > self._stamp:
                self._stamp = ns
                self._cond.notify_all()

    def _on_mesh_state(self, msg: JointState) -> None:
        """mesh_state is published once per tick and never re-sent: two with one stamp
        mean two ticks at one simulation time (the plant stands still after a fault)."""
        ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        with self._cond:
            stamp, count = self._mesh
            self._mesh = (ns, count + 1 if ns == stamp else 1)
            if self._mesh[1] >= 2 and self._still is None:
                self._still = ns
                self._cond.notify_all()

    def _on_clock(self, msg: Clock) -> None:
        ns = msg.clock.sec * 1_000_000_000 + msg.clock.nanosec
        with self._cond:
            if self._clock is None or ns > self._clock:
                self._clock = ns
                self._clock_moved = time.monotonic()
                self._cond.notify_all()

    def _notify(self, *_: Any) -> None:
        with self._cond:
            self._cond.notify_all()

    # ------------------------------------------------------------------ waiting

    def _check(self) -> None:
        """Raise if a signal came or the spawned node ended."""
        if self.stop.is_set():
            raise ReplayError('interrupted')
        if self.child is not None and self.child.poll() is not None:
            raise ReplayError(f'table_sim ended with {self.child.returncode} before the replay '
                              f'was done; its log: {self.child_log}')

    def _wait(self, ready: Callable[[], T | None], timeout: float, what: str) -> T:
        """The first non-None ``ready()`` (called under the lock); ReplayError saying
        ``what`` was missing after ``timeout`` s."""
        deadline = time.monotonic() + timeout
        with self._cond:
            while True:
                value = ready()
                if value is not None:
                    return value
                self._check()
                left = deadline - time.monotonic()
                if left <= 0.0:
                    raise ReplayError(what)
                self._cond.wait(min(POLL, left))

    def _result(self, future: Any, what: str) -> Any:
        future.add_done_callback(self._notify)
        self._wait(lambda: True if future.done() else None, REPLY_TIMEOUT,
                   f'{what}: no reply from {self.target} within {REPLY_TIMEOUT:g} s')
        return future.result()

    def connect(self, schedule: Schedule, lockstep: bool,
                timeout: float = CONNECT_TIMEOUT) -> None:
        """Wait until every input, ``<node>/tick`` and the node's services are matched and
        the node's joint_states (lockstep) or /clock (free-running) have arrived."""
        needs: list[tuple[str, Callable[[], bool]]] = [
            ('its input topics', lambda: all(p.get_subscription_count() > 0
                                             for p in self.inputs.values())),
            ('its parameter services', self.params.services_are_ready),
        ]
        if any(isinstance(e, Reset) for e in schedule.events):
            needs.append(('its reset service', self.reset.service_is_ready))
        if lockstep:
            needs.append((f'{self.tick.topic_name}', lambda: self.tick.get_subscription_count() > 0))
            needs.append(('its joint_states', lambda: self._stamp is not None))
        else:
            needs.append(('/clock (publish_clock: true)', lambda: self._clock is not None))
        deadline = time.monotonic() + timeout
        while True:
            with self._cond:
                missing = [name for name, ready in needs if not ready()]
            if not missing:
                break
            self._check()
            if time.monotonic() > deadline:
                raise ReplayError(f'table_sim ({self.target}) not reachable within {timeout:g} s: '
                                  f'missing {", ".join(missing)}')
            time.sleep(0.02)
        # Discovery is matched on both sides once the node has served a request: its
        # participant learns our endpoints in the order we created them (the publishers
        # first), so by then its readers have matched our input and tick writers.
        self._sync('connecting')

    def wait_step(self, after: int | None, timeout: float) -> int:
        """The step of the newest joint_states stamp later than step ``after``."""
        def ready() -> int | None:
            if self._stamp is not None:
                step = self.step_of(self._stamp)
                if after is None or step > after:
                    return step
            if self._still is not None:
                raise ReplayError(
                    f'{self.target} published two ticks at t = {self._still * 1e-9:.6f} s: '
                    'its simulation stands still (a diverged model waits for ~/reset), and a '
                    'lockstep replay, which tells ticks apart by their stamps, cannot follow')
            return None
        return self._wait(ready, timeout, f'no new joint_states from {self.target} within '
                          f'{timeout:g} s after answering step {after}')

    def wait_clock(self, step: int) -> int:
        """Block until the node's /clock reaches ``step``; the step it is at."""
        def ready() -> int | None:
            if self._clock is not None and self.step_of(self._clock) >= step:
                return self.step_of(self._clock)
            if time.monotonic() - self._clock_moved > STALL_TIMEOUT:
                raise ReplayError(f'the /clock of {self.target} stood still for '
                                  f'{STALL_TIMEOUT:g} s (last: {self._clock})')
            return None
        return self._wait(ready, float('inf'), 'unreachable')

    # ------------------------------------------------------------------ actions

    def node_parameters(self, names: list[str]) -> dict[str, Any]:
        """The target's values of ``names`` (None for one it lacks)."""
        self._wait(lambda: True if self.params.services_are_ready() else None,
                   CONNECT_TIMEOUT, f'no node {self.target} reachable within '
                   f'{CONNECT_TIMEOUT:g} s (its parameter services are not there)')
        response = self._result(self.params.get_parameters(names),
                                f'reading the parameters of {self.target}')
        return {n: parameter_value_to_python(v) for n, v in zip(names, response.values)}

    def _sync(self, what: str) -> None:
        """A parameter-service round trip that proves the node has taken what we published
        before it: the request travels from this participant to the node's by the same
        transport, after the messages published before it, and the node's executor serves
        the ready subscriptions of a wait before its services.

        (``Publisher.wait_for_all_acked`` would prove only the arrival, and takes up to a
        writer heartbeat period, 3 s with Fast DDS's defaults, per message.)"""
        self._result(self.params.get_parameters(['lockstep']), what)

    def set_parameters(self, values: dict[str, Any], what: str) -> None:
        response = self._result(self.params.set_parameters_atomically(
            [Parameter(k, value=v) for k, v in values.items()]), what)
        if not response.result.successful:
            raise ReplayError(f'{what}: {self.target} refused {values}: '
                              f'{response.result.reason}')

    def perform(self, event: Event, schedule: Schedule, confirm: bool = True) -> None:
        """Send ``event``; with ``confirm`` return only once the node has queued it."""
        what = f'{describe(event)} (step {event.step})'
        if isinstance(event, Command):
            self.inputs[event.topic].publish(input_message(event.topic, event.value))
            if confirm:
                self._sync(what)
        elif isinstance(event, ParameterChange):
            values = schedule.changed_values(event)     # ROS values already
            if values:
                self.set_parameters(values, f'parameter change at step {event.step}')
        elif isinstance(event, Reset):
            response = self._result(self.reset.call_async(Trigger.Request()), what)
            if not response.success:
                raise ReplayError(f'{what}: {self.target} refused: {response.message}')
        else:
            raise ReplayError(f'not a replayable event: {event!r}')

    def answer(self) -> None:
        """Answer the last tick the node published: one Empty on ``<node>/tick``."""
        self.tick.publish(Empty())


# ---------------------------------------------------------------------------- the two ways


def replay_lockstep(schedule: Schedule, replayer: Replayer, spawned: bool) -> int:
    """Answer the node's ticks, sending each tick's due events first; the offset (steps)
    between the node's and the schedule's steps."""
    replayer.connect(schedule, lockstep=True)
    first = replayer.wait_step(None, CONNECT_TIMEOUT)
    if spawned:
        if first != 0:
            raise ReplayError(f'the fresh table_sim is at step {first}, not 0: something '
                              'else answers its ticks (another replay or controller in this '
                              'ROS domain and namespace?)')
        offset = 0
    else:
        offset = first
        print(f'replay_run: the lockstep node is at t = {first * schedule.dt:.6f} s (step '
              f'{first}); the run is replayed from there: every event at its recorded step '
              f'+ {offset} (shifted by {offset} steps)', file=sys.stderr)
    step = first
    while step < schedule.end_step + offset:
        due = schedule.due(step - offset)
        problem = lockstep_conflict(due)
        if problem is not None:
            raise ReplayError(f'step {step - offset}: {problem}')
        for event in due:
            replayer.perform(event, schedule, confirm=not _is_answer(event))
        if not (due and _is_answer(due[-1])):
            replayer.answer()
        step = replayer.wait_step(step, STALL_TIMEOUT)
    return offset


def replay_free(schedule: Schedule, replayer: Replayer, spawned: bool, rate: float,
                lead_ticks: int) -> int:
    """Send each event when the node's /clock is ``lead_ticks`` publish ticks before its
    step; the offset (steps) between the node's and the schedule's steps."""
    replayer.follow_clock()
    replayer.connect(schedule, lockstep=False)
    ticks = schedule.settings.steps_per_publish
    lead = lead_ticks * ticks
    if spawned:
        offset = 0
        replayer.set_parameters({'real_time_factor': float(rate)},
                                'bringing the node to --rate')
        first = schedule.events[0].step if schedule.events else schedule.end_step
        now = replayer.wait_clock(0)
        if now > first - lead:
            print(f'replay_run: warning: the node reached step {now} before the replay was '
                  f'connected; the first event (step {first}) will be late', file=sys.stderr)
    else:
        now = replayer.wait_clock(0)
        offset = (now // ticks + 2) * ticks
        print(f'replay_run: the node is at t = {now * schedule.dt:.6f} s; the recording is '
              f'replayed from t = {offset * schedule.dt:.6f} s on (shifted by {offset} steps)',
              file=sys.stderr)
    for event in list(schedule.events):
        now = replayer.wait_clock(event.step + offset - lead)
        for due in schedule.due(now - offset + lead):
            replayer.perform(due, schedule)
    replayer.wait_clock(schedule.end_step + offset + ticks)
    return offset


# ---------------------------------------------------------------------------- the process


def _die_with_parent() -> None:
    """In the spawned node before exec: SIGINT when replay_run dies, even by SIGKILL, so
    that it closes its bag and ends rather than wait for answers that will not come."""
    try:
        import ctypes
        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGINT))  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):   # not Linux: the node outlives a killed replay
        pass


def _spawn_node(schedule: Schedule, record: Path, ros_args: list[str], workdir: Path,
                lockstep: bool, factor: float) -> tuple[subprocess.Popen, Path]:
    """A fresh table_sim with the schedule's start parameters, recording to ``record``;
    (process, its log file)."""
    exe = shutil.which('table_sim')
    if exe is None:
        raise ReplayError('table_sim is not on PATH (source the workspace or the venv)')
    values = {**schedule.start, 'record': str(record), 'real_time_factor': float(factor),
              'publish_clock': True, 'lockstep': lockstep}     # ROS values already
    params_file = workdir / 'replay_params.yaml'
    params_file.write_text(yaml.safe_dump({'/**': {'ros__parameters': values}},
                                          sort_keys=False))
    log_path = workdir / 'table_sim.log'
    remaps = [a for a in ros_args if a != '--ros-args']
    with open(log_path, 'w') as log:
        child = subprocess.Popen([exe, '--ros-args', *remaps, '--params-file', str(params_file)],
                                 stdout=log, stderr=subprocess.STDOUT,
                                 preexec_fn=_die_with_parent)
    return child, log_path


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


def _ros_args(argv: list[str]) -> list[str]:
    """The --ros-args part of the command line (remaps such as __ns)."""
    if '--ros-args' not in argv:
        return []
    return argv[argv.index('--ros-args'):]


def _refuse_unreproducible(schedule: Schedule, original: RecordedRun | None) -> None:
    """ReplayError if a lockstep replay cannot reproduce this run (lockstep_problem)."""
    problem = lockstep_problem(schedule, original)
    if problem is not None:
        raise ReplayError(f'a lockstep replay cannot reproduce this run: {problem}')


def _plain(value: Any) -> Any:
    return list(value) if isinstance(value, (list, tuple)) else value


def _differences(live: dict[str, Any], start: dict[str, Any]) -> list[str]:
    """The running node's parameters that differ from the schedule's start values."""
    return [f'{n} = {live[n]!r} (recorded {start[n]!r})' for n in sorted(start)
            if _plain(live.get(n)) != _plain(start[n])]


def _replay(args: argparse.Namespace, schedule: Schedule, original: RecordedRun | None,
            ros_args: list[str], stop: threading.Event, state: dict[str, Any]) -> bool:
    """Run the replay; True if it was a lockstep one. ``state`` collects the replayer,
    the child and its log for main() to clean up."""
    if args.record is not None:
        lockstep = not args.free_running
        record = Path(args.record)
        if record.exists():
            raise ReplayError(f'{record} exists; a recording never overwrites')
        if lockstep:
            _refuse_unreproducible(schedule, original)
        rate = args.rate if args.rate is not None else (0.0 if lockstep else 1.0)
        state['workdir'] = Path(tempfile.mkdtemp(prefix='replay_run_'))
        child, log = _spawn_node(schedule, record, ros_args, state['workdir'], lockstep,
                                 rate if lockstep else START_FACTOR)
        state['child'], state['log'] = child, log
        replayer = state['replayer'] = Replayer(args.node, ['replay_run', *ros_args], stop,
                                                child, log)
        replayer.set_dt(schedule.dt)
        if lockstep:
            replay_lockstep(schedule, replayer, spawned=True)
        else:
            replay_free(schedule, replayer, True, rate, args.lead_ticks)
        return lockstep

    replayer = state['replayer'] = Replayer(args.node, ['replay_run', *ros_args], stop)
    start = schedule.start
    live = replayer.node_parameters(sorted({*start, 'lockstep'}))
    for line in _differences(live, start):
        print(f'replay_run: warning: the running node has {line}; the replay will not '
              'reproduce the recording', file=sys.stderr)
    replayer.set_dt(float(live.get('dt') or schedule.dt))
    if live.get('lockstep'):
        _refuse_unreproducible(schedule, original)
        replay_lockstep(schedule, replayer, spawned=False)
        return True
    print('replay_run: the running node is free-running (lockstep: false): events are sent '
          'as its /clock passes their steps, so when they take effect follows the wall '
          'clock (usually their step, sometimes a tick or more later)', file=sys.stderr)
    replay_free(schedule, replayer, False, 0.0, args.lead_ticks)
    return False


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = argparse.ArgumentParser(
        prog='replay_run', description='Play the events recorded in a table_sim bag '
        '(commands, parameter changes, resets) into a live table_sim at their recorded '
        'steps: in lockstep with it (exact), or paced by its /clock (free-running).')
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument('bag', nargs='?', help='rosbag2 directory recorded by table_sim')
    source.add_argument('--script', help='a scenario YAML instead of a bag')
    parser.add_argument('--record', help='start a fresh table_sim recording to this path '
                        'and replay into it')
    parser.add_argument('--compare', action='store_true', help='with --record: compare the '
                        'new recording with BAG (lockstep: identical; free-running: within '
                        'the tolerance its timing explains)')
    parser.add_argument('--free-running', action='store_true', help='with --record: run the '
                        'fresh node free-running at --rate and follow its /clock instead of '
                        'lockstep')
    parser.add_argument('--node', default='table_sim', help='name of the target node')
    parser.add_argument('--rate', type=float, default=None,
                        help='real-time factor of the fresh node (lockstep: default 0 = as '
                        'fast as the replay answers; --free-running: > 0, default 1)')
    parser.add_argument('--lead-ticks', type=int, default=1,
                        help='free-running: send this many publish ticks ahead of the '
                        'recorded step (default 1: the node applies what arrives during a '
                        'tick at the start of the next one)')
    args = parser.parse_args(remove_ros_args(['replay_run', *argv])[1:])
    if args.compare and (args.record is None or args.bag is None):
        parser.error('--compare needs a BAG and --record (the new run is compared from its '
                     'own recording)')
    if args.free_running and args.record is None:
        parser.error('--free-running needs --record (a running node runs as it was started)')
    if args.rate is not None and (args.rate < 0 or (args.free_running and args.rate <= 0)):
        parser.error('--rate must be >= 0 (> 0 with --free-running: the replay then follows '
                     'the node\'s /clock)')
    if args.lead_ticks < 0:
        parser.error('--lead-ticks must be >= 0')
    ros_args = _ros_args(argv)
    stop = stop_on_signals()
    try:
        if args.bag is not None:
            original: RecordedRun | None = read_run(args.bag)
            schedule = schedule_from_run(original)
        else:
            original = None
            schedule = load_scenario(args.script)
    except (BagError, ValueError, OSError, KeyError) as exc:
        print(f'replay_run: {exc}', file=sys.stderr)
        return EXIT_ERROR

    state: dict[str, Any] = {}
    error: str | None = None
    lockstep = True
    try:
        lockstep = _replay(args, schedule, original, ros_args, stop, state)
    except ReplayError as exc:
        error = str(exc)
    except Exception as exc:  # noqa: BLE001 -- never a traceback: say what failed
        error = f'{type(exc).__name__}: {exc}'
    finally:
        replayer = state.get('replayer')
        if replayer is not None:
            try:
                replayer.close()
            except Exception as exc:  # noqa: BLE001
                error = error or f'closing the replay node: {type(exc).__name__}: {exc}'
        child = state.get('child')
        if child is not None:
            status = _stop_child(child)
            if status != 0 and error is None:
                error = f'table_sim ended with {status}; its log: {state["log"]}'
    if error is not None:
        print(f'replay_run: {error}', file=sys.stderr)
        return EXIT_ERROR
    if state.get('workdir') is not None:
        shutil.rmtree(state['workdir'], ignore_errors=True)
    print(f'replay_run: replayed {len(schedule.events)} events over '
          f'{schedule.end_step * schedule.dt:.3f} s of simulation '
          + ('in lockstep' if lockstep else 'free-running')
          + (f' into {args.record}' if args.record else ''))
    if not args.compare:
        return EXIT_OK
    try:
        new = read_run(args.record)
        if lockstep:
            exact = exact_comparison(original, new)
            print(format_exact(exact))
            return EXIT_OK if exact.ok else EXIT_DIFFERENT
        print('replay_run: a free-running replay is judged by the tolerance its measured '
              'event timing explains, not compared for identity', file=sys.stderr)
        comparison = compare_runs(original, new)
    except BagError as exc:
        print(f'replay_run: cannot compare with the new recording: {exc}', file=sys.stderr)
        return EXIT_ERROR
    print(format_comparison(comparison))
    return EXIT_OK if comparison.ok else EXIT_DIFFERENT


__all__ = ['Replayer', 'ReplayError', 'replay_lockstep', 'replay_free', 'lockstep_conflict',
           'lockstep_problem', 'main']


if __name__ == '__main__':
    sys.exit(main())
