"""Scenario files: a run of the table written down (docs/scenarios.md).

A scenario gives the node's parameters, a duration, timed actions (commands, parameter
changes, resets, at simulation times), and optionally a controller closing the loop
at every tick (``demo``, the demo controller's law, or ``module:callable``) with a
setpoint profile it tracks. :func:`load_scenario` reads and validates one: every error is
a :class:`ScenarioError` naming the file and the line. :meth:`Scenario.run` runs it
in-process (:class:`~screwgear_ros.inprocess.simulation.Simulation`); :meth:`Scenario.schedule`
is what ``replay_run --script`` plays into a live node over DDS (actions only).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from ..errors import ScrewgearError
from ..interface import Input
from ..params.declarations import declared
from ..params.table import ParameterError, SimSettings, TableParams
from ..params.yaml_reader import YamlReader
from ..sim.commands import INPUT_TOPICS, InputRejected, apply_command
from ..sim.control import TABLE_JOINT, DemoController
from ..sim.events import Command, Event, ParameterChange, Reset
from ..sim.parameter_set import default_values, split_parameters
from ..sim.plant import DriveInput
from ..sim.schedule import Schedule
from .scenario_controller import ControllerSpec, read_controller, resolve_callable
from .setpoint_profile import PROFILES, SetpointProfile, read_setpoint
from .simulation import Controller, Run, Simulation

#: The top-level keys of a scenario.
KEYS = ('parameters', 'duration', 'actions', 'controller', 'setpoint')
#: What an action can do besides its ``time``: a command on an input topic, a parameter
#: change, a reset.
ACTIONS = (*INPUT_TOPICS, 'parameters', 'reset')
#: Parameters the node refuses to change while it runs (read-only): an action may not
#: change them, whatever the value.
READ_ONLY = frozenset(p.name for cls in (TableParams, SimSettings) for p in declared(cls)
                      if p.declaration.read_only)


class ScenarioError(ScrewgearError, ValueError):
    """A scenario that cannot be run; the message names the file and the line.

    Examples
    --------
    >>> from screwgear_ros import ScenarioError, load_scenario
    >>> try:
    ...     load_scenario('no/such/scenario.yaml')
    ... except ScenarioError as exc:
    ...     print('cannot read' in str(exc) or 'no/such' in str(exc))
    True
    """


# ---------------------------------------------------------------- the scenario

@dataclass(frozen=True)
class Action:
    """One timed action: at ``time`` s, ``kind`` (an input topic, 'parameters', 'reset')
    with ``value``; ``line`` in the file."""

    time: float
    kind: str
    value: Any
    line: int = 0


@dataclass(frozen=True)
class Scenario:
    """A validated scenario (module docstring, ``docs/scenarios.md``). Immutable and
    picklable; :func:`load_scenario` makes one from a file.

    Attributes
    ----------
    path : str
        The file it was read from.
    values : tuple of (str, object)
        The node's parameters at the start, by name.
    duration : float
        Simulation time to run, s.
    actions : tuple of Action
        What happens when: commands and parameter changes at their times.
    controller : ControllerSpec or None
        The controller closing the loop (``demo`` or ``module:callable``).
    setpoint : SetpointProfile or None
        The target the controller and the metrics follow.

    Examples
    --------
    >>> from screwgear_ros import load_scenario
    >>> from screwgear_ros.sim.parameter_file import NODE_KEYS
    >>> import screwgear_ros, pathlib
    >>> example = pathlib.Path(screwgear_ros.__file__).parents[1] / 'docs/examples/pd_sine.yaml'
    >>> scenario = load_scenario(example) if example.exists() else None
    >>> scenario is None or scenario.duration > 0
    True
    """

    path: str
    values: tuple[tuple[str, Any], ...]          # the node's parameters at the start
    duration: float                              # s of simulation time
    actions: tuple[Action, ...] = ()
    controller: ControllerSpec | None = None
    setpoint: SetpointProfile | None = None

    def simulation(self, **overrides: Any) -> Simulation:
        """The scenario's simulation, some parameters changed (validated).

        Parameters
        ----------
        **overrides
            Parameters by name, on top of the scenario's start values.

        Returns
        -------
        Simulation
            Not started: :meth:`run` or ``Simulation.run`` starts it.
        """
        return Simulation.from_values(dict(self.values), **overrides)

    def events(self, simulation: Simulation) -> list[Event]:
        """The actions as session events at their steps (parameter changes on top of the
        simulation's own parameters).

        Parameters
        ----------
        simulation : Simulation
            The simulation the events are for (its step and parameters).

        Returns
        -------
        list of Event
            In step order, each with its ``step`` set.
        """
        dt = simulation.settings.dt
        values = {**simulation.params.as_dict(), **simulation.settings.as_dict()}
        out: list[Event] = []
        for action in self.actions:
            step = round(action.time / dt)
            if action.kind == 'reset':
                out.append(Reset(step))
            elif action.kind == 'parameters':
                values = {**values, **action.value}
                params, settings = split_parameters(values)
                out.append(ParameterChange(params, settings, step))
            else:
                out.append(Command(action.kind, action.value, step))
        return out

    def run(self, record: str | os.PathLike[str] | None = None,
            simulation: Simulation | None = None,
            guard: Callable[[Controller | None], Controller] | None = None) -> Run:
        """Run the scenario in-process: the one code path that runs a scenario.

        Parameters
        ----------
        record : path, optional
            Record the run there, as table_sim records.
        simulation : Simulation, optional
            Run on it (e.g. the scenario's with some parameters changed); default: the
            scenario's own.
        guard : callable, optional
            ``guard(controller) -> controller``: what answers each tick in the place of
            the scenario's controller (None when it has none), e.g. one that stops a run
            over its wall-time limit.

        Returns
        -------
        Run
            The run's samples.

        Raises
        ------
        ScenarioError
            The scenario changes publish_rate after its start.
        """
        for action in self.actions:
            if action.kind == 'parameters' and 'publish_rate' in action.value:
                raise ScenarioError(f'{self.path}: line {action.line}: an in-process run counts '
                                    'its ticks at the publish_rate it starts with; change '
                                    'publish_rate at the start (replay_run --script plays '
                                    'such a change into a node)')
        simulation = simulation or self.simulation()
        controller = (None if self.controller is None
                      else self.controller.make(simulation, self.setpoint))
        target = self._table_target(simulation, controller)
        return simulation.run(controller if guard is None else guard(controller),
                              self.duration, record, events=self.events(simulation),
                              setpoint=target)

    def _table_target(self, simulation: Simulation,
                      controller: Controller | None) -> Callable[[float], float] | None:
        """What a recorded run records as the controller's setpoint: the scenario's
        profile, or the demo controller's own targets (its profile starts at the run's
        first tick, t = 0), when it is the table joint's; else None."""
        table = simulation.settings.joint_names[TABLE_JOINT]
        if self.setpoint is not None:
            return self.setpoint if self.setpoint.joint == table else None
        if isinstance(controller, DemoController) and controller.law.gains.joint == table:
            return controller.law.target
        return None

    def schedule(self) -> Any:
        """What ``replay_run --script`` plays into a node.

        Returns
        -------
        Schedule
            The start values and the actions at their steps
            (:class:`~screwgear_ros.sim.schedule.Schedule`).
        """
        simulation = self.simulation()
        return Schedule(simulation.params, simulation.settings, self.events(simulation),
                        end_step=round(self.duration / simulation.settings.dt))


def load_scenario(path: str | os.PathLike[str]) -> Scenario:
    """Read and validate a scenario file (``docs/scenarios.md``).

    Parameters
    ----------
    path : str or path-like
        The scenario file (YAML).

    Returns
    -------
    Scenario
        Every value checked as the node checks it.

    Raises
    ------
    ScenarioError
        Naming the file and the line of what is wrong.

    Examples
    --------
    >>> from screwgear_ros import load_scenario
    >>> import screwgear_ros, pathlib
    >>> root = pathlib.Path(screwgear_ros.__file__).parents[1]
    >>> path = root / 'docs/examples/demo_position_steps.yaml'
    >>> load_scenario(path).duration > 0 if path.exists() else True
    True
    """
    path = Path(path)
    reader = YamlReader.open(path, ScenarioError)
    if reader.root is None:
        raise ScenarioError(f'{path}: empty; a scenario needs at least a duration')
    top = reader.mapping(reader.root, 'a scenario')
    reader.known(top, KEYS, 'scenario key')
    if 'duration' not in top:
        raise reader.error(reader.root, 'a scenario needs a duration (s of simulation time)')
    duration = reader.number(top['duration'][1], 'duration', low=0.0, strict=True)

    values = default_values()
    if 'parameters' in top:
        values = _parameters(reader, top['parameters'][1], values, 'parameters')
    start = values
    actions: list[Action] = []
    if 'actions' in top:
        node = top['actions'][1]
        if not isinstance(node, yaml.SequenceNode):
            raise reader.error(node, 'actions must be a list of {time: s, <action>: value}')
        timed = []
        for item in node.value:
            entries = reader.mapping(item, 'an action')
            if 'time' not in entries:
                raise reader.error(item, 'an action needs a time (s of simulation time)')
            time_node = entries['time'][1]
            t = reader.number(time_node, 'an action time', low=0.0)
            if t > duration:
                raise reader.error(time_node, f'action at {t:g} s is after the end of the '
                                   f'scenario (duration {duration:g} s)')
            rest = {k: v for k, v in entries.items() if k != 'time'}
            reader.known(rest, ACTIONS, 'action')
            if len(rest) != 1:
                raise reader.error(item, f'an action has a time and exactly one of '
                                   f'{", ".join(ACTIONS)}; this one has {len(rest)}')
            (kind, (_, value_node)), = rest.items()
            timed.append((t, kind, value_node, item))
        timed.sort(key=lambda entry: entry[0])        # stable: file order at equal times
        for t, kind, value_node, item in timed:
            line = item.start_mark.line + 1
            if kind == 'parameters':
                before = values
                _changeable(reader, value_node, f'parameters at {t:g} s')
                values = _parameters(reader, value_node, values, f'parameters at {t:g} s')
                change = {k: v for k, v in values.items() if before.get(k) != v}
                actions.append(Action(t, kind, change, line))
            elif kind == 'reset':
                if reader.value(value_node) is not True:
                    raise reader.error(value_node, 'reset takes the value true')
                actions.append(Action(t, kind, True, line))
            else:
                command = _command(reader, kind, value_node)
                params, settings = split_parameters(values)
                try:
                    apply_command(DriveInput(), kind, command, params, settings.joint_names)
                except InputRejected as exc:
                    raise reader.error(value_node, f'the node would refuse this command: '
                                       f'{exc}') from None
                actions.append(Action(t, kind, command, line))
    controller = read_controller(reader, top['controller'][1]) if 'controller' in top else None
    first = split_parameters(start)[1]
    tick = first.steps_per_publish * first.dt
    written = top.get(Input.SETPOINT)   # the setpoint input's profile
    setpoint = read_setpoint(reader, written[1], tick) if written is not None else None
    if setpoint is not None and setpoint.joint not in values['joint_names']:
        raise reader.error(top[Input.SETPOINT][1], f'setpoint joint {setpoint.joint!r} is not one '
                           f'of the joint_states names {values["joint_names"]}')
    return Scenario(str(path), tuple(start.items()), duration, tuple(actions), controller,
                    setpoint)


def _parameters(reader: YamlReader, node: yaml.Node, values: dict[str, Any],
                what: str) -> dict[str, Any]:
    """``values`` with the parameters of a mapping node, validated as the node validates
    them; the error names the line of the parameter it is about."""
    entries = reader.mapping(node, what)
    merged = {**values, **{name: reader.value(v) for name, (_, v) in entries.items()}}
    try:
        split_parameters(merged)
    except ParameterError as exc:
        key = entries.get(exc.name)
        raise reader.error(key[0] if key is not None else node, f'{what}: {exc}') from None
    return merged


def _changeable(reader: YamlReader, node: yaml.Node, what: str) -> None:
    """Refuse a read-only parameter in an action's parameters, at its line: the node
    refuses to change it while it runs."""
    for name, (key, _) in reader.mapping(node, what).items():
        if name in READ_ONLY:
            raise reader.error(key, f'{what}: {name} is read-only: the node refuses to '
                               'change it while it runs; set it under the scenario\'s '
                               'parameters')


def _command(reader: YamlReader, topic: str, node: yaml.Node) -> Any:
    """The value of a command action, as its message would carry it."""
    value = reader.value(node)
    if topic == Input.CMD_EFFORT:
        if not isinstance(value, list):
            raise reader.error(node, 'cmd_effort takes a list of one signed torque, e.g. '
                               '[-350.0]')
        return value
    if topic == Input.JOINT_COMMANDS:
        from ..sim.commands import JointCommand
        if not isinstance(value, dict) or not set(value) <= {'name', 'position', 'velocity',
                                                             'effort'}:
            raise reader.error(node, 'joint_commands takes {name: [...], effort: [...]}')
        return JointCommand(tuple(value.get('name', ())), tuple(value.get('position', ())),
                            tuple(value.get('velocity', ())), tuple(value.get('effort', ())))
    if topic == Input.CMD_DIRECTION:
        if isinstance(value, bool) or not isinstance(value, int):
            raise reader.error(node, f'cmd_direction takes +1 or -1, not {value!r}')
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise reader.error(node, f'{topic} takes a number, not {value!r}')
    return float(value)


def schedule_from_scenario(path: str | Path) -> Schedule:
    """The timed actions of a scenario file (docs/scenarios.md; the test bags are recorded
    from these) as a schedule.

    Parameters
    ----------
    path : str or Path
        The scenario file.

    Returns
    -------
    Schedule
        Its start values and actions at their steps.

    Raises
    ------
    ScenarioError
        Naming the line of what is wrong; and for a scenario with a controller: that
        runs in-process (``run_scenario``), a replay plays actions only.
    """
    scenario = load_scenario(path)            # the format's one reader
    if scenario.controller is not None:
        raise ScenarioError(f'{path}: line {scenario.controller.line}: this scenario closes '
                         'its loop with a controller, which run_scenario runs in-process; '
                         'replay_run --script plays a scenario\'s timed actions only')
    return scenario.schedule()

__all__ = [
    'ACTIONS',
    'KEYS',
    'PROFILES',
    'READ_ONLY',
    'Action',
    'ControllerSpec',
    'Scenario',
    'ScenarioError',
    'SetpointProfile',
    'load_scenario',
    'resolve_callable',
    'schedule_from_scenario',
]
