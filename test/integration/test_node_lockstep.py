"""table_sim in lockstep, over real DDS: one tick per answer, responsive while it waits.

The controller here is the test itself: it answers each new joint_states stamp once,
so every assertion is about which tick comes after which message, never about how
fast the machine is (the only time limits are generous timeouts).
"""

from __future__ import annotations

import signal
import time
from pathlib import Path

import pytest
from diagnostic_msgs.msg import DiagnosticArray
from ros_procs import (
    STARTUP_TIMEOUT,
    Peer,
    RosProcess,
    assert_clean_exit,
    stamp_ns,
    start_process,
    wait_until,
)
from sensor_msgs.msg import JointState
from std_msgs.msg import Empty, Float64MultiArray
from std_srvs.srv import Trigger

from screwgear_ros.bag.reader import read_run
from screwgear_ros.sim.events import Command, ParameterChange, Reset

TICK_NS = 1_000_000          # 1 kHz publishing: one tick is 1 ms of simulation time
TICK_STEPS = 20              # of 50 µs


def _values(msg: DiagnosticArray) -> dict[str, str]:
    return {kv.key: kv.value for kv in msg.status[0].values}


def _recording_in_lockstep(tmp_path: Path) -> tuple[RosProcess, Path]:
    """table_sim in lockstep, as fast as the answers come, recording to tmp_path/run."""
    bag = tmp_path / 'run'
    return start_process('table_sim', params={'lockstep': True, 'real_time_factor': 0.0,
                                              'record': str(bag)},
                         workdir=tmp_path / 'sim'), bag


@pytest.mark.ros
def test_lockstep_ticks_once_per_answer_and_stays_responsive_while_waiting(tmp_path):
    sim, bag = _recording_in_lockstep(tmp_path)
    try:
        with Peer('test_lockstep') as peer:
            js = peer.subscribe('/joint_states', JointState)
            diag = peer.subscribe('/diagnostics', DiagnosticArray)
            # a subscriber that came late still gets the outputs it must answer (re-sent)
            assert stamp_ns(js.wait_for(lambda m: True, STARTUP_TIMEOUT, 'joint_states')) == 0
            waiting = diag.wait_for(lambda m: float(_values(m)['lockstep_waiting_s']) > 0.0,
                                    30.0, 'the wait for the controller in /diagnostics')
            assert _values(waiting)['lockstep'] == 'true'
            assert 'waiting' in waiting.status[0].message
            assert {stamp_ns(m) for m in js.snapshot()} == {0}     # no answer, no tick
            # responsive while waiting: parameters and reset are served at once
            results = peer.set_parameters('/table_sim', {'table_damping': 8867.0})
            assert all(r.successful for r in results)
            assert peer.call(Trigger, '/table_sim/reset').success
            effort = peer.publisher('/cmd_effort', Float64MultiArray)
            for k in range(1, 6):                 # each answer releases exactly one tick
                effort.publish(Float64MultiArray(data=[100.0 * (-1) ** k]))
                js.wait_next(lambda m, k=k: stamp_ns(m) == k * TICK_NS, 30.0, f'tick {k}')
            tick = peer.publisher('/table_sim/tick', Empty)
            peer.get_parameters('table_sim', ['lockstep'])     # the node matched `tick`
            tick.publish(Empty())                 # a tool's answer: a tick, no command
            last = js.wait_next(lambda m: stamp_ns(m) == 6 * TICK_NS, 30.0, 'tick 6')
            assert last.effort[2] == -(100.0 + 350.0)       # the last cmd_effort (-100): -(T + T_p)
            time.sleep(1.5)                       # nothing answered: the table waits
            assert max(stamp_ns(m) for m in js.snapshot()) == 6 * TICK_NS
        assert_clean_exit(sim, signal.SIGINT)     # Ctrl-C while it waits
    finally:
        sim.kill()
    log = sim.output()[1]
    assert log.count('lockstep: waiting for the controller') == 1
    assert 'the controller answered' in log
    run = read_run(bag)
    events = [e for _, e in run.events]
    assert [(type(e), e.step) for e in events] == [
        (ParameterChange, 0), (Reset, 0),
        *((Command, k * TICK_STEPS) for k in range(5))]
    assert [e.value for e in events if isinstance(e, Command)] == [
        [-100.0], [100.0], [-100.0], [100.0], [-100.0]]
    assert list(run.joint_states.steps) == [k * TICK_STEPS for k in range(7)]


@pytest.mark.ros
def test_command_timeout_stops_the_drive_when_the_commands_stop(tmp_path):
    """Lockstep with ~/tick answers (no command) after one cmd_effort: the drive torque
    goes to zero at the first tick 50 ms of simulation after that command, exactly."""
    sim = start_process('table_sim', params={'lockstep': True, 'real_time_factor': 0.0,
                                             'command_timeout': 0.05},
                        workdir=tmp_path / 'sim')
    try:
        with Peer('test_timeout') as peer:
            effort = peer.publisher('/cmd_effort', Float64MultiArray)
            ticks: list = []                     # the tick publisher, once there is one
            seen: dict[int, JointState] = {}

            def answer(msg: JointState) -> None:
                t = stamp_ns(msg)
                if t in seen:
                    return                       # a re-send: answered already
                seen[t] = msg
                if ticks and TICK_NS < t < 70 * TICK_NS:
                    ticks[0].publish(Empty())

            js = peer.subscribe('/joint_states', JointState)
            peer.node.create_subscription(JointState, '/joint_states', answer, 100)
            js.wait_for(lambda m: stamp_ns(m) == 0, STARTUP_TIMEOUT, 'joint_states')
            effort.publish(Float64MultiArray(data=[120.0]))     # answers tick 0
            js.wait_for(lambda m: stamp_ns(m) == TICK_NS, 30.0, 'tick 1')
            # From now on only ~/tick answers; the node has matched the publisher once it
            # served a request sent after it was created.
            ticks.append(peer.publisher('/table_sim/tick', Empty))
            peer.get_parameters('table_sim', ['lockstep'])
            ticks[0].publish(Empty())                           # answers tick 1
            # `seen` itself: js's subscription can take tick 70 before `answer`'s does
            wait_until(lambda: 70 * TICK_NS in seen, STARTUP_TIMEOUT, '70 ticks answered')
            drive = {t // TICK_NS: m.effort[0] - 350.0 for t, m in seen.items()}
            assert [drive[k] for k in (1, 49, 50)] == [120.0, 120.0, 120.0]
            assert [drive[k] for k in (51, 60, 70)] == [0.0, 0.0, 0.0]
            effort.publish(Float64MultiArray(data=[80.0]))   # the next command resumes
            peer.get_parameters('table_sim', ['lockstep'])   # taken (the module docstring)
            ticks[0].publish(Empty())
            js.wait_for(lambda m: stamp_ns(m) == 71 * TICK_NS and m.effort[0] == 430.0,
                        30.0, 'the drive resumed')
        assert_clean_exit(sim, signal.SIGINT)
    finally:
        sim.kill()
    log = sim.output()[1]
    assert log.count('(command_timeout)') == 1 and 'set to zero until the next command' in log


@pytest.mark.ros
def test_while_a_tool_publishes_on_tick_commands_do_not_answer(tmp_path):
    """A tool that answers with ~/tick owns the ticks: while its publisher exists, any
    number of cmd_effort messages are applied, in order, at the next tick, and none of
    them releases it; the one ~/tick does. (This is what lets replay_run send several
    commands in one tick.)"""
    sim, bag = _recording_in_lockstep(tmp_path)
    try:
        with Peer('test_tool_ticks') as peer:
            js = peer.subscribe('/joint_states', JointState)
            effort = peer.publisher('/cmd_effort', Float64MultiArray)
            tick = peer.publisher('/table_sim/tick', Empty)
            js.wait_for(lambda m: stamp_ns(m) == 0, STARTUP_TIMEOUT, 'joint_states')
            peer.get_parameters('table_sim', ['lockstep'])     # the node matched `tick`
            for k in range(1, 3):
                for value in (10.0 * k, 20.0 * k, -30.0 * k):
                    effort.publish(Float64MultiArray(data=[value]))
                    # taken before the next is sent (the node serves messages first)
                    peer.get_parameters('table_sim', ['lockstep'])
                time.sleep(0.5)                     # no answer yet: no tick
                assert max(stamp_ns(m) for m in js.snapshot()) == (k - 1) * TICK_NS
                tick.publish(Empty())
                last = js.wait_next(lambda m, k=k: stamp_ns(m) == k * TICK_NS, 30.0,
                                    f'tick {k}')
                assert last.effort[2] == -(30.0 * k + 350.0)   # the last cmd_effort in force
        assert_clean_exit(sim, signal.SIGINT)
    finally:
        sim.kill()
    run = read_run(bag)
    assert [(e.value, e.step) for _, e in run.events if isinstance(e, Command)] == [
        ([10.0], 0), ([20.0], 0), ([-30.0], 0),
        ([20.0], TICK_STEPS), ([40.0], TICK_STEPS), ([-60.0], TICK_STEPS)]
