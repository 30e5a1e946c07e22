"""What can happen to a running table besides integration: the session's typed events.

A :class:`~screwgear_ros.sim.session.Session` queues these and applies them, in order,
at the first integration step of its next tick. ``step`` is None while an event
waits in the queue and is the step it took effect at once applied; a recording
stores them with that step and a replay submits them again. One declaration
serves the node, the recorder, the bag reader, replay and check.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..params.table import SimSettings, TableParams


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


def describe(event: Event) -> str:
    """A short human description: 'cmd_torque 150.0', 'parameter change', 'reset'."""
    if isinstance(event, Command):
        return f'{event.topic} {event.value}'
    if isinstance(event, ParameterChange):
        return 'parameter change'
    if isinstance(event, Setpoint):
        return f'setpoint {event.value}'
    return 'reset'


__all__ = ['Command', 'Event', 'ParameterChange', 'Reset', 'Setpoint', 'describe']
