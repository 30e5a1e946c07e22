"""Replaying the checked-in bags: in-process bit for bit, and over DDS into real nodes.

In-process: the recorded inputs, parameter changes and resets fed to a fresh session
at their recorded steps give the recorded outputs bit for bit.

Over DDS, lockstep: ``replay_run BAG --record NEW`` starts a fresh table_sim with
``lockstep:=true`` and answers each of its ticks itself, after sending the events due
at that tick; the node records what it applied. NEW must be BAG again, exactly: every
event at its recorded step and every output sample identical (runs.compare's
exact_comparison), and it must pass check_run on its own. Into an already running
lockstep node the run is shifted to the node's current step, and every event must
land on its recorded step + that offset exactly.

Over DDS, free-running: into a running node with ``lockstep: false`` events are sent
as its /clock passes their steps, so where they land follows the wall clock and the
machine's load. Those tests assert only what holds however loaded the machine is:
every command applied, in order, and a recording that passes check_run.
"""

from __future__ import annotations

import dataclasses
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest
from bag_runs import BAGS, copy_bag, installed
from paths import DATA
from ros_procs import STARTUP_TIMEOUT, Peer, assert_clean_exit, stamp_ns, start_process, wait_until

from screwgear_ros.bag.reader import RecordedRun, read_run
from screwgear_ros.inprocess.scenario import schedule_from_scenario
from screwgear_ros.runs.compare import (
    compare_runs,
    exact_comparison,
    format_comparison,
    format_exact,
    shift_event,
)
from screwgear_ros.runs.lockstep_plan import plan_from_run
from screwgear_ros.runs.replay_in_process import replay_in_process, schedule_from_run
from screwgear_ros.sim.events import Command, ParameterChange, Reset

#: Generous bounds for a process to finish: a hang fails the test, a slow machine does not.
TOOL_TIMEOUT = 600.0
WAIT = 120.0


def tool(name: str, *args: object, timeout: float = TOOL_TIMEOUT) -> subprocess.CompletedProcess:
    return installed(name, *args, timeout=timeout)


def assert_no_traceback(result: subprocess.CompletedProcess) -> None:
    assert 'Traceback' not in result.stdout + result.stderr, result.stdout + result.stderr


def events_of(run: RecordedRun) -> list[tuple[str, object, int]]:
    """(kind, content, step) of every event a replay of ``run`` plays, in file order
    (not the real_time_factor changes of the old recordings' start-up)."""
    out = []
    for event in schedule_from_run(run).events:
        if isinstance(event, Command):
            out.append((event.topic, event.value, event.step))
        elif isinstance(event, ParameterChange):
            out.append(('parameters', event.params, event.step))
        else:
            out.append(('reset', None, event.step))
    return out


@pytest.mark.parametrize('name', BAGS)
def test_in_process_replay_is_bit_for_bit(name: str) -> None:
    run = read_run(DATA / name)
    commands = [e for _, e in run.events if isinstance(e, Command)]
    assert commands and len(run.joint_states) > 500
    replay = replay_in_process(run)
    assert replay.fault is None
    assert np.array_equal(replay.joint_states, run.joint_states.values)
    assert np.array_equal(replay.transmission_error, run.transmission_error.values[:, 0])
    # ... and the comparison can fail: the first command one tick late is visible.
    index = next(k for k, (_, e) in enumerate(run.events) if isinstance(e, Command))
    late = replay_in_process(shift_event(run, index, run.parameters.settings.steps_per_publish))
    assert not np.array_equal(late.joint_states, run.joint_states.values)


@pytest.mark.ros
@pytest.mark.parametrize('name', BAGS)
def test_lockstep_replay_into_a_fresh_node_is_exact(name: str, tmp_path: Path) -> None:
    new = tmp_path / name
    ros_args = ['--ros-args', '-r', '__ns:=/axis_c'] if name == 'load_steps_parameter_changes' \
        else []
    result = tool('replay_run', DATA / name, '--record', new, '--compare', *ros_args)
    assert_no_traceback(result)
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'IDENTICAL' in result.stdout, result.stdout

    original, replayed = read_run(DATA / name), read_run(new)
    comparison = exact_comparison(original, replayed)
    assert comparison.ok, format_exact(comparison)
    assert comparison.timings and all(t.delay == 0 for t in comparison.timings)
    assert replayed.parameters.settings.lockstep
    if ros_args:
        assert '/axis_c/joint_states' in replayed.topics
        assert '/axis_c/table_sim/run_parameters' in replayed.topics
    checked = tool('check_run', '--no-progress', new)
    assert checked.returncode == 0, checked.stdout + checked.stderr


@pytest.mark.ros
def test_lockstep_keeps_the_order_of_events_in_one_tick(tmp_path: Path) -> None:
    """Several events at one step, the same topic several times among them, cmd_effort
    (which answers a tick for a controller) first, in the middle and last: each is in
    the node's queue before the next is sent and the replay answers with ~/tick, so the
    node applies (and records) them all in the scenario's order, at its step, and a
    replay of that recording is exact again."""
    scenario = tmp_path / 'crowded.yaml'
    scenario.write_text(
        'parameters: {publish_rate: 200.0, table_damping: 8867.0}\nduration: 0.6\nactions:\n'
        '  - {time: 0.1, cmd_effort: [100.0]}\n'
        '  - {time: 0.1, load_torque: 100.0}\n'
        '  - {time: 0.1, cmd_torque: 50.0}\n'
        '  - {time: 0.1, cmd_effort: [120.0]}\n'
        '  - {time: 0.1, cmd_effort: [130.0]}\n'
        '  - {time: 0.1, cmd_torque: 300.0}\n'
        '  - {time: 0.1, cmd_direction: -1}\n'
        '  - {time: 0.3, cmd_torque: 200.0}\n'
        '  - {time: 0.3, reset: true}\n'
        '  - {time: 0.3, parameters: {mesh_damping: 1000.0}}\n'
        '  - {time: 0.3, load_torque: -50.0}\n'
        '  - {time: 0.3, cmd_effort: [-150.0]}\n'
        '  - {time: 0.3, cmd_effort: [-160.0]}\n')
    recorded = tmp_path / 'crowded'
    result = tool('replay_run', '--script', scenario, '--record', recorded)
    assert_no_traceback(result)
    assert result.returncode == 0, result.stdout + result.stderr
    schedule = schedule_from_scenario(scenario)
    run = read_run(recorded)
    expected = [('parameters', e.params, e.step) if isinstance(e, ParameterChange)
                else ('reset', None, e.step) if isinstance(e, Reset)
                else (e.topic, e.value, e.step) for e in schedule.events]
    assert events_of(run) == expected

    again = tmp_path / 'again'
    result = tool('replay_run', recorded, '--record', again, '--compare')
    assert result.returncode == 0, result.stdout + result.stderr
    assert exact_comparison(run, read_run(again)).ok


def advance_lockstep_node(ticks: int) -> int:
    """Answer a running lockstep table_sim (root namespace) ``ticks`` times through
    ``table_sim/tick``; the step of the joint_states it then waits at."""
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Empty
    with Peer('advance_lockstep') as peer:
        inbox = peer.subscribe('joint_states', JointState)
        answer = peer.publisher('table_sim/tick', Empty, wait_matched=WAIT)
        # A service round trip: the node has then matched the publisher created before it.
        assert peer.get_parameters('table_sim', ['lockstep'], timeout=WAIT) == {'lockstep': True}
        seen = stamp_ns(inbox.wait_for(lambda m: True, timeout=WAIT, what='joint_states'))
        for _ in range(ticks):
            answer.publish(Empty())
            last = seen
            seen = stamp_ns(inbox.wait_for(lambda m, last=last: stamp_ns(m) > last, timeout=WAIT,
                                           what=f'joint_states after {last} ns'))
    return seen


@pytest.mark.ros
def test_lockstep_replay_into_a_running_node_lands_at_recorded_step_plus_offset(
        tmp_path: Path) -> None:
    """A running lockstep node that a controller already drove a few ticks: the replay
    starts at the node's current step, and the node's own recording shows every event
    (commands, parameter changes, a reset) at its recorded step + that offset."""
    original = read_run(DATA / 'load_steps_parameter_changes')
    start = schedule_from_run(original).start
    node = start_process('table_sim', params={**start, 'record': str(tmp_path / 'live'),
                                              'lockstep': True, 'real_time_factor': 0.0},
                         workdir=tmp_path / 'node')
    try:
        now_ns = advance_lockstep_node(5)
        result = tool('replay_run', DATA / 'load_steps_parameter_changes')
        assert_no_traceback(result)
        assert result.returncode == 0, result.stdout + result.stderr
        assert node.alive()
        assert_clean_exit(node)
    finally:
        node.kill()
    ticks = original.parameters.settings.steps_per_publish
    now = round(now_ns / (original.dt * 1e9))
    assert now == 5 * ticks
    offset = int(re.search(r'shifted by (\d+) steps', result.stderr).group(1))
    assert offset == now, result.stderr

    live = read_run(tmp_path / 'live')
    recorded, applied = events_of(original), events_of(live)
    assert [(kind, content) for kind, content, _ in applied] == \
        [(kind, content) for kind, content, _ in recorded]
    assert [step for *_, step in applied] == [step + offset for *_, step in recorded]
    assert any(kind == 'reset' for kind, *_ in applied)
    checked = tool('check_run', '--no-progress', tmp_path / 'live')
    assert checked.returncode == 0, checked.stdout + checked.stderr


@pytest.mark.ros
def test_free_running_replay_into_a_running_node(tmp_path: Path) -> None:
    """Into a free-running node the replay follows its /clock; where each command lands
    depends on the wall clock, so only load-proof facts are checked."""
    original = read_run(DATA / 'reversals_anti_backlash')
    start = schedule_from_run(original).start
    node = start_process('table_sim', params={**start, 'record': str(tmp_path / 'live'),
                                              'real_time_factor': 1.0},
                         workdir=tmp_path / 'node')
    try:
        wait_until(lambda: (tmp_path / 'live' / 'metadata.yaml').exists(), STARTUP_TIMEOUT,
                   'table_sim to open its recording')
        result = tool('replay_run', DATA / 'reversals_anti_backlash')
        assert_no_traceback(result)
        assert result.returncode == 0, result.stdout + result.stderr
        assert 'follows the wall clock' in result.stderr, result.stderr
        assert_clean_exit(node)
    finally:
        node.kill()
    live = read_run(tmp_path / 'live')
    recorded = [(e.topic, e.value) for _, e in original.events if isinstance(e, Command)]
    applied = [(e.topic, e.value) for _, e in live.events if isinstance(e, Command)]
    assert applied == recorded
    checked = tool('check_run', '--no-progress', tmp_path / 'live')
    assert checked.returncode == 0, checked.stdout + checked.stderr


@pytest.mark.ros
def test_free_running_replay_with_record_is_explained_by_its_timing(tmp_path: Path) -> None:
    """``--free-running`` records a fresh free-running node; --compare then checks that
    the new run is what the original's events make at the steps they landed, and says
    so. Where they landed depends on the load, so the verdict itself must be CONSISTENT:
    the node computes exactly what its events make, whatever their timing."""
    new = tmp_path / 'free'
    result = tool('replay_run', DATA / 'steady_drive', '--record', new, '--free-running',
                  '--rate', 2.0, '--compare')
    assert_no_traceback(result)
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'free-running replay vs original' in result.stdout, result.stdout
    assert 'RESULT: CONSISTENT (timing differs by up to ' in result.stdout, result.stdout
    assert 'at the steps they landed' in result.stderr, result.stderr
    original, replayed = read_run(DATA / 'steady_drive'), read_run(new)
    assert not replayed.parameters.settings.lockstep
    assert [(e.topic, e.value) for _, e in replayed.events if isinstance(e, Command)] == \
        [(e.topic, e.value) for _, e in original.events if isinstance(e, Command)]
    checked = tool('check_run', '--no-progress', new)
    assert checked.returncode == 0, checked.stdout + checked.stderr


@pytest.mark.parametrize('name', BAGS)
def test_the_free_running_comparison_fails_what_timing_does_not_explain(name: str) -> None:
    """compare_runs in-process: a run against itself passes (bit for bit); a run whose
    first command is recorded a tick later than its outputs show fails, naming the first
    sample that its events do not make; a run with no samples compared nothing."""
    run = read_run(DATA / name)
    same = compare_runs(run, run)
    assert same.ok and same.identical and same.nothing_compared is None, \
        format_comparison(same)
    index = next(k for k, (_, e) in enumerate(run.events) if isinstance(e, Command))
    late = shift_event(run, index, run.parameters.settings.steps_per_publish)
    moved = compare_runs(run, late)
    assert not moved.ok and moved.first_difference is not None, format_comparison(moved)
    assert moved.timings[0].delay == run.parameters.settings.steps_per_publish
    empty = dataclasses.replace(run, true_joint_states=_none_of(run.true_joint_states),
                                transmission_error=_none_of(run.transmission_error))
    nothing = compare_runs(run, empty)
    assert nothing.nothing_compared is not None and not nothing.ok
    assert 'PASS' not in format_comparison(nothing)


def _none_of(signal: object) -> object:
    return dataclasses.replace(signal, steps=signal.steps[:0], order=signal.order[:0],
                               values=signal.values[:0])


def drop_joint_states_at(step: int, dt_ns: int):
    """An edit for copy_bag: the joint_states of ``step`` left out (a lost tick)."""
    def edit(topic: str, msgtype: str, log_time: int, raw: bytes):
        if topic.endswith('/joint_states') and log_time == step * dt_ns:
            return None
        return log_time, raw
    return edit


def record_a_fault(bag: Path) -> None:
    """A run of the diverging model recorded as the node does: the time stands still for
    a few ticks, then a detuning change, a reset and a command revive it in one tick."""
    from diverging import diverging

    from screwgear_ros.interface import topic_names
    from screwgear_ros.runs.run_io import RunIO
    from screwgear_ros.sim.session import Session
    params, settings = diverging()
    session = Session(params, settings)
    io = RunIO(topic_names('', clock=settings.publish_clock), settings.joint_names)
    recorder = io.open_recorder(bag)
    io.start(session)
    standing = 0
    while standing < 3:
        io.tick(session, session.tick())
        standing += session.plant.fault is not None
    for event in (ParameterChange(dataclasses.replace(params, mesh_damping=717.0,
                                                      mesh_stiffness_amplitude=1.0e6),
                                  settings),
                  Reset(), Command('cmd_torque', 50.0)):
        session.submit(event)
    for _ in range(100):
        io.tick(session, session.tick())
    recorder.close()


@pytest.mark.ros
def test_a_killed_replay_takes_its_node_down(tmp_path: Path) -> None:
    """replay_run killed with SIGKILL (e.g. by a timeout): the lockstep node it spawned
    gets SIGINT from the kernel, closes its bag and ends, instead of waiting forever."""
    new = tmp_path / 'killed'
    replay = start_process('replay_run', args=[str(DATA / 'steady_drive'), '--record',
                                               str(new), '--rate', '0.25'],
                           workdir=tmp_path / 'replay')
    try:
        wait_until(lambda: (new / 'metadata.yaml').exists(), WAIT, 'the node to record')
    finally:
        replay.kill()

    def closed() -> bool:
        try:
            return read_run(new).truncated is None
        except Exception:  # noqa: BLE001 -- still being written
            return False
    wait_until(closed, WAIT, 'the orphaned node to close its bag', poll=0.2)


@pytest.mark.ros
def test_replay_errors_exit_2_with_the_reason(tmp_path: Path) -> None:
    not_a_bag = tool('replay_run', tmp_path / 'nothing', '--record', tmp_path / 'new')
    assert not_a_bag.returncode == 2 and not_a_bag.stderr.startswith('replay_run: ')
    assert_no_traceback(not_a_bag)

    taken = tmp_path / 'taken'
    taken.mkdir()
    exists = tool('replay_run', DATA / 'steady_drive', '--record', taken)
    assert exists.returncode == 2 and 'exists' in exists.stderr, exists.stderr
    assert_no_traceback(exists)

    # A recording that lost a tick (a full recorder queue in real time): refused before
    # any node starts.
    lost, run = tmp_path / 'lost', read_run(DATA / 'steady_drive')
    copy_bag(DATA / 'steady_drive', lost,
             drop_joint_states_at(int(run.joint_states.steps[50]), round(run.dt * 1e9)))
    refused = tool('replay_run', lost, '--record', tmp_path / 'from_lost')
    assert refused.returncode == 2 and 'lost ticks' in refused.stderr, refused.stderr
    assert not (tmp_path / 'from_lost').exists()
    assert_no_traceback(refused)


@pytest.mark.ros
def test_a_replay_of_a_start_sample_only_bag_is_not_identical(tmp_path: Path) -> None:
    """A bag holding only its start sample (a run of length 0, or the main chunk lost)
    holds no run: comparing its replay with it is "could not do the work" (exit 2)."""
    copy_bag(DATA / 'steady_drive', tmp_path / 'start',
             lambda topic, msgtype, t, raw: (t, raw) if t == 0 else None)
    result = tool('replay_run', tmp_path / 'start', '--record', tmp_path / 'new', '--compare')
    assert_no_traceback(result)
    assert result.returncode == 2, result.stdout + result.stderr
    assert 'IDENTICAL' not in result.stdout and 'nothing compared' in result.stderr
    assert 'after the start' in result.stderr, result.stderr


@pytest.mark.ros
def test_a_run_whose_time_stood_still_replays_exactly_in_lockstep(tmp_path: Path) -> None:
    """After a diverged model the node publishes ticks with one stamp until a reset; the
    replay counts ticks (mesh_state), not stamps, so every event lands in its tick and
    the replay is the recording again."""
    bag = tmp_path / 'fault'
    record_a_fault(bag)
    run = read_run(bag)
    assert np.count_nonzero(np.diff(run.joint_states.steps) == 0) >= 3   # time stood still
    result = tool('replay_run', bag, '--record', tmp_path / 'again', '--compare')
    assert_no_traceback(result)
    assert result.returncode == 0, result.stdout + result.stderr
    assert exact_comparison(run, read_run(tmp_path / 'again')).ok


def test_the_plan_counts_ticks_and_refuses_a_recording_that_lost_one() -> None:
    run = read_run(DATA / 'steady_drive')
    plan = plan_from_run(run)
    assert plan.ticks == len(run.joint_states) - 1
    ticks = run.parameters.settings.steps_per_publish
    # each event applied by the tick that starts at its step: sample (step / ticks) + 1
    assert all(tick == event.step // ticks + 1 for tick, event in plan.events)
    steps = run.joint_states.steps.copy()
    steps[10:] += ticks                  # one tick missing after sample 9
    lost = dataclasses.replace(run, true_joint_states=dataclasses.replace(
        run.true_joint_states, steps=steps))
    with pytest.raises(ValueError, match='lost ticks'):
        plan_from_run(lost)
