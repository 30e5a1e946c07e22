"""replay_run: play a recorded run's events (or a scripted scenario) into a live table_sim.

Each recorded event is played the way the node received it in the recording: a
command is published on its input topic, a parameter change is set through the
node's parameter service (atomically), a reset is a call of ``<node>/reset``.

**Lockstep** (the default with ``--record``, and into a running node whose
``lockstep`` parameter is true): the replay answers the node's ticks itself. Before
each answer it sends the events the tick applied in the recording, each confirmed
inside the node before the next, then answers with one std_msgs/Empty on
``<node>/tick`` (while it publishes there, the node counts no command as an answer).
The node applies them all, in order, at the tick's first step, so a replay into a fresh
node reproduces the recording bit for bit: any number of commands on any topics in one
tick, parameter changes, resets, and runs whose time stood still after a fault (ticks
are counted, not told apart by their stamps). :mod:`screwgear_ros.ros.node_replay`.

**Free-running** (into a running node with ``lockstep: false``, or ``--record NEW
--free-running``): each event is sent when the node's /clock reaches one publish tick
(``--lead-ticks``) before its step; it lands where the wall clock puts it, usually on
its step, sometimes a tick or more late. ``--compare`` then says CONSISTENT (not the
same run: a moved event makes another trajectory) when the new run is exactly what the
original's events make at the steps they landed (runs.compare), with the timing and the
largest signal difference to the original beside it.

* ``replay_run BAG --record NEW``: starts a fresh ``table_sim`` with the bag's start
  parameters, ``record:=NEW``, ``lockstep:=true``, ``publish_clock:=true`` and real-time
  factor ``--rate`` (default 0: as fast as the replay answers), replays, stops it with
  SIGINT. ``--compare`` then compares NEW with BAG.
* ``replay_run BAG``: into the running node (``--ros-args -r __ns:=/axis_c`` picks the
  table, ``--node`` its name), the run shifted to start at the node's current step
  (lockstep) or two ticks after its current /clock (free-running); stderr says which.
* ``--script SCENARIO.yaml`` instead of BAG plays a scripted scenario (this is how the
  test bags are recorded: scripts/record_test_bags.sh).

The replay must be alone with its node: a second node of the same full name, or any
other publisher on the node's input topics or ``<node>/tick``, is refused before the
replay starts (and stops it if one appears meanwhile).

Exit status: 0 replayed (with ``--compare``: IDENTICAL, or free-running: CONSISTENT,
what the events make at the steps they landed); 1 ``--compare`` found a difference; 2 an error,
with the reason on stderr and never a traceback: a BAG or scenario that cannot be read,
a recording that lost ticks (lockstep), NEW exists, table_sim not on PATH, the node
(its inputs, ``~/tick``, services, joint_states or /clock) not reachable within
CONNECT_TIMEOUT, another node of its name or another publisher to it, the spawned node
ending early or with a non-zero status, a parameter change or reset refused (the
node's reason), a service reply missing after REPLY_TIMEOUT, a lockstep node making no
tick for STALL_TIMEOUT after an answer (a free-running node's /clock standing still as
long), a comparison that compared nothing (an original with no sample after its start), a new recording that cannot be read, and
SIGINT/SIGTERM: replay_run then stops within a second, saying how far it got (a node it
started gets SIGINT too and closes its bag on its own).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import shutil
import signal
import sys
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from ..bag.errors import BagError
from ..bag.reader import RecordedRun, read_run
from ..inprocess.scenario import schedule_from_scenario
from ..ros.node_replay import (
    CHILD_CLOSE,
    CHILD_GRACE,
    START_FACTOR,
    Progress,
    replay_free,
    replay_lockstep,
    spawn_node,
    stop_node,
)
from ..ros.replay_client import Interrupted, ReplayClient, ReplayError
from ..ros.shutdown import STOP_SIGNALS, RosArgumentsError, stop_on_signals, without_ros_args
from ..runs.compare import compare_runs, exact_comparison, format_comparison, format_exact
from ..runs.lockstep_plan import LockstepPlan, plan_from_run, plan_from_schedule
from ..runs.replay_in_process import schedule_from_run
from ..sim.schedule import Schedule, differences
from . import EXIT_ERROR, EXIT_OK

#: ``--compare`` found a difference.
EXIT_DIFFERENT = 1


def _parser() -> argparse.ArgumentParser:
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
                        'new recording with BAG (lockstep: identical; free-running: consistent, '
                        'what the events make at the steps they landed)')
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
    return parser


def _arguments(argv: list[str]) -> argparse.Namespace:
    parser = _parser()
    args = parser.parse_args(without_ros_args(['replay_run', *argv])[1:])
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
    args.ros_args = argv[argv.index('--ros-args'):] if '--ros-args' in argv else []
    return args


@contextlib.contextmanager
def _raising_on_signals() -> Iterator[None]:
    """SIGINT/SIGTERM raise Interrupted in the main thread meanwhile: for the parts
    without ROS (reading bags, comparing), which never wait on anything a stop event could
    wake. The replay itself only sets the stop event (ros.shutdown)."""
    def interrupt(signum: int, frame: object) -> None:
        raise Interrupted()
    previous = {signum: signal.signal(signum, interrupt) for signum in STOP_SIGNALS}
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


def _load(args: argparse.Namespace) -> tuple[Schedule, RecordedRun | None]:
    try:
        if args.bag is not None:
            original = read_run(args.bag)
            return schedule_from_run(original), original
        return schedule_from_scenario(args.script), None
    except (ValueError, OSError, KeyError) as exc:   # BagError is caught by main()
        raise ReplayError(str(exc)) from None


def _plan(schedule: Schedule, original: RecordedRun | None) -> LockstepPlan:
    try:
        return plan_from_run(original) if original is not None else plan_from_schedule(schedule)
    except ValueError as exc:
        raise ReplayError(str(exc)) from None


def _child_exit(child: Any, log: Path, workdir: Path, stop: threading.Event,
                progress: Progress):
    """The exit callback for a spawned node: stop it; its workdir (parameters file, log)
    is kept only when the node failed, for its log."""
    def finish(exc_type: type | None, exc: BaseException | None, tb: object) -> None:
        interrupted = stop.is_set() or isinstance(exc, Interrupted)
        status = stop_node(child, CHILD_GRACE if interrupted else CHILD_CLOSE)
        if status is None and interrupted:
            progress.closing = child.pid         # it ends on its own
            status = 0
        elif status is None:
            child.kill()
            child.wait()
            status = -signal.SIGKILL
        if status == 0:
            shutil.rmtree(workdir, ignore_errors=True)
        elif exc is None:
            raise ReplayError(f'table_sim ended with {status}; its log: {log}')
    return finish


def _replay(args: argparse.Namespace, schedule: Schedule, original: RecordedRun | None,
            stop: threading.Event, stack: contextlib.ExitStack, progress: Progress) -> bool:
    """Run the replay; True if it was a lockstep one. ``stack`` stops what it started."""
    ros_args = ['replay_run', *args.ros_args]
    if args.record is not None:
        lockstep = not args.free_running
        record = Path(args.record)
        if record.exists():
            raise ReplayError(f'{record} exists; a recording never overwrites')
        plan = _plan(schedule, original) if lockstep else None
        rate = args.rate if args.rate is not None else (0.0 if lockstep else 1.0)
        workdir = Path(tempfile.mkdtemp(prefix='replay_run_'))
        child, log = spawn_node(schedule, record, args.ros_args, workdir, lockstep,
                                rate if lockstep else START_FACTOR)
        stack.push(_child_exit(child, log, workdir, stop, progress))
        client = stack.enter_context(ReplayClient(args.node, ros_args, stop, child, log,
                                                  record))
        client.set_dt(schedule.dt)
        if plan is not None:
            replay_lockstep(schedule, plan, client, True, progress)
        else:
            replay_free(schedule, client, True, rate, args.lead_ticks, progress)
        return lockstep

    client = stack.enter_context(ReplayClient(args.node, ros_args, stop))
    start = schedule.start
    live = client.node_parameters(sorted({*start, 'lockstep'}))
    for line in differences(live, start):
        print(f'replay_run: warning: the running node has {line}; the replay will not '
              'reproduce the recording', file=sys.stderr)
    client.set_dt(float(live.get('dt') or schedule.dt))
    if live.get('lockstep'):
        replay_lockstep(schedule, _plan(schedule, original), client, False, progress)
        return True
    print('replay_run: the running node is free-running (lockstep: false): events are sent '
          'as its /clock passes their steps, so when they take effect follows the wall '
          'clock (usually their step, sometimes a tick or more later)', file=sys.stderr)
    replay_free(schedule, client, False, 0.0, args.lead_ticks, progress)
    return False


def _compare(original: RecordedRun, record: str, lockstep: bool) -> int:
    new = read_run(record)
    if lockstep:
        exact = exact_comparison(original, new)
        print(format_exact(exact))
        problem = exact.nothing_compared
        verdict = EXIT_OK if exact.ok else EXIT_DIFFERENT
    else:
        comparison = compare_runs(original, new)
        print(format_comparison(comparison))
        problem = comparison.nothing_compared
        verdict = EXIT_OK if comparison.ok else EXIT_DIFFERENT
    if problem is not None:
        raise ReplayError(f'nothing compared: {problem}')
    return verdict


def main(argv: list[str] | None = None) -> int:
    try:
        args = _arguments(list(sys.argv[1:] if argv is None else argv))
    except RosArgumentsError as exc:
        print(f'replay_run: {exc}', file=sys.stderr)
        return EXIT_ERROR
    stop = stop_on_signals()
    progress = Progress()
    what = 'reading the recording'
    try:
        with _raising_on_signals():
            schedule, original = _load(args)
        progress.total = len(schedule.events)
        what = 'replaying'
        with contextlib.ExitStack() as stack:
            lockstep = _replay(args, schedule, original, stop, stack, progress)
        print(f'replay_run: replayed {len(schedule.events)} events over '
              f'{schedule.end_step * schedule.dt:.3f} s of simulation '
              + ('in lockstep' if lockstep else 'free-running')
              + (f' into {args.record}' if args.record else ''))
        if not args.compare:
            return EXIT_OK
        what = 'comparing'
        if not lockstep:
            print('replay_run: a free-running replay is judged by whether its outputs are '
                  'what the events make at the steps they landed, not compared for identity',
                  file=sys.stderr)
        assert original is not None        # --compare needs a BAG (_arguments)
        with _raising_on_signals():
            return _compare(original, args.record, lockstep)
    except Interrupted:
        kept = (f'; {args.record} keeps what was recorded until then'
                if args.record and Path(args.record).exists() else '')
        if progress.closing is not None:
            kept += f' (table_sim, pid {progress.closing}, is still closing it)'
        done = f': {progress}' if what == 'replaying' else f' while {what}'
        print(f'replay_run: interrupted{done}{kept}', file=sys.stderr)
        # Asked to stop, with nothing of ours left to write (the node closes its own bag):
        # end without the interpreter's finalization, which tears down numba's compiled
        # code and the DDS participant and can take seconds on a busy machine.
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(EXIT_ERROR)
    except BagError as exc:
        print(f'replay_run: {"cannot compare: " if what == "comparing" else ""}{exc}',
              file=sys.stderr)
    except ReplayError as exc:
        print(f'replay_run: {exc}', file=sys.stderr)
    except Exception as exc:  # noqa: BLE001 -- never a traceback: say what failed
        print(f'replay_run: {what}: {type(exc).__name__}: {exc}', file=sys.stderr)
    return EXIT_ERROR


__all__ = ['EXIT_DIFFERENT', 'EXIT_ERROR', 'EXIT_OK', 'main']


if __name__ == '__main__':
    sys.exit(main())
