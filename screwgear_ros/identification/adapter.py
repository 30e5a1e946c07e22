"""The one place identification touches the package's simulation, parameter and bag
code (the message codec and the node's reading of a command's message are re-exported
here for :mod:`~screwgear_ros.identification.recording`).

:func:`simulate` re-runs a recording's commands through the node's own
:class:`~screwgear_ros.sim.session.Session` (the project's one simulation loop) with
:meth:`~screwgear_ros.sim.session.Session.advance`: each recorded command is an event at
the first step of its tick, and the ticks between commands run in compiled calls. What joint_states would publish is then
made by the node's own :class:`~screwgear_ros.physics.sensors.SensorChain` with the
base file's measurement delay and speed filter, but without noise or encoder counts:
the fit compares a smooth prediction with the noisy measurement (quantisation would
make the cost a staircase that finite differences cannot see into).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from ..bag.format import typestore
from ..errors import ScrewgearError
from ..inprocess.simulation import ParameterFileError, file_values, resolve
from ..params.declarations import Declaration, Kind, declared
from ..params.table import ParameterError, SimSettings, TableParams
from ..physics.sensors import JOINTS as SENSOR_JOINTS
from ..physics.sensors import SensorChain, SensorConfig
from ..sim.commands import InputRejected, carries_no_command, command_value
from ..sim.events import Command
from ..sim.session import ROW, AdvanceMode, Session, Tick
from .errors import FitParameterError
from .samples import Recording


class Diverged(ScrewgearError, ArithmeticError):
    """The model cannot be run or diverged at a trial point (a large residual, never
    seen outside the fit)."""


class CommandRefused(Diverged):
    """The node refuses a recorded command with a trial point's parameters (a large
    residual; at the base values, a recording the fit cannot use)."""


def base_values(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The parameters a ROS 2 parameter file sets (validated as the node validates them).

    Raises
    ------
    FitParameterError
        The file cannot be read, or the node would refuse a value in it.
    """
    try:
        values = file_values(path)
        resolve(values)
    except (ParameterFileError, ParameterError) as exc:
        raise FitParameterError(f'--params {path}: {exc}') from None
    return values


def declarations() -> dict[str, tuple[Kind, Declaration, Any]]:
    """Every physical parameter (TableParams) with its kind, declaration, default."""
    return {p.name: (p.kind, p.declaration, p.default) for p in declared(TableParams)}


def settings_names() -> set[str]:
    return {p.name for p in declared(SimSettings)}


def model(values: Mapping[str, Any]) -> tuple[TableParams, SimSettings]:
    """The validated model of ``values`` over the node's defaults (:class:`Diverged`
    where the node refuses them: a trial point the model cannot run)."""
    try:
        return resolve(values)
    except (ParameterError, ValueError, ArithmeticError) as exc:
        raise Diverged(str(exc)) from None


def tick_period(values: Mapping[str, Any]) -> float:
    _, settings = resolve(values)
    return settings.steps_per_publish * settings.dt


#: Counts per revolution of the encoders that predict a counting drive's speed: the most
#: the node takes, so fine that their quantisation is far below any encoder's noise.
FINE_COUNTS = 1 << 30


def _prediction_sensors(settings: SimSettings, speeds: bool) -> SensorConfig:
    """The base file's sensors without noise: delay and speed filter. For angles without
    counts either; for speeds, where a joint counts, with :data:`FINE_COUNTS`, so the
    speed is a backward difference over the tick as the drive computes it."""
    config = settings.sensors
    joints = tuple(replace(j, counts=FINE_COUNTS if speeds and j.counts else 0,
                           position_noise=0.0, velocity_noise=0.0) for j in config.joints)
    return SensorConfig(joints, config.seed)  # type: ignore[arg-type]


def simulate(values: Mapping[str, Any], recording: Recording, speeds: bool = False,
             reversals: list[int] | None = None) -> np.ndarray:
    """(n, 6) θ and ω of the three joints as joint_states would publish them, at the
    recording's samples, for the model of ``values``, from the preload equilibrium
    (``speeds``: ω as counting encoders measure it, else the exact ω, delayed and
    filtered as the angles); ``reversals``, if given, gets the number of reversals of the
    drive direction the node applied (an effort inside ``effort_deadband`` is none).

    Raises
    ------
    Diverged
        The node refuses ``values``, or the model diverged.
    CommandRefused
        A recorded command the node refuses (with these parameters).
    """
    params, settings = model(values)
    n = recording.samples
    rows = np.empty((n, ROW))
    session = Session(params, settings)
    first = session.last_outputs
    rows[0, :6] = (*first.position, *first.velocity)
    per_tick = settings.steps_per_publish
    # the command recorded for sample i takes effect at the first step of tick i
    events = [Command(str(topic), value, step=(i - 1) * per_tick)
              for i, topic, value in recording.inputs]
    refused: list[tuple[int, InputRejected]] = []
    turns = [0]

    def monitor(tick: Tick | None) -> bool:
        if tick is not None and tick.rejected:
            refused.append((tick.start // per_tick + 1, tick.rejected[0]))
            return True
        if tick is not None and tick.reversal:
            turns[0] += 1
        return session.plant.fault is not None

    try:
        session.advance(n - 1, events=events, mode=AdvanceMode.ROWS, rows=rows[1:],
                        monitor=monitor)
    except ArithmeticError:
        # a command's tick after a fault inside a compiled run of quiet ticks measures a
        # plant whose time stood still (a speed over zero time): the model diverged
        if session.plant.fault is None:
            raise
        raise Diverged(session.plant.fault) from None
    if reversals is not None:
        reversals.append(turns[0])
    if refused:
        i, error = refused[0]
        raise CommandRefused(f'{recording.path}: tick {i}: the node refuses a recorded '
                             f'command: {error}')
    if session.plant.fault is not None:
        raise Diverged(session.plant.fault)
    exact = rows[:, :6]
    out = exact.copy()
    steps = (settings.steps_per_publish * np.arange(n)).tolist()
    angles = SensorChain(_prediction_sensors(settings, False), settings.dt)
    if not angles.ideal:
        for j, step in enumerate(steps):
            out[j, :3], out[j, 3:] = angles.measure_values(step, exact[j, :3].tolist(),
                                                           exact[j, 3:].tolist())
    counting = _prediction_sensors(settings, True)
    if speeds and any(joint.counts for joint in counting.joints):
        chain = SensorChain(counting, settings.dt)
        for j, step in enumerate(steps):
            out[j, 3:] = chain.measure_values(step, exact[j, :3].tolist(),
                                              exact[j, 3:].tolist())[1]
    if not np.isfinite(out).all():
        raise Diverged('the simulated joint states are not finite')
    return np.array(out)


__all__ = [
    'SENSOR_JOINTS',
    'CommandRefused',
    'Diverged',
    'base_values',
    'carries_no_command',
    'command_value',
    'declarations',
    'model',
    'settings_names',
    'simulate',
    'tick_period',
    'typestore',
]
