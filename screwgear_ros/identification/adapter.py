"""The one place identification touches the package's simulation, parameter and bag
code (the message codec and the node's reading of a command's message are re-exported
here for :mod:`~screwgear_ros.identification.recording`).

:func:`simulate` re-runs a recording's commands through the node's own
:class:`~screwgear_ros.sim.session.Session` (the project's one simulation loop) with
:meth:`~screwgear_ros.sim.session.Session.advance`: each recorded command is an event at
the first integration step at or after its time (the session ticks once per step), and
the steps between commands run in compiled calls. What joint_states would publish at
each sample's own time is then made from the exact states with the base file's
measurement delay and speed filter (the speeds through the node's own
:class:`~screwgear_ros.physics.sensors.SensorChain`), but without noise or encoder counts:
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


def mesh_hz(values: Mapping[str, Any]) -> float:
    """The highest mesh mode of the linear model of ``values`` (its oscillating modes
    other than the rigid body's), Hz (NaN where it cannot be linearized). Bearing friction
    is left out: stuck at rest, its switch would read as a huge damping that hides the
    mesh mode (design.friction_state), and it does not move the mode's frequency."""
    from ..design.friction_state import without_friction
    from ..design.linearize import linearize
    try:
        modes = linearize(without_friction(model(values)[0])).modes()
    except (ScrewgearError, ArithmeticError, ValueError):
        return float('nan')
    found = [m.hz for m in modes if m.oscillating and not m.shape.startswith('rigid')]
    return max(found) if found else float('nan')


def simulate(values: Mapping[str, Any], recording: Recording, speeds: bool = False,
             reversals: list[int] | None = None) -> np.ndarray:
    """(n, 6) θ and ω of the three joints as joint_states would publish them, at each of
    the recording's samples' own times, for the model of ``values``, from the preload
    equilibrium at the recording's start (``speeds``: ω as counting encoders measure it,
    else the exact ω, delayed and filtered as the angles); ``reversals``, if given, gets
    the number of reversals of the drive direction the node applied (an effort inside
    ``effort_deadband`` is none).

    The session ticks once per integration step, so each recorded command is applied
    from the first step at or after its time (a zero-order hold on the step grid). The
    angle a joint publishes is its exact angle one measurement delay earlier (the
    prediction's sensors have no noise and no counts), interpolated linearly between
    steps (50 µs apart: far finer than any encoder's rate); the speeds are made by the
    node's own sensor chain at the base file's ticks, then interpolated likewise.

    Raises
    ------
    Diverged
        The node refuses ``values``, or the model diverged.
    CommandRefused
        A recorded command the node refuses (with these parameters).
    """
    params, settings = model(values)
    dt = settings.dt
    per_tick = settings.steps_per_publish
    fine = replace(settings, publish_rate=1.0 / dt)
    origin = recording.origin
    at = (np.asarray(recording.times, dtype=np.int64) - origin) * 1e-9 / dt   # in steps
    # a sample on a step (the node's own) is that step's state exactly, not a blend
    # with the next step's by the roundoff of ns → steps
    near = np.rint(at)
    at = np.where(np.abs(at - near) < 1e-6, near, at)
    steps = int(np.ceil(at[-1])) + 1
    rows = np.empty((steps + 1, ROW))
    session = Session(params, fine)
    first = session.last_outputs
    rows[0, :6] = (*first.position, *first.velocity)
    events = [Command(str(topic), value, step=max(0, int(np.ceil((t - origin) * 1e-9 / dt
                                                                  - 1e-6))))
              for t, topic, value in recording.inputs]
    refused: list[tuple[int, InputRejected]] = []
    turns = [0]

    def monitor(tick: Tick | None) -> bool:
        if tick is not None and tick.rejected:
            refused.append((tick.start, tick.rejected[0]))
            return True
        if tick is not None and tick.reversal:
            turns[0] += 1
        return session.plant.fault is not None

    try:
        session.advance(steps, events=events, mode=AdvanceMode.ROWS, rows=rows[1:],
                        monitor=monitor)
    except ArithmeticError:
        # a command's step after a fault inside a compiled run of quiet steps measures a
        # plant whose time stood still (a speed over zero time): the model diverged
        if session.plant.fault is None:
            raise
        raise Diverged(session.plant.fault) from None
    if reversals is not None:
        reversals.append(turns[0])
    if refused:
        step, error = refused[0]
        raise CommandRefused(f'{recording.path}: at {step * dt:.6g} s: the node refuses a '
                             f'recorded command: {error}')
    if session.plant.fault is not None:
        raise Diverged(session.plant.fault)
    exact = rows[:, :6]
    if not np.isfinite(exact).all():
        raise Diverged('the simulated joint states are not finite')
    grid = np.arange(steps + 1, dtype=np.float64)
    out = np.empty((len(at), 6))
    sensors = settings.sensors.joints
    for j in range(3):
        delay = sensors[j].delay * per_tick
        out[:, j] = np.interp(at - delay, grid, exact[:, j])
        out[:, 3 + j] = np.interp(at - delay, grid, exact[:, 3 + j])
    counting = _prediction_sensors(settings, True)
    if speeds and not SensorChain(_prediction_sensors(settings, False), dt).ideal:
        config = counting if any(joint.counts for joint in counting.joints) else \
            _prediction_sensors(settings, False)
        chain = SensorChain(config, dt)
        ticks = np.arange(0, steps + 1, per_tick)
        measured = np.array([chain.measure_values(int(k), exact[k, :3].tolist(),
                                                  exact[k, 3:].tolist())[1] for k in ticks])
        for j in range(3):
            out[:, 3 + j] = np.interp(at, ticks.astype(np.float64), measured[:, j])
    return out


__all__ = [
    'SENSOR_JOINTS',
    'CommandRefused',
    'Diverged',
    'base_values',
    'carries_no_command',
    'command_value',
    'declarations',
    'mesh_hz',
    'model',
    'settings_names',
    'simulate',
    'tick_period',
    'typestore',
]
