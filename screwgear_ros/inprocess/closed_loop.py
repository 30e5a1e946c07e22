"""The closed loop of :meth:`Simulation.run <screwgear_ros.inprocess.simulation.Simulation.run>`
over :meth:`Session.advance <screwgear_ros.sim.session.Session.advance>`: the controller
answers each tick's observation, every sample lands in the run's arrays."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from ..interface import Input
from ..sim.commands import InputRejected
from ..sim.control import SetpointNotes
from ..sim.events import AdvanceError, Event, ParameterChange, Setpoint, shown
from ..sim.session import AdvanceMode, Session, Tick
from ..sim.simtime import sim_time_ns
from .samples import Observation

Controller = Callable[[Observation], 'float | None']


def closed_loop(session: Session, controller: Controller | None, first: Observation, ticks: int,
          observed: np.ndarray, command: list[Any],
          columns: tuple[list[int], list[int], list[int]], events: Sequence[Event],
          recording: Any, rejected: list[tuple[int, str]],
          measured: np.ndarray | None = None,
          setpoint: Callable[[float], float] | None = None) -> None:
    """The closed loop of :meth:`Simulation.run`: every sample's observed vector into
    ``observed``, its step, path and direction appended to ``columns``, the answers
    into ``command`` (each tick's outputs kept as one array copy: no object per tick
    outlives the tick), the ``setpoint`` submitted before them when due; ``measured``:
    the joint_states θ and ω of each sample, when the sensors are not ideal."""
    plant = session.plant
    record = recording.tick if recording is not None else None
    steps, paths, directions = columns
    vector = plant.observed
    observed[0] = vector
    if measured is not None:
        measured[0] = (*first.position, *first.velocity)
    steps.append(first.step)
    paths.append(first.active_path)
    directions.append(plant.input.direction)
    observation = first
    notes, dt = SetpointNotes(), session.settings.dt
    plant_dt, ideal = plant.dt, session.sensors.ideal
    i = 1
    effort: Any = None

    def answer() -> Any:
        """Before tick i: the setpoint when due, then the controller's answer."""
        nonlocal effort
        if setpoint is not None:
            # t as the controllers take it: from the integer ns stamp of the sample
            stamp = sim_time_ns(observation.step, dt)
            target = _target(setpoint(stamp * 1e-9), stamp)
            if notes.due(stamp, target):
                session.submit(Setpoint(target))
        effort = None if controller is None else controller(observation)
        if effort is not None:
            if type(effort) is not float:
                effort = _plain(effort)
            command[i - 1] = effort
        return effort

    def observe(tick: Tick | None) -> None:
        """After tick i: its sample, and the observation the controller gets next."""
        nonlocal observation, ideal, i
        if tick is not None:
            if record is not None:
                record(tick)
            if tick.rejected:
                _refused(tick, effort, rejected)
            ideal = session.sensors.ideal       # a parameter change may have changed them
        # The observation from the observed vector itself (its columns above), rather
        # than through the session's Outputs, which the fast tick does not make.
        th1, th2, th3, w1, w2, w3, e1, e2, e3, d1, r1, f1, d3, r3, f3 = vector.tolist()
        step, path = plant.step, plant.active_path
        position, velocity = (th1, th2, th3), (w1, w2, w3)
        if ideal:
            shown_position, shown_velocity = position, velocity
        else:
            m = session.measured
            shown_position, shown_velocity = m.position, m.velocity
        if measured is not None:
            measured[i] = (*shown_position, *shown_velocity)
        observation = Observation(step * plant_dt, step, shown_position, shown_velocity,
                                  (e1, e2, e3), d1 if path == 1 else d3, (d1, d3),
                                  (r1, r3), (f1, f3), path, plant.fault, position, velocity)
        observed[i] = vector
        steps.append(step)
        paths.append(path)
        directions.append(plant.direction)
        i += 1

    def change(event: ParameterChange) -> None:
        recording.submit_change(replace(event, step=None))

    session.advance(ticks, events=events, controller=answer, monitor=observe,
                    mode=AdvanceMode.ANSWERS if recording is None else AdvanceMode.TICKS,
                    changes=change if recording is not None else None)


def _target(value: Any, stamp: int) -> float:
    """What ``setpoint(t)`` returned at ``stamp`` (ns) as a float; an answer that is no
    real number is refused by name (a NaN is the session's to refuse and count)."""
    if isinstance(value, np.generic):
        value = value.item()
    try:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise TypeError
        return float(value)
    except (TypeError, OverflowError):     # no number, an int beyond float64
        raise AdvanceError(f'setpoint(t) must return an angle, rad, a real number that '
                           f'float64 holds; at t = {stamp * 1e-9:g} s it returned '
                           f'{shown(value)}') from None


def _plain(effort: Any) -> Any:
    """A controller's answer as the session judges it: a NumPy scalar as its Python
    value; an int beyond float64 refused here, as no cmd_effort message carries it."""
    if isinstance(effort, np.generic):
        effort = effort.item()
    if isinstance(effort, int) and not isinstance(effort, bool):
        try:
            float(effort)
        except OverflowError:
            raise InputRejected(Input.CMD_EFFORT, f'an int of {effort.bit_length()} bits',
                                'beyond float64: no message can carry it') from None
    return effort


def _refused(tick: Tick, effort: Any, rejected: list[tuple[int, str]]) -> None:
    """Refusals of a tick: the controller's answer ``effort`` (None: it gave none)
    raises (the session validated it as the node does; the tick ran with the last valid
    command, as in the node), a scheduled command's is kept in ``rejected``."""
    for error in tick.rejected:
        if effort is not None and error.topic == Input.CMD_EFFORT and error.value == [effort]:
            raise error
        rejected.append((tick.start, str(error)))


__all__ = ['Controller', 'closed_loop']
