"""The parts of a scenario file besides its actions' times (docs/scenarios.md): the
table it starts from (``parameters_file``, or the caller's file in its place), a command
action's value, the settling band and the user metrics; each refusal names its line
(the reader's error, a :class:`~screwgear_ros.inprocess.scenario.ScenarioError`)."""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from ..interface import Input
from ..params.declarations import declared
from ..params.table import ParameterError, SimSettings, TableParams
from ..params.yaml_reader import YamlReader
from ..sim.parameter_set import default_values, split_parameters
from .metrics import METRIC_DOCS, BandUnit, SettlingBand
from .scenario_controller import resolve_callable
from .setpoint_profile import SetpointProfile
from .simulation import ParameterFileError, file_values

#: Parameters the node refuses to change while it runs (read-only): an action may not
#: change them, whatever the value.
READ_ONLY = frozenset(p.name for cls in (TableParams, SimSettings) for p in declared(cls)
                      if p.declaration.read_only)


def read_base(reader: YamlReader, top: dict[str, Any], path: Path,
          params: str | os.PathLike[str] | Mapping[str, Any] | None
          ) -> tuple[dict[str, Any], str | None]:
    """The values the scenario's own ``parameters`` go on top of: the node's defaults,
    then ``params`` (given by the caller) or else the scenario's ``parameters_file``
    (relative to the scenario), each validated as the node validates a file."""
    values = default_values()
    node = top['parameters_file'][1] if 'parameters_file' in top else reader.root
    if isinstance(params, Mapping):
        return {**values, **params}, '(values given by the caller)'
    if params is not None:
        file, what = Path(params), f'--params {params}'
    elif 'parameters_file' in top:
        name = reader.value(node)
        if not isinstance(name, str) or not name:
            raise reader.error(node, 'parameters_file names a table_sim parameter file '
                               '(a path relative to the scenario)')
        file, what = path.resolve().parent / name, f'parameters_file {name}'
    else:
        return values, None
    try:
        merged = {**values, **file_values(file)}
        split_parameters(merged)
    except ParameterFileError as exc:
        raise reader.error(node, f'{what}: {exc}') from None
    except ParameterError as exc:
        raise reader.error(node, f'{what}: {file}: the node refuses it: {exc}') from None
    return merged, str(file)


def read_band(reader: YamlReader, node: yaml.Node, values: dict[str, Any],
          setpoint: SetpointProfile | None) -> SettlingBand:
    """``settling_band: {fraction | rad | counts: value}``; counts need the setpoint's
    joint to have an encoder."""
    entries = reader.mapping(node, 'settling_band')
    units = tuple(u.value for u in BandUnit)
    if len(entries) != 1 or next(iter(entries)) not in units:
        raise reader.error(node, 'settling_band is one of {fraction: 0.02} (of the step), '
                           '{rad: 1.0e-6} or {counts: 2} (of the joint\'s encoder)')
    (unit, (_, value_node)), = entries.items()
    value = reader.number(value_node, f'settling_band {unit}', low=0.0, strict=True)
    if unit == BandUnit.COUNTS:
        from ..params.sensors import JOINTS
        joint = setpoint.joint if setpoint is not None else values['joint_names'][1]
        name = JOINTS[list(values['joint_names']).index(joint)]
        if not values.get(f'encoder_counts_{name}'):
            raise reader.error(value_node, f'settling_band in counts needs an encoder on '
                               f'{joint}: encoder_counts_{name} is 0 (an ideal sensor); give '
                               'the band in rad, or set the encoder')
    return SettlingBand(value, BandUnit(unit))


def read_user_metrics(reader: YamlReader, node: yaml.Node,
                  path: Path) -> tuple[tuple[str, str, str], ...]:
    """``metrics: {name: module:callable}``: each loadable, its name new."""
    directory = str(path.resolve().parent)
    out = []
    for name, (key, value_node) in reader.mapping(node, 'metrics').items():
        if not isinstance(name, str) or not name.isidentifier() or name in METRIC_DOCS:
            raise reader.error(key, f'metric name {name!r}: a Python identifier that is not '
                               f'a built-in metric ({", ".join(METRIC_DOCS)})')
        use = reader.value(value_node)
        if not isinstance(use, str) or use.count(':') != 1 or not all(use.split(':')):
            raise reader.error(value_node, f'metric {name}: module:callable, a function '
                               f'(run, setpoint) -> float, not {use!r}')
        try:
            resolve_callable(use, directory)
        except Exception as exc:  # noqa: BLE001 - any import failure is the file's problem
            raise reader.error(value_node, f'metric {name}: {use!r} cannot be loaded: '
                               f'{type(exc).__name__}: {exc}') from None
        out.append((name, use, directory))
    return tuple(out)


def read_command(reader: YamlReader, topic: str, node: yaml.Node) -> Any:
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


def read_parameters(reader: YamlReader, node: yaml.Node, values: dict[str, Any],
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


def check_changeable(reader: YamlReader, node: yaml.Node, what: str) -> None:
    """Refuse a read-only parameter in an action's parameters, at its line: the node
    refuses to change it while it runs."""
    for name, (key, _) in reader.mapping(node, what).items():
        if name in READ_ONLY:
            raise reader.error(key, f'{what}: {name} is read-only: the node refuses to '
                               'change it while it runs; set it under the scenario\'s '
                               'parameters')


__all__ = ['READ_ONLY', 'check_changeable', 'read_band', 'read_base', 'read_command', 'read_parameters', 'read_user_metrics']
