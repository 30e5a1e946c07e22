"""The table in-process, with no ROS: :class:`Simulation`, a Python API over the node's
own :class:`~screwgear_ros.sim.session.Session`.

A simulation is built from what the node takes (its parameter file, parameters by name,
its defaults otherwise), every value checked by the node's own validation
(:func:`screwgear_ros.sim.parameter_set.split_parameters`, the same messages). It then runs the
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
"""

from __future__ import annotations

import math
import os
import shutil
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ScrewgearError
from ..interface import Input
from ..numerics.integrator import OBSERVED
from ..params.table import ParameterError, SimSettings, TableParams
from ..sim.commands import InputRejected, apply_command
from ..sim.events import AdvanceError, Command, Event, shown, step_of
from ..sim.parameter_file import NODE_KEYS, ParameterFileError, file_values, resolve
from ..sim.session import Session
from ..sim.simtime import sim_time_ns
from .closed_loop import Controller, closed_loop
from .samples import (
    DELTA,
    DELTA_RATE,
    JOINTS,
    MESH_1,
    MESH_3,
    MESH_FORCE,
    Observation,
    Run,
    observation_of,
)

#: Bytes a run holds per tick, an upper estimate: the observed row (15 float64), the
#: measured one (6), the command and the step, path and direction columns as Python
#: objects in their lists.
BYTES_PER_TICK = 15 * 8 + 6 * 8 + 4 * 40


class RunInProgress(ScrewgearError, RuntimeError):
    """:meth:`Simulation.reset` or :meth:`Simulation.step` called while
    :meth:`Simulation.run` drives the session (from its controller, say): a run restarts,
    and takes ticks its samples do not hold, only between runs."""


def memory_bytes() -> int:
    """The machine's physical memory, bytes (what a run must fit in)."""
    return os.sysconf('SC_PHYS_PAGES') * os.sysconf('SC_PAGE_SIZE')


class Simulation:
    """The table in-process: see the module docstring.

    ``Simulation(params, settings)`` from validated values, or
    :meth:`from_yaml` / :meth:`from_values` from what the node takes. :meth:`reset`
    starts a run; :meth:`step` and :meth:`run` drive it.

    Parameters
    ----------
    params : TableParams, optional
        The table's physics; default the paper's.
    settings : SimSettings, optional
        Step, publish rate, sensors, …; default the node's.

    Raises
    ------
    TypeError
        ``params`` or ``settings`` of another type (build them by name with
        :meth:`from_values`).

    Examples
    --------
    >>> from screwgear_ros import Simulation
    >>> sim = Simulation.from_values(publish_rate=500.0)
    >>> first = sim.reset()
    >>> sim.step(effort=20.0).step > first.step
    True
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
        self._running = False

    @classmethod
    def from_values(cls, values: Mapping[str, Any] | None = None, /,
                    **overrides: Any) -> Simulation:
        """The node's defaults, then ``values``, then ``overrides``, by parameter name.

        Parameters
        ----------
        values : mapping, optional
            Parameter name → value, as a parameter file holds them.
        **overrides
            Parameter name → value, on top of ``values``.

        Returns
        -------
        Simulation

        Raises
        ------
        ParameterError
            A value the node refuses, naming it and the rule.
        """
        return cls(*resolve(values, **overrides))

    @classmethod
    def from_yaml(cls, path: str | os.PathLike[str], **overrides: Any) -> Simulation:
        """The node's parameter file ``path`` (``/**:`` or ``table_sim:`` keys with
        ``ros__parameters``), then ``overrides`` by parameter name, the node's defaults
        for the rest.

        Parameters
        ----------
        path : str or path-like
            A ROS 2 parameter file, as ``table_sim --params-file`` takes it.
        **overrides
            Parameter name → value, on top of the file's.

        Returns
        -------
        Simulation

        Raises
        ------
        ParameterFileError
            The file cannot be read as a parameter file.
        ParameterError
            A value the node refuses (naming the file or the keyword argument).
        """
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
        self._running = False

    def with_values(self, **overrides: Any) -> Simulation:
        """A new simulation with some parameters changed (validated).

        Parameters
        ----------
        **overrides
            Parameter name → value.

        Returns
        -------
        Simulation
        """
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
        """Start a new run at step 0 at the preload equilibrium, at rest, with no input.

        Returns
        -------
        Observation
            The first observation: what the node publishes before its first tick.

        Raises
        ------
        RunInProgress
            Called while :meth:`run` drives the session (from its controller): a run's
            samples and recording are one session's, so the run ends with this error
            rather than go on as if the reset had not been asked for.
        """
        if self._running:
            raise RunInProgress('reset() during run(): a run cannot restart itself; end '
                                'the run (return from run()) and call run() again')
        self._session = session = Session(self.params, self.settings)
        return observation_of(session.last_outputs, session.plant.fault, session.measured)

    def step(self, effort: float | None = None, *, torque: float | None = None,
             direction: int | None = None, load: float | None = None) -> Observation:
        """Submit the given commands, in the order of the arguments, then one tick.

        ``effort``: cmd_effort's signed drive torque (N·m; the sign is the direction,
        zero keeps it); ``torque``: cmd_torque (N·m, 0 … max_torque); ``direction``:
        cmd_direction (+1 or −1); ``load``: load_torque (N·m at the table). Each means
        what it means on the node's topic and is validated the same way, against the
        input and parameters in force: a refused command raises
        :class:`~screwgear_ros.sim.commands.InputRejected` with the node's message, and
        nothing is submitted or integrated.

        Parameters
        ----------
        effort : float, optional
            cmd_effort's signed drive torque, N·m.
        torque : float, optional
            cmd_torque, N·m.
        direction : int, optional
            cmd_direction, +1 or −1.
        load : float, optional
            load_torque, N·m at the table.

        Returns
        -------
        Observation
            What the tick published.

        Raises
        ------
        InputRejected
            A command the node refuses (nothing is applied).
        RunInProgress
            Called while :meth:`run` drives the session (from its controller): a tick
            that the run does not sample would leave its samples and its recording
            short of what happened (``check_run`` would fail the bag), so the run ends
            with this error.
        """
        if self._running:
            raise RunInProgress('step() during run(): the run ticks the session itself, '
                                'once per answer of its controller; return the effort '
                                'from the controller instead')
        session = self.session
        commands: list[tuple[Input, Any]] = []
        if effort is not None:
            commands.append((Input.CMD_EFFORT, [effort]))
        if torque is not None:
            commands.append((Input.CMD_TORQUE, torque))
        if direction is not None:
            commands.append((Input.CMD_DIRECTION, direction))
        if load is not None:
            commands.append((Input.LOAD_TORQUE, load))
        if commands:
            drive, params = session.plant.input, session.plant.params
            names = session.settings.joint_names
            for topic, value in commands:        # all or nothing (InputRejected)
                try:
                    drive = apply_command(drive, topic, value, params, names)
                except InputRejected:
                    raise
                except (TypeError, ValueError, OverflowError):
                    # no message of the topic can carry it (an int beyond float64, an array)
                    raise InputRejected(topic, shown(value), 'a message of this topic '
                                        'cannot carry it') from None
            for topic, value in commands:
                session.submit(Command(topic, value))
        tick = session.tick()
        return observation_of(tick.outputs, tick.fault, tick.measured)

    def run(self, controller: Controller | None, duration: float,
            record: str | os.PathLike[str] | None = None, *,
            events: Sequence[Event] = (),
            setpoint: Callable[[float], float] | None = None,
            overwrite: bool = False) -> Run:
        """A new run of ``duration`` s of simulation time (rounded to whole ticks), closed
        by ``controller(observation) -> effort`` at every tick: the effort it returns
        for the observation of tick k (cmd_effort's signed drive torque, N·m; None: no
        command) takes effect at the first step of tick k + 1, as a lockstep answer does.

        ``record``: a new rosbag2 directory to record the run to, exactly as table_sim
        records it (``check_run`` and ``replay_run`` take it): a path that does not
        exist or an empty directory (``tempfile.mkdtemp()`` gives a fresh one); with
        ``overwrite`` also an earlier recording there, which is deleted first (a
        non-empty directory that is no recording, i.e. has no ``metadata.yaml``, is
        refused with FileExistsError either way). ``events``: session
        events with their ``step`` set (a scenario's actions), in any order: each is
        submitted once the outputs of its step are out (those of one step in the order
        given), before the controller's answer, as ``replay_run`` plays them into a node. An effort the node refuses raises
        :class:`~screwgear_ros.sim.commands.InputRejected` with the node's message and ends
        the run: the session validated it when it was to take effect, as the node does,
        and ran that tick with the last valid command, as the node does; the recording
        holds the run up to there, that tick included, closed and readable.

        ``setpoint``: the controller's target for the table joint, t (s of simulation
        time) → rad, when it is known (a scenario's profile). A recorded run records it
        as table_sim records demo_controller's ``setpoint`` (before the answer, sent as
        :class:`~screwgear_ros.sim.control.SetpointNotes` says), so ``plot_run`` shows the
        tracking error; it changes nothing else, and an unrecorded run ignores it.

        Parameters
        ----------
        controller : callable or None
            ``controller(observation) -> effort`` (N·m, or None for no command); None
            runs open loop.
        duration : float
            Simulation time, s, rounded to whole ticks.
        record : str or path-like, optional
            A new rosbag2 directory to record the run to.
        events : sequence of Event
            Session events with their ``step`` set.
        setpoint : callable, optional
            t → the table's target angle (rad), recorded for the plots.

        Returns
        -------
        Run
            The samples, sample 0 the start.

        Raises
        ------
        InputRejected
            An answer the node refuses (the run ends there; a recording is kept).
        ValueError
            A duration that is not a finite number of seconds >= 0, or a ``setpoint``
            that is not callable.
        AdvanceError
            An element of ``events`` that is no session event, or has no step that is an
            integer >= 0 (a ValueError too).
        RunInProgress
            Called from a run's controller.
        """
        try:
            valid = (not isinstance(duration, bool) and isinstance(duration, (int, float))
                     and math.isfinite(duration) and duration >= 0.0)
        except OverflowError:                  # an int beyond float64
            valid = False
        if not valid:
            raise ValueError(f'duration must be a finite number of seconds >= 0, '
                             f'got {shown(duration)}')
        if not isinstance(events, Sequence) or isinstance(events, (str, bytes)):
            raise AdvanceError(f'events must be a sequence of session events, got a '
                               f'{type(events).__name__}')
        steps = [step_of(event, f'events[{i}]') for i, event in enumerate(events)]
        if setpoint is not None and not callable(setpoint):
            raise ValueError(f'setpoint must be a callable t -> rad, got a '
                             f'{type(setpoint).__name__}')
        ticks = round(duration / self.tick_period)
        if ticks * BYTES_PER_TICK > memory_bytes():
            raise ValueError(f'duration {duration:g} s is {ticks:.3g} ticks, about '
                             f'{ticks * BYTES_PER_TICK / 2**30:.3g} GiB of samples; this '
                             f'machine has {memory_bytes() / 2**30:.3g} GiB: run it in '
                             'parts (step(), or run() over shorter durations)')
        if record is not None and overwrite:
            remove_recording(Path(record))
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
        self._running = True
        try:
            if record is not None:
                from ..runs.session_record import SessionRecording  # the bag writer: to record
                recording = SessionRecording(record, session)
            closed_loop(session, controller, first, ticks, observed, command, columns,
                        [events[i] for i in sorted(range(len(events)), key=steps.__getitem__)],
                        recording, rejected,
                        measured, setpoint if recording is not None else None)
        finally:
            self._running = False
            if recording is not None:
                recording.close()
        steps, paths, directions = columns
        n = len(steps)
        return Run(self.params, self.settings, np.array(steps, dtype=np.int64), observed[:n],
                   np.array(paths, dtype=np.int8), np.array(directions, dtype=np.int8),
                   np.array(command[:n], dtype=np.float64), session.plant.fault,
                   None if record is None else Path(record),
                   rejected, None if measured is None else measured[:n])


def remove_recording(path: Path) -> None:
    """Delete the rosbag2 recording at ``path``, if there is one. FileExistsError: a
    non-empty directory (or a file) there that is not a recording."""
    if not path.exists() or (path.is_dir() and not any(path.iterdir())):
        return
    if not (path / 'metadata.yaml').is_file():
        raise FileExistsError(f'{path} exists and is not a recording (no metadata.yaml): '
                              'not overwritten')
    shutil.rmtree(path)


def stamp_ns(observation: Observation, dt: float) -> int:
    """The header stamp (ns) the node puts on this observation's messages."""
    return sim_time_ns(observation.step, dt)


__all__ = [
    'BYTES_PER_TICK',
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
    'RunInProgress',
    'Simulation',
    'file_values',
    'remove_recording',
    'resolve',
    'stamp_ns',
]
