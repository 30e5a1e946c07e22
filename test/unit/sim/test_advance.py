"""Session.advance, the session's one loop, against the session ticked by hand.

Each test runs the same run twice: once through ``advance`` and once tick by tick with
``submit`` and ``tick`` (the reference: events submitted before the tick whose first
step reaches theirs), and compares states, outputs and stamps bit for bit.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from screwgear_ros.errors import ScrewgearError
from screwgear_ros.interface import Input
from screwgear_ros.params.table import SimSettings, TableParams
from screwgear_ros.sim.events import (
    AdvanceError,
    Command,
    ParameterChange,
    Reset,
    Setpoint,
    Timeline,
)
from screwgear_ros.sim.session import ROW, AdvanceMode, Session, Tick, row_of

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
    """In ROWS mode, the ticks between events (and the command timeout's)
    run many per compiled call: the rows are the hand-ticked outputs, bit for bit."""
    rows = np.empty((80, ROW))
    session = Session(P, S)
    assert session.advance(80, events=EVENTS, mode=AdvanceMode.ROWS, rows=rows) == 80
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
    """In ANSWERS mode a controller's answer alone runs the fast tick (the monitor gets
    None); in TICKS mode each is a full Tick; both leave the session as tick(command)
    does."""
    def controller_of(session: Session):
        return lambda: 50.0 * np.sin(session.step * 1e-3)

    fast, full = Session(P, S), Session(P, S)
    fast_seen: list = []
    full_seen: list = []
    fast.advance(40, controller=controller_of(fast), monitor=fast_seen.append,
                 mode=AdvanceMode.ANSWERS)
    full.advance(40, controller=controller_of(full), monitor=full_seen.append)
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


@pytest.mark.parametrize('kwargs, words', [
    ({}, 'needs ticks, until or both'),
    ({'ticks': -5}, 'ticks must be an integer >= 0, got -5'),
    ({'ticks': 2.5}, 'ticks must be an integer >= 0, got 2.5'),
    ({'ticks': math.nan}, 'ticks must be an integer >= 0, got nan'),
    ({'ticks': True}, 'ticks must be an integer >= 0, got True'),
    ({'ticks': '3'}, "ticks must be an integer >= 0, got '3'"),
    ({'until': 1.5}, 'until must be a step'),
    ({'until': -1}, 'until must be a step'),
    ({'ticks': 1, 'events': [Reset()]}, 'events[0] (reset) needs the step'),
    ({'ticks': 1, 'events': ['reset']}, 'events[0] must be a session event'),
    ({'ticks': 1, 'events': Reset(step=0)}, 'events must be a sequence'),
    ({'ticks': 1, 'events': [Reset(step=-3)]}, 'its step must be an integer >= 0, got -3'),
    ({'ticks': 1, 'events': [Reset(step=2.0)]}, 'its step must be an integer >= 0'),
    ({'ticks': 1, 'events': [Reset(step=40), Reset(step=4)]},
     'events[1] (reset) is at step 4, before step 40 of the event ahead of it'),
    ({'ticks': 1, 'mode': 'rows'}, 'mode must be an AdvanceMode'),
    ({'ticks': 1, 'mode': AdvanceMode.ROWS}, 'it needs rows'),
    ({'ticks': 3, 'rows': np.empty((2, ROW))}, 'rows has 2 rows, fewer than the 3'),
    ({'ticks': 1, 'rows': np.empty((2, 3))}, 'rows must be a float64 array'),
])
def test_an_argument_that_breaks_its_rule_is_refused_by_name(kwargs, words):
    """Each refusal names the argument and the rule, is a ScrewgearError, a ValueError
    and a TypeError, and leaves the session where it was."""
    session = Session(P, S)
    before = session.plant.full_state.tobytes()
    with pytest.raises(AdvanceError) as caught:
        session.advance(**kwargs)
    assert words in str(caught.value)
    assert isinstance(caught.value, ScrewgearError | ValueError | TypeError)
    assert session.step == 0 and session.plant.full_state.tobytes() == before


def test_an_event_behind_the_session_or_a_time_before_it_is_refused():
    """An event is never applied after its step: a new sequence whose first event lies
    before the session's step is refused, and so is a time (or step) in the past."""
    session = Session(P, S)
    session.advance(5)
    with pytest.raises(AdvanceError, match='events.0. is at step 0, before the session'):
        session.advance(1, events=[Command(Input.CMD_TORQUE, 1.0, step=0)])
    with pytest.raises(AdvanceError, match='until must be a step'):
        session.advance(until=4 * TICK)
    for time in (0.001, math.nan, math.inf, 'soon', None, 10**400):
        with pytest.raises(AdvanceError, match='time must be a finite simulation time'):
            session.advance_to(time)   # type: ignore[arg-type]
    assert session.step == 5 * TICK
    assert session.advance(np.int64(2)) == 2          # a NumPy integer is an integer


def test_fuzz_advance_takes_only_what_its_rules_allow():
    """A seeded family of hostile advance() calls (counts, steps, times, event lists of
    odd elements, steps and orders, setpoints that are no angle, every mode): each is
    either refused with an AdvanceError naming its argument, the session untouched, or
    runs and leaves the same bits as a twin advanced in TICKS mode; never another
    exception."""
    odd = [-5, 2.5, math.nan, math.inf, None, 'x', True, 10**30, -(10**30), np.float64(3.0)]
    for seed in range(400):
        rng = np.random.default_rng(seed)
        session, twin = Session(P, S), Session(P, S)
        for _ in range(6):
            kind = rng.integers(5)
            before = session.plant.full_state.tobytes()
            step = session.step
            events = sorted(
                (Command(Input.CMD_TORQUE, float(rng.uniform(0, 200)),
                         step=step + int(rng.integers(0, 5 * TICK))),
                 Setpoint(odd[rng.integers(len(odd))] if rng.random() < 0.5 else 0.1,
                          step=step + int(rng.integers(0, 5 * TICK)))),
                key=lambda e: e.step)
            if kind == 0:
                events.reverse()
            elif kind == 1:
                events = [*events, odd[rng.integers(len(odd))]]
            # (a huge count is a long run, not a hostile one: 10**30 is only a step here)
            ticks = odd[rng.integers(len(odd))] if kind == 2 else int(rng.integers(0, 8))
            ticks = 3 if ticks == 10**30 else ticks
            mode = [*AdvanceMode][rng.integers(3)]
            rows = np.empty((8, ROW)) if mode is AdvanceMode.ROWS or kind == 3 else None
            controller = (lambda: 30.0) if kind == 4 else None
            try:
                done = session.advance(ticks, events=events, mode=mode, rows=rows,
                                       controller=controller)
            except AdvanceError as error:
                assert any(name in str(error) for name in ('ticks', 'events')), \
                    f'seed {seed}: {error}'
                assert session.plant.full_state.tobytes() == before, f'seed {seed}'
                continue
            except Exception as error:     # noqa: BLE001 - the finding this family looks for
                raise AssertionError(f'seed {seed}: {type(error).__name__}: {error}') from None
            assert done == ticks, f'seed {seed}'
            assert twin.advance(ticks, events=events, controller=controller) == done
            assert session.plant.full_state.tobytes() == twin.plant.full_state.tobytes(), \
                f'seed {seed}'
            assert session.rejected == twin.rejected, f'seed {seed}'


