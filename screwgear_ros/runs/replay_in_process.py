"""Replay a recorded run in-process through a :class:`~screwgear_ros.sim.session.Session`,
and the schedules that ``replay_run`` plays into a live node.

:func:`replay_in_process` drives a fresh session through a recording exactly as the
node ran it: every event recorded between two ``joint_states`` samples (in file order) is
submitted before the tick that produced the second sample, so it takes effect at
that tick's first step, as in the node. Each event's recorded step and each
sample's step are checked against the session's (a bag that disagrees is
'invalid'). With ``refine = 1`` this is the node's own computation again, bit for
bit; with ``refine = 2`` the same run at dt/2 (the Richardson estimate of RK4's
error that ``check_run`` judges by).

A :class:`~screwgear_ros.sim.schedule.Schedule` comes from a recording
(:func:`schedule_from_run`) or a scripted scenario (:func:`schedule_from_scenario`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import TypeVar

import numpy as np

from ..bag.errors import InvalidBag
from ..bag.reader import RecordedRun
from ..sim.events import Event, ParameterChange, describe
from ..sim.schedule import Schedule, ros_values
from ..sim.session import ROW, ROW_JOINTS, ROW_STEP, ROW_TE, AdvanceMode, Session, Tick, row_of

_E = TypeVar('_E', bound=Event)


def _refined(event: _E, refine: int) -> _E:
    """``event`` for a session at dt/refine: steps and the settings' dt scaled."""
    if isinstance(event, ParameterChange):
        event = replace(event, settings=replace(event.settings,
                                                dt=event.settings.dt / refine))
    return replace(event, step=None if event.step is None else event.step * refine)


@dataclass
class ReplayedOutputs:
    """Outputs at the bag's output samples: joint_states rows and transmission errors,
    and the ticks that went through :meth:`Session.tick` (every tick that applied an
    event, or in which command_timeout came due; ``ticks[j]`` made sample
    ``tick_samples[j]``). The ticks in between took no event: each ran under the input
    and parameters of the tick before it (:meth:`Session.advance` in ``AdvanceMode.ROWS``)."""

    joint_states: np.ndarray        # (n, 9) like RecordedRun.true_joint_states.values
    transmission_error: np.ndarray  # (m,) m
    fault: str | None
    ticks: list[Tick] = field(default_factory=list)
    tick_samples: list[int] = field(default_factory=list)


def replay_in_process(run: RecordedRun, refine: int = 1) -> ReplayedOutputs:
    """Re-run the recorded events through a fresh session at dt/refine, sampling the
    outputs of every tick (sample 0: the start of the run; sample i > 0: what tick i made).

    Every event recorded (in file order) before the ``joint_states`` sample i is
    submitted before the tick that makes it; the ticks between events go through
    :meth:`Session.advance` in ``AdvanceMode.ROWS``. Raises :class:`BagError` where the recording disagrees
    with the session (an event or a sample off the node's tick grid, a recorded command
    the node must have refused).
    """
    start = run.parameters
    samples = run.true_joint_states
    n = len(samples)
    rows = np.empty((n, ROW))
    m = len(run.transmission_error)
    if m and not np.array_equal(run.transmission_error.steps, samples.steps[:m]):
        raise InvalidBag('transmission_error and joint_states samples are not '
                       'published at the same steps')
    replayed = ReplayedOutputs(rows[:, ROW_JOINTS], rows[:m, ROW_TE], None)
    if not n:
        return replayed
    session = Session(start.params, _refined(ParameterChange(start.params, start.settings),
                                             refine).settings,
                      np.asarray(start.initial_state), start.start_step * refine)
    if samples.steps[0] != start.start_step:
        raise InvalidBag(f'the first joint_states is at step {samples.steps[0]}, '
                       f'the run starts at step {start.start_step}')
    rows[0] = row_of(session.last_outputs)
    events, k = run.events, 0
    # The sample whose tick takes each event: the first sample recorded after it.
    takes = np.searchsorted(samples.order, [order for order, _ in events], side='right')
    full: list[Tick | None] = []

    def stop(tick: Tick | None) -> bool:
        full.append(tick)
        return True

    i = 1
    while i < n:
        while k < len(events) and takes[k] <= i:
            event = _refined(events[k][1], refine)
            if event.step != session.step:
                raise InvalidBag(f'{describe(events[k][1])} is recorded at '
                                 f'step {events[k][1].step}, but the node applied what '
                                 f'arrived then at step {session.step // refine}')
            session.submit(event)
            k += 1
        # Up to the next sample that takes an event, the ticks between in compiled
        # calls; stops after a full tick (one that applied events, or in which
        # command_timeout came due), which check_run reads.
        full.clear()
        done = session.advance((int(takes[k]) if k < len(events) else n) - i,
                               mode=AdvanceMode.ROWS, rows=rows[i:], monitor=stop)
        tick = full[0] if full else None
        if tick is not None:
            if tick.rejected:
                raise InvalidBag(f'step {tick.start // refine}: a recorded command '
                               f'the node must have refused: {tick.rejected[0]}')
            replayed.ticks.append(tick)
            replayed.tick_samples.append(i + done - 1)
        made = rows[i:i + done, ROW_STEP].astype(np.int64)
        off = np.flatnonzero(samples.steps[i:i + done] * refine != made)
        if len(off):
            raise InvalidBag(f'joint_states sample {i + off[0]} is at step '
                           f'{samples.steps[i + off[0]]}, but the tick that produced it '
                           f'ends at step {made[off[0]] // refine}')
        i += done
    replayed.fault = session.plant.fault
    return replayed


def replayed_events(run: RecordedRun) -> list[tuple[float, Event]]:
    """The recorded (file position, event)s a replay plays: parameter changes that change
    nothing a replay sets (a real_time_factor change) are left out."""
    before = ros_values(run.parameters.params, run.parameters.settings)
    kept = []
    for order, event in run.events:
        if isinstance(event, ParameterChange):
            after = ros_values(event.params, event.settings)
            if after == before:
                continue
            before = after
        kept.append((order, event))
    return kept


def schedule_from_run(run: RecordedRun) -> Schedule:
    """The recorded events of a run (:func:`replayed_events`), to replay at their
    recorded steps."""
    start = run.parameters
    return Schedule(start.params, start.settings, [e for _, e in replayed_events(run)],
                    end_step=run.end_step)


__all__ = [
    'ReplayedOutputs',
    'replay_in_process',
    'replayed_events',
    'schedule_from_run',
]
