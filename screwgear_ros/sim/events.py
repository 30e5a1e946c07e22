"""What can happen to a running table besides integration: the session's typed events.

A :class:`~screwgear_ros.sim.session.Session` queues these and applies them, in order,
at the first integration step of its next tick. ``step`` is None while an event
waits in the queue and is the step it took effect at once applied; a recording
stores them with that step and a replay submits them again. One declaration
serves the node, the recorder, the bag reader, replay and check.
"""

from __future__ import annotations

import operator
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from ..errors import ScrewgearError
from ..interface import COMMAND_TOPICS
from ..params.table import SimSettings, TableParams


class AdvanceError(ScrewgearError, TypeError, ValueError):
    """An argument of :meth:`Session.advance <screwgear_ros.sim.session.Session.advance>`,
    or an event of its timeline, that breaks its rule; the message names both. A
    ``TypeError`` and a ``ValueError``: a wrong type and a wrong value are both refused
    with it."""


@dataclass(frozen=True)
class Command:
    """A controller command: relative input topic and the value its message carries
    (:func:`screwgear_ros.sim.commands.command_value`: the ``data`` field, a list for
    ``cmd_effort``, a ``JointCommand`` for ``joint_commands``)."""

    topic: str
    value: Any
    step: int | None = None

    @classmethod
    def of(cls, topic: str, value: Any) -> Command:
        """``Command(topic, value)``, made without the frozen dataclass's
        ``object.__setattr__`` per field: a closed loop submits one a tick."""
        command = object.__new__(cls)
        command.__dict__.update(topic=topic, value=value, step=None)
        return command

    def at(self, step: int) -> Command:
        """This command, taking effect at ``step``."""
        return _stamped(self, step)


@dataclass(frozen=True)
class ParameterChange:
    """A complete, validated parameter set in force from the step it takes effect at."""

    params: TableParams
    settings: SimSettings
    step: int | None = None

    def at(self, step: int) -> ParameterChange:
        return _stamped(self, step)


@dataclass(frozen=True)
class Setpoint:
    """The controller's target for the table joint, rad (the ``setpoint`` topic): only
    recorded, at the step it would have taken effect at, so that a plot can show the
    tracking error. It changes neither the plant nor the input in force, is no command
    (``command_timeout`` does not count it) and is not replayed."""

    value: float
    step: int | None = None

    def at(self, step: int) -> Setpoint:
        return _stamped(self, step)


@dataclass(frozen=True)
class Reset:
    """Back to the preload equilibrium at rest; simulation time keeps running."""

    step: int | None = None

    def at(self, step: int) -> Reset:
        return _stamped(self, step)


Event = Command | ParameterChange | Reset | Setpoint


def _stamped(event: Any, step: int) -> Any:
    """A copy of ``event`` (an event above) with ``step`` set: ``dataclasses.replace``
    without its field walk and the frozen dataclass's ``object.__setattr__`` per field:
    the session stamps every event it applies, and a closed loop sends one a tick."""
    stamped = object.__new__(type(event))
    stamped.__dict__.update(event.__dict__, step=step)
    return stamped


class Timeline:
    """Events at integer steps, handed out once each as their step comes.

    An event at step s is due once the outputs of a step >= s are out: it takes effect
    at the next tick's first step. The one place that rule is written; sessions
    (:meth:`~screwgear_ros.sim.session.Session.advance`), schedules and replay plans
    read their events through it.

    Parameters
    ----------
    events : sequence of Event
        Each with its ``step`` set (an integer >= 0), in increasing step order (ties
        keep their order).
    name : str
        What the caller calls ``events``, for the messages.

    Raises
    ------
    AdvanceError
        An element that is no event, an event without its step or with a step that is
        no integer >= 0, or an event before the one ahead of it: a timeline is in step
        order, and an event is never applied later than its step.

    Examples
    --------
    >>> t = Timeline([Reset(step=0), Reset(step=10)])
    >>> len(t.due(5)), len(t.due(5)), t.next_step, len(t.due(10))
    (1, 0, 10, 1)
    """

    __slots__ = ('_events', '_next')

    def __init__(self, events: Sequence[Event], name: str = 'events') -> None:
        if not isinstance(events, Sequence) or isinstance(events, (str, bytes)):
            raise AdvanceError(f'{name} must be a sequence of session events, got '
                               f'a {type(events).__name__}')
        previous = None
        for i, event in enumerate(events):
            step = step_of(event, f'{name}[{i}]')
            if previous is not None and step < previous:
                raise AdvanceError(
                    f'{name}[{i}] ({describe(event):.60}) is at step {step}, before step '
                    f'{previous} of the event ahead of it: {name} must be in step order')
            previous = step
        self._events = events
        self._next = 0

    @property
    def next_step(self) -> int | None:
        """The step of the first event not yet handed out (None: none left)."""
        k = self._next
        return self._events[k].step if k < len(self._events) else None

    def due(self, step: int) -> Sequence[Event]:
        """The events not yet handed out whose step is <= ``step``, in order; call
        with steps that do not decrease."""
        first = k = self._next
        events = self._events
        while k < len(events) and events[k].step <= step:   # type: ignore[operator]
            k += 1
        self._next = k
        return events[first:k]


def step_of(event: Any, name: str) -> int:
    """The step of ``event``, an integer >= 0; AdvanceError naming ``name`` otherwise
    (an element that is no event, an event without its step).

    Examples
    --------
    >>> step_of(Reset(step=3), 'events[0]')
    3
    """
    if not isinstance(event, (Command, ParameterChange, Reset, Setpoint)):
        raise AdvanceError(f'{name} must be a session event (Command, ParameterChange, '
                           f'Reset, Setpoint), got a {type(event).__name__}')
    if isinstance(event, Command) and not any(event.topic == topic for topic in COMMAND_TOPICS):
        raise AdvanceError(f'{name}: a command\'s topic must be one of '
                           f'{", ".join(COMMAND_TOPICS)}, got {shown(event.topic)}')
    step = event.step
    if step is None:
        raise AdvanceError(f'{name} ({describe(event):.60}) needs the step it takes effect at')
    try:
        index = -1 if isinstance(step, bool) else operator.index(step)
    except TypeError:
        index = -1
    if index < 0:
        raise AdvanceError(f'{name} ({describe(event):.60}): its step must be an integer '
                           f'>= 0, got {shown(step)}')
    return index


def shown(value: Any, width: int = 60) -> str:
    """``repr(value)`` for a message, cut to ``width`` characters; an int past the
    interpreter's digit limit (which ``repr`` refuses) by its size.

    Examples
    --------
    >>> shown(10**5000)
    'an int of 16610 bits'
    """
    try:
        text = repr(value)
    except ValueError:                 # an int past the interpreter's digit limit
        return (f'an int of {value.bit_length()} bits' if isinstance(value, int)
                else f'a {type(value).__name__} holding an int of over 4300 digits')
    return text if len(text) <= width else f'{text[:width - 3]}...'


def describe(event: Event) -> str:
    """A short human description: 'cmd_torque 150.0', 'parameter change', 'reset'."""
    if isinstance(event, Command):
        value = event.value
        return f'{event.topic} {value if isinstance(value, float) else shown(value)}'
    if isinstance(event, ParameterChange):
        return 'parameter change'
    if isinstance(event, Setpoint):
        value = event.value
        return f'setpoint {value if isinstance(value, float) else shown(value)}'
    return 'reset'


__all__ = ['AdvanceError', 'Command', 'Event', 'ParameterChange', 'Reset', 'Setpoint', 'Timeline', 'describe',
           'shown', 'step_of']
