"""Replay a recorded run in-process, and the command schedule a live replay publishes.

:func:`timeline` merges a run's events and output samples in file order, which is
the order the node applied and published them. :func:`replay_in_process` feeds the
recorded inputs, parameter changes and resets to a fresh :class:`Plant` at their
recorded steps and collects its outputs where the bag has outputs: with
``refine = 1`` this is the node's own computation again (bit for bit), with
``refine = 2`` the same run at dt/2 (the Richardson estimate of RK4's error that
``check_run`` judges by). :func:`schedule_from_run` and :func:`load_scenario` list
what ``replay_run`` does to a live node, and when: publish an input command, set
parameters, call the reset service.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator

import numpy as np
import yaml

from ..commands import INPUT_TOPICS, InputRejected, apply_command
from ..params import (ParameterError, SimSettings, TableParams, default_values,
                      split_parameters)
from ..plant import DriveInput, Outputs, Plant
from .bagread import BagError, Command, Event, ParameterChange, RecordedRun, Reset

#: Kinds of timeline items besides events.
JOINT_STATES = 'joint_states'
TRANSMISSION_ERROR = 'transmission_error'


def timeline(run: RecordedRun) -> Iterator[tuple[str, int, Event | None, int]]:
    """(kind, step, event or None, sample index) for every event and output sample,
    in file order. ``kind`` is 'event', 'joint_states' or 'transmission_error'."""
    orders = [np.array([o for o, _ in run.events], dtype=np.float64),
              run.joint_states.order, run.transmission_error.order]
    kinds = np.concatenate([np.full(len(o), k) for k, o in enumerate(orders)]).astype(np.int64)
    # Event positions are floats so that a moved event can sit between two outputs.
    index = np.concatenate([np.arange(len(o)) for o in orders]).astype(np.int64)
    by_file = np.argsort(np.concatenate(orders), kind='stable')
    js_steps, te_steps = run.joint_states.steps, run.transmission_error.steps
    for j in by_file:
        k, i = int(kinds[j]), int(index[j])
        if k == 0:
            event = run.events[i][1]
            yield 'event', event.step, event, i
        elif k == 1:
            yield JOINT_STATES, int(js_steps[i]), None, i
        else:
            yield TRANSMISSION_ERROR, int(te_steps[i]), None, i


def apply_event(drive: DriveInput, event: Command, plant_params) -> DriveInput:
    """The input in force after a recorded command (the node's own validation)."""
    try:
        return apply_command(drive, event.topic, event.value, plant_params)
    except InputRejected as exc:
        raise BagError('invalid', f'step {event.step}: a recorded command the node '
                       f'must have refused: {exc}') from None


def joint_values(o: Outputs) -> np.ndarray:
    """θ(3) rad, ω(3) rad/s, effort(3) N·m, as the bag's joint_states rows."""
    return np.array([*o.position, *o.velocity, *o.effort])


@dataclass
class ReplayedOutputs:
    """Outputs at the bag's output samples: joint_states rows and transmission errors."""

    joint_states: np.ndarray        # (n, 9) like RecordedRun.joint_states.values
    transmission_error: np.ndarray  # (m,) m
    fault: str | None


def replay_in_process(run: RecordedRun, refine: int = 1) -> ReplayedOutputs:
    """Re-run the recorded inputs through :class:`Plant` at dt/refine."""
    start = run.parameters
    plant = Plant(start.params, run.dt / refine, np.asarray(start.initial_state))
    plant.step = start.start_step * refine
    js = np.empty((len(run.joint_states), 9))
    te = np.empty(len(run.transmission_error))
    cached: tuple[int, int] | None = None
    version = 0          # bumped by every event, so outputs are recomputed after one
    out: Outputs | None = None

    def advance_to(step: int) -> None:
        n = step * refine - plant.step
        if n < 0:
            raise BagError('invalid', f'step {step} comes after step {plant.step // refine} '
                           'in the file: time runs backwards')
        if n:
            plant.advance(n)   # after a fault the node, like the plant, stands still
    for kind, step, event, i in timeline(run):
        advance_to(step)
        if kind == 'event':
            version += 1
            if isinstance(event, Command):
                plant.set_input(apply_event(plant.input, event, plant.params))
            elif isinstance(event, ParameterChange):
                plant.set_params(event.parameters.params)
            elif isinstance(event, Reset):
                plant.reset()
            continue
        if cached != (plant.step, version):
            out = plant.outputs()
            cached = (plant.step, version)
        if kind == JOINT_STATES:
            js[i] = joint_values(out)
        else:
            te[i] = out.transmission_error
    return ReplayedOutputs(js, te, plant.fault)


#: Settings a replay does not copy from the recording: where to record, and the pace
#: (replay_run sets the pace itself).
NOT_REPLAYED = ('record', 'real_time_factor')


@dataclass(frozen=True)
class Action:
    """Something to do to the node when its simulation reaches ``step``.

    ``kind``: an input topic name (value = the message's data), 'parameters'
    (value = mapping of parameter name → new value) or 'reset' (value None).
    """

    step: int
    kind: str
    value: Any = None


@dataclass
class Schedule:
    """What replay_run does: start the node with ``start`` parameters, then ``actions``
    in order, until step ``end_step``."""

    start: dict[str, Any]          # every node parameter, ROS names (record excluded)
    actions: list[Action] = field(default_factory=list)
    end_step: int = 0

    @property
    def dt(self) -> float:
        return float(self.start['dt'])

    @property
    def ticks(self) -> int:
        """Integration steps per publish tick."""
        return int(round(1.0 / (float(self.start['publish_rate']) * self.dt)))


def _values(params: TableParams, settings: SimSettings) -> dict[str, Any]:
    """Every node parameter a replay sets, by ROS name (``NOT_REPLAYED`` aside)."""
    values = {**params.as_dict(), **settings.as_dict()}
    return {k: v for k, v in values.items() if k not in NOT_REPLAYED}


def schedule_from_run(run: RecordedRun) -> Schedule:
    """The recorded events of a run as replay actions: every input command as applied,
    every changed parameter (``NOT_REPLAYED`` aside) and every reset."""
    previous = _values(run.parameters.params, run.parameters.settings)
    schedule = Schedule(dict(previous), end_step=run.end_step)
    for _, event in run.events:
        if isinstance(event, Command):
            schedule.actions.append(Action(event.step, event.topic, event.value))
        elif isinstance(event, ParameterChange):
            values = _values(event.parameters.params, event.parameters.settings)
            changed = {k: v for k, v in values.items() if previous.get(k) != v}
            previous = values
            if changed:
                schedule.actions.append(Action(event.step, 'parameters', changed))
        elif isinstance(event, Reset):
            schedule.actions.append(Action(event.step, 'reset'))
    return schedule


def load_scenario(path: str | Path) -> Schedule:
    """A scripted run (the test bags are recorded from these), YAML::

        parameters: {table_damping: 8867.0, publish_rate: 200.0}   # node start values
        duration: 4.0                                               # s of simulation
        actions:                                                    # at simulation times, s
          - {time: 0.2, cmd_torque: 400.0}
          - {time: 1.5, parameters: {mesh_damping: 1000.0}}
          - {time: 2.0, reset: true}
    """
    document = yaml.safe_load(Path(path).read_text(encoding='utf-8')) or {}
    overrides = dict(document.get('parameters') or {})
    try:
        params, settings = split_parameters({**default_values(), **overrides})
    except ParameterError as exc:
        raise ValueError(f'{path}: {exc}') from None
    dt = settings.dt
    schedule = Schedule(_values(params, settings),
                        end_step=int(round(float(document['duration']) / dt)))
    for entry in document.get('actions') or []:
        entry = dict(entry)
        step = int(round(float(entry.pop('time')) / dt))
        if len(entry) != 1:
            raise ValueError(f'{path}: each action has a time and one of '
                             f'{", ".join(INPUT_TOPICS)}, parameters, reset: {entry}')
        kind, value = entry.popitem()
        if kind == 'reset':
            value = None
        elif kind not in INPUT_TOPICS and kind != 'parameters':
            raise ValueError(f'{path}: unknown action {kind!r}')
        schedule.actions.append(Action(step, kind, value))
    schedule.actions.sort(key=lambda a: a.step)
    return schedule


__all__ = ['timeline', 'apply_event', 'joint_values', 'ReplayedOutputs', 'replay_in_process',
           'Action', 'Schedule', 'schedule_from_run', 'load_scenario', 'NOT_REPLAYED',
           'JOINT_STATES', 'TRANSMISSION_ERROR']
