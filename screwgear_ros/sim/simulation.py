"""The table in-process, with no ROS: :class:`Simulation`, a Python API over the node's
own :class:`~screwgear_ros.sim.session.Session`.

A simulation is built from what the node takes (its parameter file, parameters by name,
its defaults otherwise), every value checked by the node's own validation
(:func:`screwgear_ros.params.sets.split_parameters`, the same messages). It then runs the
node's tick: :meth:`Simulation.step` submits the commands a controller would publish on
the node's input topics (validated by :mod:`screwgear_ros.sim.commands`, as the node
validates them) and integrates one tick (1/``publish_rate`` s); the commands take effect
at the tick's first step, as an answer does in lockstep. :meth:`Simulation.run` closes
the loop with ``controller(observation) -> effort`` at every tick, returns the samples
as NumPy arrays and can record the run as table_sim records it (``check_run`` and
``replay_run`` take the bag). A controller that is deterministic gives the same bits
here as around ``table_sim`` in lockstep.

Everything a simulation is made of (parameters, settings) is an immutable, picklable
value, and a run depends on nothing else: the same inputs give the same bits in any
process, in any order.

Why one module of this length: the Observation a controller sees, the Run it gets
back and the closed loop that fills one from the other share one column layout; the
loop is the in-process API's hot path and is kept beside the arrays it writes.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from ..interface import Input
from ..numerics.integrator import OBSERVED
from ..params.sets import default_values, split_parameters
from ..params.table import ParameterError, SimSettings, TableParams
from .commands import InputRejected, apply_command
from .control import SetpointNotes
from .events import Command, Event, ParameterChange, Setpoint
from .plant import OBSERVED_DELTA, OBSERVED_JOINTS
from .session import Session, Tick
from .simtime import sim_time_ns

#: Keys of a ROS 2 parameter file whose ``ros__parameters`` table_sim takes: any node
#: (``/**``) and the node's own name, with or without its leading slash.
NODE_KEYS = ('/**', 'table_sim', '/table_sim', '/**/table_sim')


class ParameterFileError(ValueError):
    """A parameter file that cannot be read as table_sim's parameters; says why."""


def file_values(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The table_sim parameters of a ROS 2 parameter file (``/**:`` or node-name keys
    with ``ros__parameters``, in file order; or a bare mapping of parameter names)."""
    try:
        with open(path, encoding='utf-8') as stream:
            document = yaml.safe_load(stream)
    except OSError as exc:
        raise ParameterFileError(f'{path}: cannot read: {exc.strerror or exc}') from None
    except yaml.YAMLError as exc:
        raise ParameterFileError(f'{path}: not valid YAML: {exc}') from None
    if document is None:
        return {}
    if not isinstance(document, dict):
        raise ParameterFileError(f'{path}: a parameter file is a mapping, not '
                                 f'{type(document).__name__}')
    sections = {k: v for k, v in document.items()
                if isinstance(v, dict) and 'ros__parameters' in v}
    if not sections:
        return dict(document)
    values: dict[str, Any] = {}
    for key, section in sections.items():
        if key in NODE_KEYS:
            entries = section['ros__parameters'] or {}
            if not isinstance(entries, dict):
                raise ParameterFileError(f'{path}: {key}: ros__parameters must be a mapping')
            values.update(entries)
    if not any(key in NODE_KEYS for key in sections):
        raise ParameterFileError(f'{path}: no parameters for table_sim (keys '
                                 f'{", ".join(NODE_KEYS)}); found {", ".join(map(str, sections))}')
    return values


def resolve(values: Mapping[str, Any] | None = None, **overrides: Any) -> tuple[
        TableParams, SimSettings]:
    """The node's defaults, then ``values``, then ``overrides``, by parameter name,
    validated as the node validates them (ParameterError naming the parameter)."""
    return split_parameters({**default_values(), **dict(values or {}), **overrides})


@dataclass(slots=True)
class Observation:
    """What one tick publishes, SI units. Read-only by convention (slotted, not frozen:
    one is made a tick). ``position``, ``velocity`` and ``effort`` are per joint in
    joint_states order (pinion 1, table, pinion 3): what the joint sensors measure
    (:mod:`screwgear_ros.physics.sensors`; the exact state when they are ideal), and
    ``true_position``, ``true_velocity`` the exact state (~/true_joint_states);
    ``delta``, ``delta_rate`` and ``mesh_force`` are mesh_state's values (mesh 1,
    mesh 3)."""

    time: float                                # simulation time, s (step·dt)
    step: int                                  # integration steps since the start
    position: tuple[float, float, float]       # rad
    velocity: tuple[float, float, float]       # rad/s
    effort: tuple[float, float, float]         # N·m
    transmission_error: float                  # δ of the active path, m
    delta: tuple[float, float]                 # δ1, δ3, m
    delta_rate: tuple[float, float]            # δ̇1, δ̇3, m/s
    mesh_force: tuple[float, float]            # F1, F3, N
    active_path: int                           # 1 or 3
    fault: str | None                          # why the plant stands still, if it does
    true_position: tuple[float, float, float] = (0.0, 0.0, 0.0)   # rad, exact
    true_velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)   # rad/s, exact


def _observation(tick_outputs: Any, fault: str | None, measured: Any = None) -> Observation:
    o = tick_outputs
    m = o if measured is None else measured
    return Observation(o.time, o.step, m.position, m.velocity, o.effort,
                       o.delta[0] if o.active_path == 1 else o.delta[1], o.delta,
                       o.delta_rate, o.mesh_force, o.active_path, fault, o.position,
                       o.velocity)


#: Columns of :attr:`Run.observed`, the plant's observed vector of each sample
#: (:data:`~screwgear_ros.numerics.integrator.OBSERVED` wide): θ, ω and effort of the three joints
#: (a joint_states row), then δ, δ̇ and F of mesh 1 and of mesh 3 (mesh_state's values).
JOINTS = OBSERVED_JOINTS
MESH_1, MESH_3 = OBSERVED_DELTA[1], OBSERVED_DELTA[3]
DELTA, DELTA_RATE, MESH_FORCE = [MESH_1, MESH_3], [MESH_1 + 1, MESH_3 + 1], \
    [MESH_1 + 2, MESH_3 + 2]


@dataclass
class Run:
    """The samples of a closed-loop run: sample 0 is the start (what :meth:`Simulation.reset`
    returned), sample i > 0 what tick i made. ``command[i]`` is the effort the controller
    answered sample i with (NaN: no command; the last sample is not answered)."""

    params: TableParams
    settings: SimSettings
    step: np.ndarray          # (n,) int64
    observed: np.ndarray      # (n, OBSERVED) float64, columns above
    path: np.ndarray          # (n,) int8: the active path, 1 or 3
    direction: np.ndarray     # (n,) int8: the commanded direction during the sample's tick
    command: np.ndarray       # (n,) float64, N·m
    fault: str | None = None  # why the plant stood still, if it faulted
    record: Path | None = None
    #: Scheduled commands the session refused when they were to take effect (the node
    #: logs these and keeps the last valid command in force), as (step, message).
    rejected: list[tuple[int, str]] = field(default_factory=list)
    #: (n, 6): θ and ω of the three joints as joint_states published them, measured by
    #: the joint sensors (None: the sensors are ideal, the exact :attr:`observed` ones)
    measured: np.ndarray | None = None

    @property
    def time(self) -> np.ndarray:
        """Simulation time of each sample, s."""
        return self.step * self.settings.dt

    @property
    def joint_states(self) -> np.ndarray:
        """(n, 9): θ, ω, effort of the three joints, as a joint_states row."""
        return self.observed[:, JOINTS]

    @property
    def position(self) -> np.ndarray:
        return self.observed[:, 0:3]

    @property
    def velocity(self) -> np.ndarray:
        return self.observed[:, 3:6]

    @property
    def effort(self) -> np.ndarray:
        return self.observed[:, 6:9]

    @property
    def delta(self) -> np.ndarray:
        """(n, 2): δ1, δ3, m."""
        return self.observed[:, DELTA]

    @property
    def delta_rate(self) -> np.ndarray:
        return self.observed[:, DELTA_RATE]

    @property
    def mesh_force(self) -> np.ndarray:
        return self.observed[:, MESH_FORCE]

    @property
    def transmission_error(self) -> np.ndarray:
        """δ of the active path, m (the transmission_error topic)."""
        return np.where(self.path == 1, self.observed[:, MESH_1], self.observed[:, MESH_3])

    @property
    def active_path(self) -> np.ndarray:
        return self.path

    def __len__(self) -> int:
        return len(self.step)


Controller = Callable[[Observation], 'float | None']


class Simulation:
    """The table in-process: see the module docstring.

    ``Simulation(params, settings)`` from validated values, or
    :meth:`from_yaml` / :meth:`from_values` from what the node takes. :meth:`reset`
    starts a run; :meth:`step` and :meth:`run` drive it.
    """

    def __init__(self, params: TableParams | None = None,
                 settings: SimSettings | None = None) -> None:
        params = TableParams() if params is None else params
        settings = SimSettings() if settings is None else settings
        if not isinstance(params, TableParams) or not isinstance(settings, SimSettings):
            raise TypeError('Simulation(params, settings) takes a TableParams and a SimSettings '
                            '(Simulation.from_values builds them from parameter names)')
        self.params, self.settings = resolve({**params.as_dict(), **settings.as_dict()})
        self._session: Session | None = None

    @classmethod
    def from_values(cls, values: Mapping[str, Any] | None = None, /,
                    **overrides: Any) -> Simulation:
        """The node's defaults, then ``values``, then ``overrides``, by parameter name.
        Raises :class:`~screwgear_ros.params.table.ParameterError` as the node refuses a value."""
        return cls(*resolve(values, **overrides))

    @classmethod
    def from_yaml(cls, path: str | os.PathLike[str], **overrides: Any) -> Simulation:
        """The node's parameter file ``path`` (``/**:`` or ``table_sim:`` keys with
        ``ros__parameters``), then ``overrides`` by parameter name, the node's defaults
        for the rest. Raises :class:`ParameterFileError` (unreadable file) or
        :class:`~screwgear_ros.params.table.ParameterError` (a value the node refuses)."""
        values = file_values(path)
        try:
            return cls.from_values(values, **overrides)
        except ParameterError as exc:
            where = 'keyword argument' if exc.name in overrides else str(path)
            raise ParameterError(exc.name, exc.value, f'{exc.rule} ({where})') from None

    def __getstate__(self) -> dict[str, Any]:
        """A pickled simulation is its parameters and settings (a run in progress stays
        behind: it is resumed nowhere else)."""
        return {'params': self.params, 'settings': self.settings}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.params, self.settings = state['params'], state['settings']
        self._session = None

    def with_values(self, **overrides: Any) -> Simulation:
        """A new simulation with some parameters changed (validated)."""
        return Simulation.from_values({**self.params.as_dict(), **self.settings.as_dict()},
                                      **overrides)

    # ------------------------------------------------------------------ one run

    @property
    def session(self) -> Session:
        """The session of the run in progress (RuntimeError before :meth:`reset`)."""
        if self._session is None:
            raise RuntimeError('no run in progress: call reset() first')
        return self._session

    @property
    def tick_period(self) -> float:
        """Simulation time of one tick, s (steps_per_publish · dt)."""
        return self.settings.steps_per_publish * self.settings.dt

    def reset(self) -> Observation:
        """Start a new run at step 0 at the preload equilibrium, at rest, with no input;
        its first observation (what the node publishes before its first tick)."""
        self._session = session = Session(self.params, self.settings)
        return _observation(session.last_outputs, session.plant.fault, session.measured)

    def step(self, effort: float | None = None, *, torque: float | None = None,
             direction: int | None = None, load: float | None = None) -> Observation:
        """Submit the given commands, in the order of the arguments, then one tick.

        ``effort``: cmd_effort's signed drive torque (N·m; the sign is the direction,
        zero keeps it); ``torque``: cmd_torque (N·m, 0 … max_torque); ``direction``:
        cmd_direction (+1 or −1); ``load``: load_torque (N·m at the table). Each means
        what it means on the node's topic and is validated the same way, against the
        input and parameters in force: a refused command raises
        :class:`~screwgear_ros.sim.commands.InputRejected` with the node's message, and
        nothing is submitted or integrated. Returns the tick's observation.
        """
        session = self.session
        commands = []
        if effort is not None:
            commands.append(('cmd_effort', [effort]))
        if torque is not None:
            commands.append(('cmd_torque', torque))
        if direction is not None:
            commands.append(('cmd_direction', direction))
        if load is not None:
            commands.append(('load_torque', load))
        if commands:
            drive, params = session.plant.input, session.plant.params
            names = session.settings.joint_names
            for topic, value in commands:        # all or nothing (InputRejected)
                drive = apply_command(drive, topic, value, params, names)
            for topic, value in commands:
                session.submit(Command(topic, value))
        tick = session.tick()
        return _observation(tick.outputs, tick.fault, tick.measured)

    def run(self, controller: Controller | None, duration: float,
            record: str | os.PathLike[str] | None = None, *,
            events: Sequence[Event] = (),
            setpoint: Callable[[float], float] | None = None) -> Run:
        """A new run of ``duration`` s of simulation time (rounded to whole ticks), closed
        by ``controller(observation) -> effort`` at every tick: the effort it returns
        for the observation of tick k (cmd_effort's signed drive torque, N·m; None: no
        command) takes effect at the first step of tick k + 1, as a lockstep answer does.

        ``record``: a new rosbag2 directory to record the run to, exactly as table_sim
        records it (``check_run`` and ``replay_run`` take it). ``events``: session
        events with their ``step`` set (a scenario's actions), each submitted once the
        outputs of its step are out, before the controller's answer, as ``replay_run``
        plays them into a node. An effort the node refuses raises
        :class:`~screwgear_ros.sim.commands.InputRejected` with the node's message and ends
        the run: the session validated it when it was to take effect, as the node does,
        and ran that tick with the last valid command, as the node does; the recording
        holds the run up to there, that tick included, closed and readable.

        ``setpoint``: the controller's target for the table joint, t (s of simulation
        time) → rad, when it is known (a scenario's profile). A recorded run records it
        as table_sim records demo_controller's ``setpoint`` (before the answer, sent as
        :class:`~screwgear_ros.sim.control.SetpointNotes` says), so ``plot_run`` shows the
        tracking error; it changes nothing else, and an unrecorded run ignores it.
        """
        if isinstance(duration, bool) or not (isinstance(duration, (int, float))
                                              and math.isfinite(duration) and duration >= 0.0):
            raise ValueError(f'duration must be a finite number of seconds >= 0, '
                             f'got {duration!r}')
        if any(event.step is None for event in events):
            raise ValueError('every event of a run needs the step it takes effect at')
        ticks = int(round(duration / self.tick_period))
        first = self.reset()
        session = self.session
        recording = None
        observed = np.empty((ticks + 1, OBSERVED))
        measured = None if session.sensors.ideal else np.empty((ticks + 1, 6))
        # A list, made an array at the end: a store into it costs a fraction of NumPy's
        # per-element one, and holds whatever the controller answered until the session
        # has judged it (a refused answer raises InputRejected, as the node refuses it).
        command: list[Any] = [math.nan] * (ticks + 1)
        columns: tuple[list[int], list[int], list[int]] = ([], [], [])
        rejected: list[tuple[int, str]] = []
        try:
            if record is not None:
                from ..ros.session_record import SessionRecording  # rclpy messages: to record
                recording = SessionRecording(record, session)
            _loop(session, controller, first, ticks, observed, command, columns,
                  sorted(events, key=lambda e: e.step), recording, rejected, measured,
                  setpoint if recording is not None else None)
        finally:
            if recording is not None:
                recording.close()
        steps, paths, directions = columns
        n = len(steps)
        return Run(self.params, self.settings, np.array(steps, dtype=np.int64), observed[:n],
                   np.array(paths, dtype=np.int8), np.array(directions, dtype=np.int8),
                   np.array(command[:n], dtype=np.float64), session.plant.fault,
                   None if record is None else Path(record),
                   rejected, None if measured is None else measured[:n])


def _loop(session: Session, controller: Controller | None, first: Observation, ticks: int,
          observed: np.ndarray, command: list[Any],
          columns: tuple[list[int], list[int], list[int]], events: list[Event],
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
            target = float(setpoint(stamp * 1e-9))
            if notes.due(stamp, target):
                session.submit(Setpoint(target))
        effort = None if controller is None else controller(observation)
        if effort is not None:
            if type(effort) is not float and isinstance(effort, np.generic):
                effort = effort.item()
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
                    every_tick=recording is not None,
                    changes=change if recording is not None else None)


def _refused(tick: Tick, effort: Any, rejected: list[tuple[int, str]]) -> None:
    """Refusals of a tick: the controller's answer ``effort`` (None: it gave none)
    raises (the session validated it as the node does; the tick ran with the last valid
    command, as in the node), a scheduled command's is kept in ``rejected``."""
    for error in tick.rejected:
        if effort is not None and error.topic == Input.CMD_EFFORT and error.value == [effort]:
            raise error
        rejected.append((tick.start, str(error)))


def stamp_ns(observation: Observation, dt: float) -> int:
    """The header stamp (ns) the node puts on this observation's messages."""
    return sim_time_ns(observation.step, dt)


__all__ = [
    'DELTA',
    'DELTA_RATE',
    'JOINTS',
    'MESH_1',
    'MESH_3',
    'MESH_FORCE',
    'NODE_KEYS',
    'Controller',
    'InputRejected',
    'Observation',
    'ParameterFileError',
    'Run',
    'Simulation',
    'file_values',
    'resolve',
    'stamp_ns',
]
