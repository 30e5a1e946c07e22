"""Which events a lockstep replay sends before each of its answers (no ROS here).

In lockstep the node integrates a tick only once it is answered, and applies everything
it received meanwhile, in arrival order, at that tick's first step. Tick i (i >= 1) is
the one that makes output sample i (sample 0: the start of the run). A replay that waits
for sample i - 1, sends tick i's events one after the other (each taken by the node
before the next), then answers, makes the node apply exactly those events at exactly
that tick, however many there are and whatever their topics.

Ticks are counted, not told apart by their stamps: after a diverged model the node's
time stands still and its ticks share one stamp, yet each still applies what it
received. A recording says which tick applied an event by its place in the file: the
recorder writes a tick's events before its outputs (:func:`plan_from_run`). A scenario
says it by simulation time: an event at step s is applied by the tick after the first
sample at a step >= s (:func:`plan_from_schedule`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..bag.reader import RecordedRun
from ..sim.events import Command, Event, ParameterChange, Timeline
from ..sim.schedule import Schedule
from .replay_in_process import replayed_events


@dataclass
class LockstepPlan:
    """``events``: (tick that applies it, event) in the order to send them; ``ticks``:
    how many ticks the replay answers (the run's samples after the first)."""

    events: list[tuple[int, Event]] = field(default_factory=list)
    ticks: int = 0
    _next: int = 0

    def due(self, tick: int) -> list[Event]:
        """The events tick ``tick`` applies (to send before answering sample tick - 1);
        call with increasing ticks."""
        first = self._next
        while self._next < len(self.events) and self.events[self._next][0] <= tick:
            self._next += 1
        return [event for _, event in self.events[first:self._next]]

    @property
    def sent(self) -> int:
        """Events handed out by :meth:`due` so far."""
        return self._next


def plan_from_run(run: RecordedRun) -> LockstepPlan:
    """The replayed events of ``run`` (:func:`~screwgear_ros.runs.replay_in_process.replayed_events`)
    with the tick that applied each. Raises ValueError where a lockstep replay cannot
    reproduce the run: a recording that lost ticks (a real-time recorder whose queue was
    full drops whole ticks), which leaves no way to count them."""
    samples = run.true_joint_states
    kept = replayed_events(run)
    if len(samples) == 0:
        return LockstepPlan([], 0)
    ticks = np.searchsorted(samples.order, [order for order, _ in kept], side='right')
    plan = LockstepPlan([(int(t), e) for t, (_, e) in zip(ticks, kept, strict=False)], len(samples) - 1)
    problem = lost_tick(run, plan)
    if problem is not None:
        raise ValueError(f'a lockstep replay cannot reproduce this run: {problem}')
    return plan


def lost_tick(run: RecordedRun, plan: LockstepPlan) -> str | None:
    """Where consecutive joint_states samples are neither one tick apart nor at one step
    (a faulted plant's time stands still), or None."""
    steps = run.true_joint_states.steps
    if len(steps) < 2:
        return None
    per_tick = np.full(len(steps) - 1, run.parameters.settings.steps_per_publish,
                       dtype=np.int64)
    for tick, event in plan.events:
        if isinstance(event, ParameterChange) and tick >= 1:
            per_tick[tick - 1:] = event.settings.steps_per_publish
    gaps = np.diff(steps)
    bad = np.flatnonzero((gaps != per_tick) & (gaps != 0))
    if not len(bad):
        return None
    i = int(bad[0])
    return (f'joint_states sample {i + 1} is at step {steps[i + 1]}, {gaps[i]} steps after '
            f'the one before, but a tick of this run is {per_tick[i]} steps: the recording '
            'lost ticks (in real time a full recorder queue drops whole ticks), so their '
            'events cannot be placed')


def plan_from_schedule(schedule: Schedule) -> LockstepPlan:
    """The events of a scripted ``schedule`` with the tick that applies each, walking the
    tick grid from step 0 (a parameter change of ``publish_rate`` changes the length of
    the ticks from the one that applies it), until a sample at ``end_step`` or later."""
    per_tick = schedule.settings.steps_per_publish
    events: list[tuple[int, Event]] = []
    timeline, step, tick = Timeline(schedule.events), 0, 0
    while step < schedule.end_step:
        tick += 1
        for event in timeline.due(step):
            events.append((tick, event))
            if isinstance(event, ParameterChange):
                per_tick = event.settings.steps_per_publish
        step += per_tick
    return LockstepPlan(events, tick)


def sending_order(group: list[Event]) -> list[tuple[Event, bool]]:
    """``group`` with, for each event, whether the node must confirm it has taken it before
    the next event is sent (or the tick is answered): every command, unless a parameter
    change or reset follows, whose service reply confirms it. One confirmation is asked
    per message: an executor that takes one message per subscription per wait (rclpy's
    SingleThreadedExecutor) serves a ready service in the same wait, and the node's own
    (the events executor) serves in arrival order."""
    return [(event, isinstance(event, Command)
             and (k + 1 == len(group) or isinstance(group[k + 1], Command)))
            for k, event in enumerate(group)]


__all__ = [
    'LockstepPlan',
    'lost_tick',
    'plan_from_run',
    'plan_from_schedule',
    'sending_order',
]
