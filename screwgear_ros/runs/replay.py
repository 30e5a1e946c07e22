"""Replay a recorded run in-process, and the command schedule a live replay publishes.

:func:`timeline` merges a run's events and output samples in file order, which is
the order the node applied and published them. :func:`replay_in_process` feeds the
recorded inputs, parameter changes and resets to a fresh :class:`Plant` at their
recorded steps and collects its outputs where the bag has outputs: with
``refine = 1`` this is the node's own computation again (bit for bit), with
``refine = 2`` the same run at dt/2 (the Richardson estimate of RK4's error that
``check_run`` judges by). :func:`command_schedule` lists the input commands for
``replay_run`` to publish into a live node.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator

import numpy as np

from ..commands import InputRejected, apply_command
from ..plant import DriveInput, Outputs, Plant
from .bagread import BagError, Command, Event, ParameterChange, RecordedRun, Reset

#: Kinds of timeline items besides events.
JOINT_STATES = 'joint_states'
TRANSMISSION_ERROR = 'transmission_error'


def timeline(run: RecordedRun) -> Iterator[tuple[str, int, Event | None, int]]:
    """(kind, step, event or None, sample index) for every event and output sample,
    in file order. ``kind`` is 'event', 'joint_states' or 'transmission_error'."""
    orders = [np.array([o for o, _ in run.events], dtype=np.int64),
              run.joint_states.order, run.transmission_error.order]
    kinds = np.concatenate([np.full(len(o), k) for k, o in enumerate(orders)]).astype(np.int64)
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


@dataclass(frozen=True)
class ScheduledCommand:
    """An input command to publish when the node's simulation time reaches ``step``."""

    step: int
    topic: str       # relative input topic name
    value: object    # the message's data field


def command_schedule(run: RecordedRun) -> list[ScheduledCommand]:
    """The recorded input commands in the order applied (what replay_run publishes)."""
    return [ScheduledCommand(e.step, e.topic, e.value) for _, e in run.events
            if isinstance(e, Command)]


__all__ = ['timeline', 'apply_event', 'joint_values', 'ReplayedOutputs', 'replay_in_process',
           'ScheduledCommand', 'command_schedule', 'JOINT_STATES', 'TRANSMISSION_ERROR']
