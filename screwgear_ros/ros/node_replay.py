"""The two ways ``replay_run`` plays a run into a node, and the node it may start.

**Lockstep** (:func:`replay_lockstep`): the replay answers the node's ticks itself. For
each tick it sends the events that tick applies (:mod:`screwgear_ros.runs.lockstep_plan`),
each confirmed inside the node before the next, then answers with one ``<node>/tick``;
the node applies them all, in order, at the tick's first step. Ticks are counted by
their ``mesh_state`` (one per tick, never re-sent), so a run whose time stood still
after a fault replays too.

**Free-running** (:func:`replay_free`): each event is sent when the node's /clock is
``lead_ticks`` publish ticks before its step; it lands where the wall clock puts it.

:func:`spawn_node` starts a fresh table_sim that dies with this process
(``PR_SET_PDEATHSIG``: SIGINT, so it closes its bag).
"""

from __future__ import annotations

import shutil
import signal
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import yaml

from ..runs.lockstep_plan import LockstepPlan, sending_order
from ..sim.events import Reset
from ..sim.schedule import Schedule
from .replay_client import ReplayClient, ReplayError

START_FACTOR = 0.01      # free-running fresh node: real-time factor until connected
CHILD_GRACE = 0.5        # s an interrupted replay waits for its node to close the bag
GRAPH_SETTLE = 3.0       # s to wait for the graph to name what a fresh node's step betrays
#: s of graph checks after the last tick: on a busy machine discovery can name a second
#: node of the target's name only after a short replay is over, and a replay that may
#: have driven two tables must not report success.
GRAPH_FINAL = GRAPH_SETTLE
CHILD_CLOSE = 30.0       # s a finished replay waits for it (the comparison reads the bag)


@dataclass
class Progress:
    """How far a replay got (what an interrupted replay reports)."""

    events: int = 0          # events sent
    total: int = 0           # events to send
    ticks: int = 0           # lockstep: ticks answered
    step: int | None = None  # the node's last known step
    closing: int | None = None   # pid of a spawned node still closing its bag at the end

    def __str__(self) -> str:
        where = '' if self.step is None else f', the node at step {self.step}'
        ticks = f', {self.ticks} ticks answered' if self.ticks else ''
        return f'{self.events} of {self.total} events sent{ticks}{where}'


def replay_lockstep(schedule: Schedule, plan: LockstepPlan, client: ReplayClient,
                    spawned: bool, progress: Progress) -> int:
    """Answer the node's ``plan.ticks`` ticks, sending each tick's events first; the
    offset (steps) between the node's and the schedule's steps."""
    client.connect(any(isinstance(e, Reset) for _, e in plan.events), lockstep=True)
    first, meshes = client.stand()
    progress.step = first
    if spawned and first != 0:
        client.settle_graph(GRAPH_SETTLE)      # a second node of its name, most likely
        raise ReplayError(f'the fresh table_sim reports step {first}, not 0: a second node '
                          f'publishes {client.full_name}\'s joint_states, or something else '
                          'answered its ticks before the replay connected')
    if not spawned:
        print(f'replay_run: the lockstep node is at t = {first * schedule.dt:.6f} s (step '
              f'{first}); the run is replayed from there: every event at its recorded step '
              f'+ {first} (shifted by {first} steps)', file=sys.stderr)
    after: int | None = first
    for tick in range(1, plan.ticks + 1):
        for event, confirm in sending_order(plan.due(tick)):
            client.perform(event, schedule, confirm)
            progress.events += 1
        client.answer()
        progress.step, meshes = client.wait_tick(meshes, after)
        progress.ticks, after = tick, None
    client.settle_graph(GRAPH_FINAL)
    return first


def replay_free(schedule: Schedule, client: ReplayClient, spawned: bool, rate: float,
                lead_ticks: int, progress: Progress) -> int:
    """Send each event when the node's /clock is ``lead_ticks`` publish ticks before its
    step; the offset (steps) between the node's and the schedule's steps."""
    client.follow_clock()
    client.connect(any(isinstance(e, Reset) for e in schedule.events), lockstep=False)
    ticks = schedule.settings.steps_per_publish
    lead = lead_ticks * ticks
    if spawned:
        offset = 0
        client.set_parameters({'real_time_factor': float(rate)}, 'bringing the node to --rate')
        step = schedule.events[0].step if schedule.events else None
        first = schedule.end_step if step is None else step
        now = client.wait_clock(0)
        if now > first - lead:
            print(f'replay_run: warning: the node reached step {now} before the replay was '
                  f'connected; the first event (step {first}) will be late', file=sys.stderr)
    else:
        now = client.wait_clock(0)
        offset = (now // ticks + 2) * ticks
        print(f'replay_run: the node is at t = {now * schedule.dt:.6f} s; the recording is '
              f'replayed from t = {offset * schedule.dt:.6f} s on (shifted by {offset} steps)',
              file=sys.stderr)
    for event in list(schedule.events):
        assert event.step is not None          # a scheduled event carries its step
        progress.step = client.wait_clock(event.step + offset - lead)
        for due in schedule.due(progress.step - offset + lead):
            client.perform(due, schedule)
            progress.events += 1
    progress.step = client.wait_clock(schedule.end_step + offset + ticks)
    client.settle_graph(GRAPH_FINAL)
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


def spawn_node(schedule: Schedule, record: Path, ros_args: list[str], workdir: Path,
               lockstep: bool, factor: float) -> tuple[subprocess.Popen, Path]:
    """A fresh table_sim with the schedule's start parameters, recording to ``record``;
    (process, its log file)."""
    exe = shutil.which('table_sim')
    if exe is None:
        raise ReplayError('table_sim is not on PATH (source the workspace or the venv)')
    values = {**schedule.start, 'record': str(record), 'real_time_factor': float(factor),
              'publish_clock': True, 'lockstep': lockstep,     # ROS values already
              'duration': 0.0}       # the replay ends the node when its events are done
    params_file = workdir / 'replay_params.yaml'
    params_file.write_text(yaml.safe_dump({'/**': {'ros__parameters': values}},
                                          sort_keys=False))
    log_path = workdir / 'table_sim.log'
    remaps = [a for a in ros_args if a != '--ros-args']
    with open(log_path, 'w') as log:
        child = subprocess.Popen([exe, '--ros-args', *remaps, '--params-file', str(params_file)],
                                 stdout=log, stderr=subprocess.STDOUT,
                                 # only sets the parent-death signal: no lock taken
                                 preexec_fn=_die_with_parent)  # noqa: PLW1509
    return child, log_path


def stop_node(child: subprocess.Popen, grace: float) -> int | None:
    """SIGINT the spawned node (it closes its bag); its exit status, or None if it is
    still closing after ``grace`` s (it ends on its own)."""
    if child.poll() is None:
        child.send_signal(signal.SIGINT)
        try:
            return child.wait(timeout=grace)
        except subprocess.TimeoutExpired:
            return None
    return child.returncode


__all__ = [
    'CHILD_CLOSE',
    'CHILD_GRACE',
    'Progress',
    'replay_free',
    'replay_lockstep',
    'spawn_node',
    'stop_node',
]
