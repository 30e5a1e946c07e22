"""Session.advance in AdvanceMode.ROWS does what repeated Session.tick does, bit for bit,
and replay_in_process (which advances so between events) equals a replay by tick() alone.

The anchor is tick() itself: two sessions get the same events at the same steps, one
ticks every tick, the other advances through the ticks between events in ROWS mode; every
tick's outputs and the sessions' whole state after it must be identical. Scenarios:
the four test bags' scripts (commands, reversals, load steps, parameter changes, a
reset), command_timeout coming due between commands (also while it is counting at
dt/2), and a model that diverges (the fault) and is reset.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from bag_runs import BAGS
from diverging import diverging
from paths import DATA

from screwgear_ros.bag.reader import read_run
from screwgear_ros.inprocess.scenario import schedule_from_scenario
from screwgear_ros.interface import topic_names
from screwgear_ros.params.table import SimSettings, TableParams
from screwgear_ros.runs.replay_in_process import replay_in_process
from screwgear_ros.runs.run_io import RunIO
from screwgear_ros.sim import row_ticks
from screwgear_ros.sim.events import Command, ParameterChange, Reset
from screwgear_ros.sim.row_ticks import QUIET_TICKS_PER_CALL
from screwgear_ros.sim.schedule import Schedule
from screwgear_ros.sim.session import ROW, AdvanceMode, Session, row_of


def _state(session: Session) -> tuple:
    p = session.plant
    return (p.state.tolist(), p.step, p.input, p.params, p.fault, p.contact_changes,
            session.timed_out, session.last_outputs, dict(session.rejected))


def _both(schedule: Schedule, ticks: int) -> tuple[np.ndarray, np.ndarray, int, int]:
    """Rows of every tick by tick() alone and advanced in ROWS mode between events (each
    event submitted before the first tick starting at or after its step); how many
    ticks went quietly, and how many times command_timeout came due. The two sessions
    end in the same state."""
    anchor, quiet = (Session(schedule.params, schedule.settings) for _ in range(2))
    rows = [np.empty((ticks, ROW)) for _ in range(2)]
    events = sorted(schedule.events, key=lambda e: e.step)
    k = timeouts = 0
    for i in range(ticks):
        while k < len(events) and events[k].step <= anchor.step:
            anchor.submit(events[k])
            k += 1
        tick = anchor.tick()
        rows[0][i] = row_of(tick.outputs)
        timeouts += any('command_timeout' in n for n in tick.notices)
    k = i = quietly = 0
    while i < ticks:
        if k < len(events) and events[k].step <= quiet.step:
            while k < len(events) and events[k].step <= quiet.step:
                quiet.submit(events[k])
                k += 1
            rows[1][i] = row_of(quiet.tick().outputs)
            i += 1
            continue
        span = ticks - i
        if k < len(events):        # the ticks that start before the next event's step
            span = min(span, -(-(events[k].step - quiet.step)
                               // quiet.settings.steps_per_publish))
        # compiled runs of ticks up to the first full one (command_timeout due), if any
        done = quiet.advance(span, mode=AdvanceMode.ROWS, rows=rows[1][i:],
                             monitor=lambda _: True)
        quietly += done
        i += done
    assert _state(anchor) == _state(quiet)
    return rows[0], rows[1], quietly, timeouts


@pytest.mark.parametrize('block', [QUIET_TICKS_PER_CALL, 7])
@pytest.mark.parametrize('name', BAGS)
def test_the_test_scenarios_advance_in_rows_as_by_tick(name: str, block: int, monkeypatch
                                                      ) -> None:
    """Also with 7 ticks per compiled call: every quiet stretch spans many calls."""
    monkeypatch.setattr(row_ticks, 'QUIET_TICKS_PER_CALL', block)
    schedule = schedule_from_scenario(DATA / 'scenarios' / f'{name}.yaml')
    ticks = schedule.end_step // schedule.settings.steps_per_publish
    a, b, quietly, _ = _both(schedule, ticks)
    assert np.array_equal(a, b)
    assert quietly > 0.9 * ticks


@pytest.mark.parametrize('divisor', [1, 2])
def test_command_timeout_comes_due_between_commands(divisor: int) -> None:
    """Timeouts of 0.3 s at dt and dt/2: it comes due inside quiet stretches, on and off
    the tick grid; the compiled ticks stop before it and tick() applies it."""
    dt = 50e-6 / divisor
    settings = SimSettings(dt=dt, publish_rate=200.0, command_timeout=0.3013)
    steps = round(1.0 / dt)
    events = [Command('cmd_torque', 300.0, 0), Command('load_torque', 100.0, steps),
              Command('cmd_direction', -1, int(1.7 * steps)), Command('cmd_torque', 200.0, 2 * steps)]
    schedule = Schedule(TableParams(table_damping=8867.0), settings, events)
    a, b, _, timeouts = _both(schedule, int(3.0 * 200))
    assert np.array_equal(a, b)
    assert timeouts == 3          # after 0.3013 s, 1.3013 s and 2.3013 s


@pytest.mark.parametrize('block', [QUIET_TICKS_PER_CALL, 7])
def test_a_fault_and_a_reset(block: int, monkeypatch) -> None:
    """A model that diverges (a parametric pump of the mesh stiffness, no mesh damping:
    test_node_fault's); the compiled ticks stop after the tick that faulted, the plant stands
    still, then a detuning change and a reset revive it, all as tick() does; also with 7
    ticks per compiled call (the fault then comes in a later call than the first)."""
    monkeypatch.setattr(row_ticks, 'QUIET_TICKS_PER_CALL', block)
    params, settings = diverging()
    probe = Session(params, settings)
    rows = np.empty((4000, ROW))
    done = probe.advance(until=4000 * settings.steps_per_publish, mode=AdvanceMode.ROWS,
                         rows=rows)
    assert probe.plant.fault is not None and done < 4000     # stopped after the fault
    assert np.all(np.isfinite(rows[:done]))
    revive = probe.step + 50 * settings.steps_per_publish
    events = [Command('cmd_torque', 5.0, probe.step + 10 * settings.steps_per_publish),
              ParameterChange(replace(params, mesh_damping=717.0,
                                      mesh_stiffness_amplitude=1.0e6), settings, revive),
              Reset(revive)]
    a, b, _, _ = _both(Schedule(params, settings, events), done + 400)
    assert np.array_equal(a, b)
    assert np.all(a[done:done + 49, :6] == a[done - 1, :6])   # standing still, state and time


@pytest.mark.parametrize('name', BAGS)
def test_replay_in_process_equals_a_replay_by_tick_alone(name: str) -> None:
    """The previous replay loop (tick() per sample, events before the sample that follows
    them in the file) against replay_in_process, at dt and dt/2; and at dt the recording."""
    run = read_run(DATA / name)
    for refine in (1, 2):
        replayed = replay_in_process(run, refine)
        start = run.parameters
        settings = start.settings.__class__(**{**start.settings.as_dict(),
                                               'dt': start.settings.dt / refine})
        session = Session(start.params, settings, np.asarray(start.initial_state),
                          start.start_step * refine)
        rows = np.empty((len(run.joint_states), ROW))
        rows[0] = row_of(session.last_outputs)
        k = 0
        for i in range(1, len(rows)):
            while k < len(run.events) and run.events[k][0] < run.joint_states.order[i]:
                event = run.events[k][1]
                if isinstance(event, ParameterChange):
                    event = ParameterChange(event.params, event.settings.__class__(
                        **{**event.settings.as_dict(), 'dt': event.settings.dt / refine}),
                        event.step)
                session.submit(event.__class__(**{**vars(event), 'step': event.step * refine}))
                k += 1
            rows[i] = row_of(session.tick().outputs)
        assert np.array_equal(replayed.joint_states, rows[:, :9])
        assert np.array_equal(replayed.transmission_error,
                              rows[:len(run.transmission_error), 9])
        assert replayed.fault == session.plant.fault
        if refine == 1:
            assert np.array_equal(replayed.joint_states, run.joint_states.values)


def test_a_recorded_fault_replays_bit_for_bit(tmp_path: Path) -> None:
    """A recording of the diverging model: the tick that faults leaves the time where it
    was, and so do the next two, then a detuning change and a reset revive it. It
    replays in-process to the same bits, the fault inside a quiet stretch."""
    params, settings = diverging()
    # Recorded as the node does (record_session's RunIO), the reviving events submitted
    # three ticks after the fault (time stands still meanwhile), as a service call would.
    session = Session(params, settings)
    io = RunIO(topic_names('', clock=settings.publish_clock), settings.joint_names)
    recorder = io.open_recorder(tmp_path / 'fault')
    io.start(session)
    standing = 0
    while standing < 3:
        io.tick(session, session.tick())
        standing += session.plant.fault is not None
    assert session.plant.fault is not None
    for event in (ParameterChange(replace(params, mesh_damping=717.0,
                                          mesh_stiffness_amplitude=1.0e6), settings),
                  Reset(), Command('cmd_torque', 50.0)):
        session.submit(event)
    for _ in range(200):
        io.tick(session, session.tick())
    recorder.close()
    run = read_run(tmp_path / 'fault')
    assert np.count_nonzero(np.diff(run.joint_states.steps) == 0) == 3   # time stood still
    replayed = replay_in_process(run)
    assert np.array_equal(replayed.joint_states, run.joint_states.values)
    assert np.array_equal(replayed.transmission_error, run.transmission_error.values[:, 0])
    assert replayed.fault is None                       # revived by the reset
    fine = replay_in_process(run, 2)                    # and at dt/2 (its own fault, if any)
    assert fine.joint_states.shape == replayed.joint_states.shape
