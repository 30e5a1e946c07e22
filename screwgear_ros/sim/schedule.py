"""What a replay does to a session or a node, and when: start values, then session events
at their steps.

An event at step s is due once the node has published the outputs of a step >= s; it then
takes effect at the next tick's first step (:meth:`Schedule.due`). Recordings, scenarios,
the in-process recorder and the ROS replay client all speak it, so it sits in the core,
below each of them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from ..params.table import SimSettings, TableParams
from .events import Event, ParameterChange, Timeline

#: Settings a replay does not copy from the recording: where to record, and how the
#: node is paced (replay_run sets both itself).
NOT_REPLAYED = ('record', 'real_time_factor', 'lockstep')


def ros_values(params: TableParams, settings: SimSettings) -> dict[str, Any]:
    """Every node parameter a replay sets, by ROS name (``NOT_REPLAYED`` aside)."""
    values = {**params.as_dict(), **settings.as_dict()}
    return {k: v for k, v in values.items() if k not in NOT_REPLAYED}


def differences(live: dict[str, Any], start: dict[str, Any]) -> list[str]:
    """The values of a running node (``live``, by ROS name) that differ from a schedule's
    start values, as 'name = live (recorded start)'."""
    def plain(value: Any) -> Any:
        return list(value) if isinstance(value, (list, tuple)) else value
    return [f'{n} = {live.get(n)!r} (recorded {start[n]!r})' for n in sorted(start)
            if plain(live.get(n)) != plain(start[n])]


@dataclass
class Schedule:
    """What a replay does: start a node with ``params``/``settings``, then submit
    ``events`` (each with the step it is to take effect at), until step ``end_step``."""

    params: TableParams
    settings: SimSettings
    events: list[Event] = field(default_factory=list)
    end_step: int = 0
    _timeline: Timeline | None = field(default=None, repr=False, compare=False)

    @property
    def start(self) -> dict[str, Any]:
        """The start values by ROS name (``NOT_REPLAYED`` aside)."""
        return ros_values(self.params, self.settings)

    @property
    def dt(self) -> float:
        return self.settings.dt

    def due(self, step: int) -> list[Event]:
        """The events not yet taken whose step is <= ``step`` (the node has published
        the outputs of ``step``; they take effect at its next tick), in order."""
        if self._timeline is None:
            self._timeline = Timeline(self.events)
        return list(self._timeline.due(step))

    def changed_values(self, change: ParameterChange) -> dict[str, Any]:
        """The ROS parameters ``change`` sets, against the parameters in force before it."""
        before = self.start
        for event in self.events:
            if event is change:
                break
            if isinstance(event, ParameterChange):
                before = ros_values(event.params, event.settings)
        after = ros_values(change.params, change.settings)
        return {k: v for k, v in after.items() if before.get(k) != v}


__all__ = ['NOT_REPLAYED', 'Schedule', 'differences', 'ros_values']
