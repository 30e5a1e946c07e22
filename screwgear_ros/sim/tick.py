"""What one tick of a :class:`~screwgear_ros.sim.session.Session` did (:class:`Tick`),
the row of numbers a tick's outputs make where only they are kept (replays), and what
:meth:`Session.advance <screwgear_ros.sim.session.Session.advance>` makes of each tick
(:class:`AdvanceMode`)."""

from __future__ import annotations

import enum
import math
import operator
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..params.table import TableParams
from .commands import InputRejected
from .events import AdvanceError, Event, Timeline
from .plant import DriveInput, Outputs


class AdvanceMode(enum.Enum):
    """What :meth:`Session.advance <screwgear_ros.sim.session.Session.advance>` makes of
    each tick, and so what its monitor gets. Every mode leaves the same bits.

    Examples
    --------
    >>> AdvanceMode.TICKS.value
    'ticks'
    """

    #: Every tick a full :meth:`Session.tick`: the monitor gets each :class:`Tick`
    #: (a recording writes it, the energy audit reads its drive).
    TICKS = 'ticks'
    #: A tick that takes only the controller's answer runs without making its Tick
    #: (the monitor gets None for it: :attr:`Session.last_outputs`, :attr:`Session.measured`
    #: and the plant say what it did); other ticks are full ones.
    ANSWERS = 'answers'
    #: Ticks that take no event, and ask no controller, run many to a compiled call and
    #: make only their row of ``rows``; the monitor sees only the full ticks (those that
    #: applied an event or timed a command out). The sensors' chain does not follow the
    #: compiled ticks (:attr:`Session.measured` stays what it measured last).
    ROWS = 'rows'


#: Columns of an output row (:meth:`Session.advance` with ``rows``, replays; :func:`row_of`): the
#: joint_states row (θ, ω, effort of the three joints), the transmission error, the step.
ROW_JOINTS, ROW_TE, ROW_STEP = slice(0, 9), 9, 10
ROW = ROW_STEP + 1


def row_of(o: Outputs) -> tuple[float, ...]:
    """The ``ROW`` columns of ``o``."""
    return (*o.position, *o.velocity, *o.effort, o.transmission_error, o.step)


@dataclass(slots=True)
class Tick:
    """What one tick did. Read-only by convention, like :class:`~screwgear_ros.sim.plant.Outputs`
    and for the same reason not ``frozen``: one is made a tick."""

    start: int                          # step its events took effect at
    applied: tuple[Event, ...]          # those events, in order, ``step`` set
    rejected: tuple[InputRejected, ...]  # commands refused when they were to take effect
    notices: tuple[str, ...]            # inputs cut by a parameter change, for the log
    drive: DriveInput                   # input in force during the tick
    params: TableParams                 # parameters in force during the tick
    outputs: Outputs                    # at the tick's last step
    previous: Outputs                   # at its first step, before its events
    previous_direction: int             # commanded direction before the tick's events
    fault: str | None                   # why the plant stands still, if it does
    new_fault: bool                     # the model diverged during this tick
    measured: Outputs | None = None     # what the sensors measure of ``outputs`` (None:
    #                                     ``outputs`` itself, every sensor ideal)

    @property
    def start_ns(self) -> int:
        """Simulation time of ``start``, ns: the stamp of what took effect then."""
        return self.previous.time_ns

    @property
    def previous_path(self) -> int:
        """Active path before the tick's events."""
        return self.previous.active_path

    @property
    def reversal(self) -> bool:
        """The commanded direction changed at the tick's start."""
        return self.drive.direction != self.previous_direction

    @property
    def path_changed(self) -> bool:
        return self.outputs.active_path != self.previous_path


def advance_limits(step: int, steps: int, ticks: Any, until: Any, events: Any, mode: Any,
                   rows: Any) -> tuple[float, Timeline]:
    """The limit in ticks and the timeline of :meth:`Session.advance
    <screwgear_ros.sim.session.Session.advance>` by a session at ``step`` making
    ``steps`` steps a tick, every argument checked against its rule (AdvanceError
    naming it otherwise)."""
    if ticks is None and until is None:
        raise AdvanceError('advance needs ticks, until or both')
    if ticks is not None:
        ticks = _whole(ticks, 'ticks', 0, 'an integer >= 0')
    if until is not None:
        until = _whole(until, 'until', step,
                       f'a step, an integer >= the session\'s step ({step})')
    if not isinstance(mode, AdvanceMode):
        raise AdvanceError(f'mode must be an AdvanceMode (TICKS, ANSWERS, ROWS), got {mode!r:.60}')
    if rows is not None and not (isinstance(rows, np.ndarray) and rows.ndim == 2
                                 and rows.shape[1] >= ROW and rows.dtype == np.float64):
        raise AdvanceError(f'rows must be a float64 array of at least {ROW} columns')
    if mode is AdvanceMode.ROWS and rows is None:
        raise AdvanceError('AdvanceMode.ROWS makes only rows: it needs rows')
    if isinstance(events, Timeline):
        timeline = events
    else:
        timeline = Timeline(events)
        due = timeline.next_step
        if due is not None and due < step:
            raise AdvanceError(f'events[0] is at step {due}, before the session\'s step '
                               f'{step}: an event is never applied after its step')
    limit = math.inf if ticks is None else ticks
    if rows is not None:
        needed = limit if until is None else min(
            limit, -(-(until - step) // steps))
        if len(rows) < needed:
            raise AdvanceError(f'rows has {len(rows)} rows, fewer than the {needed} '
                               'ticks asked for')
    return limit, timeline


def step_of_time(time: Any, step: int, dt: float) -> int:
    """The first step whose time is not below ``time`` (s; a time on the step grid is
    that step), for a session at ``step``; AdvanceError unless ``time`` is a finite
    number not before the session's time."""
    try:
        valid = not isinstance(time, bool) and math.isfinite(time)
    except (TypeError, OverflowError):      # no number, an int beyond float64
        valid = False
    if not valid or time < step * dt:
        raise AdvanceError(f'time must be a finite simulation time, s, not before the '
                           f'session\'s ({step * dt:g} s), got {time!r:.60}')
    return math.ceil(round(time / dt, 6))


def _whole(value: Any, name: str, least: int, rule: str) -> int:
    """``value`` as an int (a NumPy integer too) that is >= ``least``; AdvanceError
    naming ``name`` and ``rule`` otherwise (a bool, a float, NaN, text ...)."""
    try:
        whole = None if isinstance(value, bool) else operator.index(value)
    except TypeError:
        whole = None
    if whole is None or whole < least:
        raise AdvanceError(f'{name} must be {rule}, got {value!r:.60}')
    return whole


__all__ = ['ROW', 'ROW_JOINTS', 'ROW_STEP', 'ROW_TE', 'AdvanceMode', 'Tick', 'advance_limits', 'row_of',
           'step_of_time']
