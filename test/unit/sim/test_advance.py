"""Session.advance, the session's one loop, against the session ticked by hand.

Each test runs the same run twice: once through ``advance`` and once tick by tick with
``submit`` and ``tick`` (the reference: events submitted before the tick whose first
step reaches theirs), and compares states, outputs and stamps bit for bit.
"""

from __future__ import annotations

import numpy as np
import pytest

from screwgear_ros.interface import Input
from screwgear_ros.params.table import SimSettings, TableParams
from screwgear_ros.sim.events import Command, ParameterChange, Reset, Timeline
from screwgear_ros.sim.session import ROW, Session, Tick, row_of

P = TableParams(table_damping=8867.0)
S = SimSettings(publish_rate=1000.0, command_timeout=0.02)   # 20 steps of 50 µs per tick
TICK = S.steps_per_publish
# Steps on and off the tick grid; one change of the tick's length (publish_rate).
EVENTS = [Command(Input.CMD_TORQUE, 150.0, step=0),
          Command(Input.CMD_DIRECTION, -1, step=2 * TICK + 7),
          ParameterChange(P, SimSettings(publish_rate=500.0, command_timeout=0.02),
                          step=5 * TICK),
          Command(Input.LOAD_TORQUE, 300.0, step=9 * TICK),
          Reset(step=30 * TICK + 3),
          Command(Input.CMD_EFFORT, [40.0], step=31 * TICK)]


def by_hand(ticks: int) -> tuple[Session, list[Tick]]:
    """The reference: every event submitted before the tick that starts at or after
    its step, one tick() at a time."""
    session, done, k = Session(P, S), [], 0
    for _ in range(ticks):
        while k < len(EVENTS) and EVENTS[k].step <= session.step:
            session.submit(EVENTS[k])
            k += 1
        done.append(session.tick())
    return session, done


def test_events_due_on_the_way_land_at_their_step_and_the_monitor_sees_every_tick():
    session, seen = Session(P, S), []
    assert session.advance(60, events=EVENTS, monitor=seen.append) == 60
    reference, ticks = by_hand(60)
    assert len(seen) == 60 and all(isinstance(t, Tick) for t in seen)
    assert [t.start for t in seen] == [t.start for t in ticks]
    applied = [(e.step, type(e)) for t in seen for e in t.applied]
    assert applied == [(e.step, type(e)) for t in ticks for e in t.applied]
    # each at the first tick start at or after its step: never before it, never a tick late
    starts = [t.start for t in seen]
    for event, (step, _) in zip(EVENTS, applied, strict=True):
        assert step >= event.step
        assert step == min(s for s in starts if s >= event.step)
    assert np.array_equal(session.plant.full_state, reference.plant.full_state)
    assert session.last_outputs.time_ns == reference.last_outputs.time_ns


def test_same_bits_as_ticking_one_by_one_in_compiled_chunks():
    """With ``rows`` and no monitor, the ticks between events (and the command timeout's)
    run many per compiled call: the rows are the hand-ticked outputs, bit for bit."""
    rows = np.empty((80, ROW))
    session = Session(P, S)
    assert session.advance(80, events=EVENTS, rows=rows) == 80
    reference, ticks = by_hand(80)
    assert np.array_equal(rows, np.array([row_of(t.outputs) for t in ticks]))
    assert np.array_equal(session.plant.full_state, reference.plant.full_state)


def test_until_a_time_stops_at_the_exact_stamp_and_a_timeline_continues():
    session, timeline = Session(P, S), Timeline(EVENTS)
    assert session.advance_to(0.003, events=timeline) == 3
    assert session.last_outputs.time_ns == 3_000_000
    # the ticks are twice as long from step 5·TICK: 0.003 s -> 0.005 s, then 0.007 s
    assert session.advance(until=7 * TICK, events=timeline) == 3
    assert session.step == 7 * TICK
    assert session.advance(ticks=2, until=10**9, events=timeline) == 2   # first limit wins
    reference, _ = by_hand(8)
    assert np.array_equal(session.plant.full_state, reference.plant.full_state)


def test_a_controller_answers_each_tick_and_the_fast_path_gives_the_same_bits():
    """A controller's answer alone runs the fast tick (the monitor gets None); asking for
    every tick makes each a full Tick; both leave the session as tick(command) does."""
    def controller_of(session: Session):
        return lambda: 50.0 * np.sin(session.step * 1e-3)

    fast, full = Session(P, S), Session(P, S)
    fast_seen: list = []
    full_seen: list = []
    fast.advance(40, controller=controller_of(fast), monitor=fast_seen.append)
    full.advance(40, controller=controller_of(full), monitor=full_seen.append,
                 every_tick=True)
    hand = Session(P, S)
    for _ in range(40):
        hand.tick(Command(Input.CMD_EFFORT, [50.0 * np.sin(hand.step * 1e-3)]))
    assert fast_seen == [None] * 40 and all(isinstance(t, Tick) for t in full_seen)
    for session in (fast, full):
        assert np.array_equal(session.plant.full_state, hand.plant.full_state)
        assert session.last_outputs.time_ns == hand.last_outputs.time_ns
        assert row_of(session.last_outputs) == row_of(hand.last_outputs)


def test_a_monitor_that_answers_true_stops_after_that_tick():
    session = Session(P, S)
    assert session.advance(10, monitor=lambda tick: tick.start >= 3 * TICK) == 4
    assert session.step == 4 * TICK


def test_advance_needs_a_limit_and_events_need_their_step():
    with pytest.raises(ValueError):
        Session(P, S).advance()
    with pytest.raises(ValueError):
        Session(P, S).advance(1, events=[Reset()])


def test_the_old_tick_paths_answer_for_one_release():
    a, b = Session(P, S), Session(P, S)
    with pytest.warns(DeprecationWarning, match='Session.advance'):
        assert a.tick_effort(10.0) is None
    with pytest.warns(DeprecationWarning, match='Session.advance'):
        assert a.tick_quietly(3, np.empty((3, ROW))) == 3
    b.advance(1, controller=lambda: 10.0)
    b.advance(3, rows=np.empty((3, ROW)))
    assert np.array_equal(a.plant.full_state, b.plant.full_state)
