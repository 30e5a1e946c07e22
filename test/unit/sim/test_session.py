"""The node's behaviour, in-process: the Session that table_sim's pacing thread ticks.

Everything table_sim does to the physics happens in ``Session.tick()``; the node only
turns messages into events and ticks into messages. So what the node does with a
command, a parameter change, a reset or a diverging model is tested here, with no
DDS and no clock, against things the session does not compute itself: the plant
driven by hand, a fresh session started where the first one should be, the
recording read back by the bag reader and replayed.
"""

from __future__ import annotations

import math
from dataclasses import replace
from fractions import Fraction

import numpy as np
import pytest
from bag_runs import record_session

from screwgear_ros.bag.reader import read_run
from screwgear_ros.params.table import SimSettings, TableParams
from screwgear_ros.physics.equilibrium import equilibrium_state
from screwgear_ros.physics.quantities import natural_frequency
from screwgear_ros.runs.replay_in_process import replay_in_process
from screwgear_ros.sim.events import Command, ParameterChange, Reset
from screwgear_ros.sim.plant import DriveInput, Plant
from screwgear_ros.sim.schedule import Schedule
from screwgear_ros.sim.session import AdvanceMode, Session, Tick

P = TableParams(table_damping=8867.0)
S = SimSettings(publish_rate=1000.0)            # 20 steps of 50 µs per tick
TICK = S.steps_per_publish


def test_events_take_effect_at_the_first_step_of_the_next_tick():
    session = Session(P, S)
    session.tick()
    session.submit(Command('cmd_torque', 200.0))
    session.submit(Command('cmd_direction', -1))
    tick = session.tick()
    assert tick.start == TICK
    assert [e.step for e in tick.applied] == [TICK, TICK]
    assert tick.drive == DriveInput(200.0, -1, 0.0) and tick.reversal and tick.path_changed
    assert tick.outputs.step == 2 * TICK and tick.outputs.active_path == 3
    # the same as driving the plant by hand: one tick at rest, then the input, then a tick
    plant = Plant(P, S.dt)
    plant.advance(TICK)
    plant.set_input(DriveInput(200.0, -1, 0.0))
    plant.advance(TICK)
    assert np.array_equal(session.plant.state, plant.state)
    assert session.tick().applied == ()            # applied once, not again


def test_ticks_of_any_size_give_the_same_trajectory():
    """Steps per tick (publish_rate) only batch the integration: events at steps that
    are tick boundaries for every rate give bit-identical states there."""
    events = [(0, Command('cmd_torque', 150.0)), (2_000, Command('cmd_direction', -1)),
              (3_500, Command('load_torque', 400.0)), (5_000, Command('cmd_effort', [90.0])),
              (7_000, 'parameters'), (9_000, Reset()), (9_000, Command('cmd_effort', [-60.0]))]
    states = {}
    for rate in (20_000.0, 4_000.0, 1_000.0, 200.0):       # 1, 5, 20, 100 steps per tick
        settings = replace(S, publish_rate=rate)
        session = Session(P, settings)
        pending = list(events)
        samples = []
        while session.step < 12_000:
            while pending and pending[0][0] == session.step:
                event = pending.pop(0)[1]
                if event == 'parameters':
                    event = ParameterChange(P.replace(table_damping=30.0, preload_torque=320.0),
                                            settings)
                session.submit(event)
            session.tick()
            if session.step % 100 == 0:
                samples.append(session.plant.state.copy())
        states[rate] = np.array(samples)
    reference = states[1_000.0]
    assert np.all(np.isfinite(reference)) and reference[:, 4].max() > 0 > reference[:, 4].min()
    for rate, got in states.items():
        assert np.array_equal(got, reference), rate


def test_a_parameter_change_applies_at_the_tick_start_and_can_change_the_tick():
    session = Session(P, S)
    session.submit(Command('cmd_torque', 100.0))
    session.tick()
    faster = replace(S, publish_rate=200.0)                  # 100 steps per tick
    softer = P.replace(mesh_damping=1000.0)
    session.submit(ParameterChange(softer, faster))
    tick = session.tick()
    assert tick.params is softer and tick.start == TICK
    assert tick.outputs.step == TICK + 100 and session.settings is faster


def test_a_command_is_judged_by_the_limits_in_force_when_it_takes_effect():
    session = Session(P, S)
    session.submit(ParameterChange(P.replace(max_torque=100.0), S))
    session.submit(Command('cmd_torque', 150.0))       # fine before, too much from this step
    tick = session.tick()
    assert len(tick.rejected) == 1 and 'cmd_torque' in str(tick.rejected[0])
    assert tick.drive.torque == 0.0 and session.rejected['cmd_torque'] == 1
    assert [type(e) for e in tick.applied] == [ParameterChange]   # the refused one is not


def test_lowering_max_torque_cuts_the_torque_and_load_in_force():
    session = Session(P, S)
    session.submit(Command('cmd_effort', [-350.0]))
    session.submit(Command('load_torque', 2_000.0))
    session.tick()
    lower = P.replace(max_torque=100.0)
    session.submit(ParameterChange(lower, S))
    tick = session.tick()
    limit = 10.0 * 100.0 * P.radius_table / P.radius_pinion_1
    assert tick.drive == DriveInput(100.0, -1, min(2_000.0, limit))
    assert len(tick.notices) == 1 and '350 -> 100' in tick.notices[0]
    assert tick.outputs.effort[2] == pytest.approx(-100.0 - P.preload_torque)


def test_reset_returns_to_equilibrium_at_the_tick_start_and_time_runs_on():
    session = Session(P, S)
    session.submit(Command('cmd_torque', 300.0))
    for _ in range(50):
        session.tick()
    assert session.plant.state[1] > 1e-3                 # the table has turned
    session.submit(Reset())
    tick = session.tick()
    assert tick.start == 50 * TICK and tick.outputs.step == 51 * TICK
    # a fresh session started at rest at that step with the same input is where we are
    fresh = Session(P, S, equilibrium_state(P), start_step=50 * TICK)
    fresh.submit(Command('cmd_torque', 300.0))
    fresh.tick()
    assert np.array_equal(session.plant.state, fresh.plant.state)


def test_a_diverging_model_halts_time_and_state_until_a_reset():
    """k_a' = 0.5 pumped at 2·ω0 with no damping: the principal parametric resonance."""
    unstable = TableParams(mode='conventional', backlash=0.0, mesh_phase='time',
                           mesh_stiffness_amplitude=5.0e6, mesh_damping=0.0)
    unstable = unstable.replace(mesh_frequency=2.0 * natural_frequency(unstable))
    session = Session(unstable, S)
    faults = []
    for _ in range(20_000):
        tick = session.tick()
        faults.append(tick.new_fault)
        if tick.fault:
            break
    assert sum(faults) == 1 and tick.fault and 'non-finite' in tick.fault
    halted = session.step
    held = session.plant.state.copy()
    session.submit(Command('cmd_torque', 5.0))          # taken while halted
    tick = session.tick()
    assert session.step == halted and np.array_equal(session.plant.state, held)
    assert np.all(np.isfinite(held)) and tick.drive.torque == 5.0 and not tick.new_fault
    session.submit(ParameterChange(unstable.replace(mesh_stiffness_amplitude=1e6,
                                                    mesh_damping=717.0), S))
    session.submit(Reset())
    tick = session.tick()
    assert tick.fault is None and session.step == halted + TICK


def test_the_recording_of_a_session_replays_bit_for_bit(tmp_path):
    """The node's own RunIO records an in-process session; the bag reader and the
    in-process replay (a fresh session fed the recorded events) give it back exactly."""
    schedule = Schedule(P, replace(S, publish_rate=200.0), [
        Command('cmd_torque', 300.0, 2_000), Command('load_torque', 500.0, 8_000),
        ParameterChange(P.replace(mesh_damping=1434.9), replace(S, publish_rate=200.0), 20_000),
        Command('cmd_effort', [-350.0], 24_000), Reset(34_000),
        Command('cmd_effort', [250.0], 36_000)], end_step=42_000)
    recorder = record_session(tmp_path / 'run', schedule)
    assert recorder.dropped == 0
    run = read_run(tmp_path / 'run')
    assert [(type(e), e.step) for _, e in run.events] == [
        (type(e), e.step) for e in schedule.events]
    assert len(run.joint_states) == 42_000 // 100 + 1
    replayed = replay_in_process(run)
    assert np.array_equal(replayed.joint_states, run.joint_states.values)
    assert np.array_equal(replayed.transmission_error, run.transmission_error.values[:, 0])


def test_command_timeout_zeroes_torque_and_load_once_until_the_next_command():
    session = Session(P, replace(S, command_timeout=0.1))   # 0.1 s = 100 ticks of 1 ms
    session.submit(Command('cmd_effort', [-200.0]))
    session.submit(Command('load_torque', 50.0))
    session.submit(Command('cmd_torque', float('nan')))      # refused: does not count
    ticks = [session.tick() for _ in range(150)]
    warned = [k for k, tick in enumerate(ticks) if tick.notices]
    assert warned == [100] and 'command_timeout' in ticks[100].notices[0]
    assert ticks[99].drive == DriveInput(200.0, -1, 50.0)
    assert ticks[100].drive == DriveInput(0.0, -1, 0.0) and session.timed_out
    session.submit(Command('cmd_torque', 30.0))               # the next command resumes
    assert session.tick().drive == DriveInput(30.0, -1, 0.0) and not session.timed_out
    idle = Session(P, replace(S, command_timeout=0.0))       # 0 = off
    idle.submit(Command('cmd_torque', 30.0))
    assert all(idle.tick().drive.torque == 30.0 for _ in range(3000))


def test_a_recording_from_before_command_timeout_replays_without_one():
    from screwgear_ros.sim.run_file import RunParameters, dump, load
    text = dump(RunParameters(P, S, tuple(equilibrium_state(P)), package_version='0.1.0'))
    old = '\n'.join(line for line in text.splitlines() if not line.startswith('command_timeout'))
    assert load(text).settings.command_timeout == S.command_timeout == 1.0
    assert load(old).settings.command_timeout == 0.0


def test_an_applied_event_is_the_submitted_one_with_its_step():
    """The session stamps each event it applies with its step: a copy equal in every
    field to dataclasses.replace, the submitted one unchanged."""
    for event in (Command('cmd_effort', [1.5]), Command('joint_commands', None),
                  ParameterChange(TableParams(), SimSettings()), Reset()):
        stamped = event.at(42)
        assert type(stamped) is type(event) and event.step is None
        assert vars(stamped) == vars(replace(event, step=42))
        assert stamped == replace(event, step=42)


def test_the_fast_command_is_what_the_dataclass_makes():
    """Command.of (a closed loop submits one a tick) makes exactly Command(topic, value)."""
    for topic, value in (('cmd_effort', [2.5]), ('cmd_torque', 3.0), ('cmd_direction', -1)):
        fast, made = Command.of(topic, value), Command(topic, value)
        assert vars(fast) == vars(made) and fast == made and repr(fast) == repr(made)


def test_a_tick_given_its_command_is_a_submit_then_a_tick():
    """tick(command) skips the queue when nothing else waits in it: a seeded closed loop
    (valid efforts, refused ones, ticks with other events queued before the command)
    gives the same ticks, bit for bit, as submit(command) then tick()."""
    rng = np.random.default_rng(28)
    queued, direct = Session(P, S), Session(P, S)
    for k in range(300):
        effort = float(rng.uniform(-1.2, 1.2) * P.max_torque)     # some over the limit
        if k % 37 == 5:
            effort = float('nan')
        others = [Command('load_torque', float(rng.uniform(-50.0, 50.0)))] if k % 11 == 3 \
            else [Reset()] if k == 150 else []
        for session in (queued, direct):
            for event in others:
                session.submit(event)
        queued.submit(Command('cmd_effort', [effort]))
        a, b = queued.tick(), direct.tick(Command('cmd_effort', [effort]))
        assert (a.start, a.applied, a.notices, a.drive, a.fault) == \
            (b.start, b.applied, b.notices, b.drive, b.fault)
        assert [str(e) for e in a.rejected] == [str(e) for e in b.rejected]
        assert np.array_equal(queued.plant.observed, direct.plant.observed)
        assert a.outputs == b.outputs and a.previous == b.previous
    assert queued.rejected == direct.rejected and queued.rejected['cmd_effort'] > 0


def answered(session: Session, effort: object) -> Tick | None:
    """What the monitor gets of one tick that ``effort`` answers in AdvanceMode.ANSWERS
    (None: the fast tick ran)."""
    seen: list[Tick | None] = []
    assert session.advance(1, controller=lambda: effort, monitor=seen.append,
                           mode=AdvanceMode.ANSWERS) == 1
    return seen[0]


@pytest.mark.parametrize('params, settings', [
    (P.replace(effort_deadband=5.0), replace(S, command_timeout=0.03)),
    (P.replace(direction_hysteresis=150.0), S),
    (P, replace(S, encoder_counts_table=4096, position_noise_pinion_1=1e-4,
                velocity_noise_pinion_3=0.01, velocity_filter_cutoff_table=200.0,
                measurement_delay_pinion_1=2, sensor_seed=7)),
], ids=['deadband-timeout', 'hysteresis', 'sensors'])
def test_a_closed_loop_tick_is_the_tick_given_its_command(params, settings):
    """A tick answered by a controller in AdvanceMode.ANSWERS, the closed loop's fast
    tick, leaves the session exactly as
    tick(Command('cmd_effort', [e])) does (state bits, step, input, path, outputs, what
    the sensors measure, refusals counted, the timeout), for a seeded loop of
    valid answers, ones in the deadband, refused ones (too large, NaN, not a number),
    ints and NumPy floats, silent ticks, and other events queued before the answer; it
    returns None only for a tick that took the answer and nothing else, else the same
    Tick."""
    rng = np.random.default_rng(2028)
    fast, full = Session(params, settings), Session(params, settings)
    limit, band = params.max_torque, params.effort_deadband
    lowered = ParameterChange(params.replace(max_torque=0.5 * limit), settings)
    plain = timeouts = 0
    for k in range(400):
        pick = rng.integers(12)
        effort = (float(rng.uniform(-1.2, 1.2) * limit) if pick < 6 else
                  float(rng.uniform(-band, band)) if pick == 6 else
                  int(rng.integers(-limit, limit)) if pick == 7 else
                  np.float64(rng.uniform(-limit, limit)) if pick == 8 else
                  [math.nan, math.inf, 'ten', True][k % 4] if pick == 9 else None)
        others = ([Command('load_torque', float(rng.uniform(-50.0, 50.0)))] if k % 11 == 3
                  else [Reset()] if k in (150, 330) else [lowered] if k == 200
                  else [Command('cmd_direction', -1)] if k % 29 == 7 else [])
        if 100 <= k < 160:                   # long enough without a command to time out
            effort, others = None, others if k == 150 else []
        for session in (fast, full):
            for event in others:
                session.submit(event)
        start = full.step
        if effort is None:
            a, b = fast.tick(), full.tick()
        else:
            a, b = answered(fast, effort), full.tick(Command('cmd_effort', [effort]))
        if a is None:
            plain += 1
            assert not others and b.applied == (Command('cmd_effort', [effort], start),)
            assert b.rejected == () and b.notices == ()
        else:
            assert (a.start, a.applied, a.notices, a.drive, a.fault, a.new_fault,
                    a.outputs, a.previous, a.measured) == \
                (b.start, b.applied, b.notices, b.drive, b.fault, b.new_fault, b.outputs,
                 b.previous, b.measured)
            assert [str(e) for e in a.rejected] == [str(e) for e in b.rejected]
        assert fast.plant.full_state.tobytes() == full.plant.full_state.tobytes()
        assert fast.plant.observed.tobytes() == full.plant.observed.tobytes()
        assert (fast.step, fast.plant.fault, fast.timed_out, fast.rejected) == \
            (full.step, full.plant.fault, full.timed_out, full.rejected)
        assert fast.plant.input == full.plant.input == b.drive
        assert (fast.plant.direction, fast.plant.active_path) == \
            (b.drive.direction, b.outputs.active_path)
        assert fast.last_outputs == full.last_outputs == b.outputs
        assert fast.measured == full.measured
        timeouts += any('command_timeout' in notice for notice in b.notices)
    assert plain > 100 and full.rejected['cmd_effort'] > 20
    assert timeouts == 1 if settings.command_timeout < 0.05 else timeouts == 0


def test_a_closed_loop_tick_in_which_the_model_diverges_is_the_full_ticks():
    """The principal parametric resonance (as above), answered with a zero effort every
    tick: the fast tick's plant faults at the tick tick's does, with the same state put
    back, and from then on the fast tick is tick (the plant stands still)."""
    unstable = TableParams(mode='conventional', backlash=0.0, mesh_phase='time',
                           mesh_stiffness_amplitude=8.0e6, mesh_damping=0.0)
    unstable = unstable.replace(mesh_frequency=2.0 * natural_frequency(unstable))
    fast, full = Session(unstable, S), Session(unstable, S)
    for _ in range(20_000):
        assert answered(fast, 0.0) is None
        tick = full.tick(Command('cmd_effort', [0.0]))
        assert fast.plant.full_state.tobytes() == full.plant.full_state.tobytes()
        if tick.new_fault:
            break
    assert fast.plant.fault == full.plant.fault and 'non-finite' in fast.plant.fault
    assert fast.step == full.step and fast.last_outputs == full.last_outputs
    assert fast.plant.observed.tobytes() == full.plant.observed.tobytes()
    a, b = answered(fast, 100.0), full.tick(Command('cmd_effort', [100.0]))
    assert a is not None and (a.start, a.applied, a.drive, a.outputs, a.fault) == \
        (b.start, b.applied, b.drive, b.outputs, b.fault)
    assert fast.step == full.step == tick.start




@pytest.mark.parametrize('dt', [50e-6, 1e-4 / 3.0])
def test_outputs_and_ticks_carry_the_stamp_of_their_step(dt):
    """Every tick's outputs carry the integer ns of their step (step·dt_ns exactly when
    dt is whole ns, else the nearest ns), and the tick the time of its start: what the
    node stamps its messages and records its events with."""
    def exact_ns(step):
        return Fraction(step) * Fraction(dt) * 10**9

    settings = replace(S, dt=dt, publish_rate=1.0 / (20 * dt))
    session = Session(P, settings, start_step=123_456_789)
    assert abs(session.last_outputs.time_ns - exact_ns(session.step)) <= Fraction(1, 2) + 1e-3
    for _ in range(5):
        before = session.step
        tick = session.tick()
        assert tick.start == before
        assert abs(tick.start_ns - exact_ns(before)) <= Fraction(1, 2) + 1e-3
        assert abs(tick.outputs.time_ns - exact_ns(tick.outputs.step)) <= Fraction(1, 2) + 1e-3
        assert tick.outputs.time == tick.outputs.step * dt
        if dt == 50e-6:
            assert tick.outputs.time_ns == tick.outputs.step * 50_000
            assert tick.start_ns == before * 50_000
