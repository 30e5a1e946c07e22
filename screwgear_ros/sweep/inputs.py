"""The files a sweep file names, read here on the client (their contents, not their
paths, go to the workers): the base parameter file, the scenario and the controller
module beside it. Each refusal is a :class:`~screwgear_ros.sweep.model.SweepError` at
the line of the sweep file that names the file.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import yaml

from ..inprocess.scenario import ScenarioError, load_scenario
from ..inprocess.simulation import ParameterFileError, file_values
from ..params.yaml_reader import YamlReader

#: Node settings that mean nothing for an in-process run (the node's pacing, clock, DDS
#: lockstep and recorder): sweeping them would change no result.
NODE_ONLY = ('record', 'real_time_factor', 'publish_clock', 'lockstep', 'duration',
             'min_answer_rate')

#: What a file's YAML can hold that a sweep cannot carry to its workers as plain values.
_UNREADABLE = (ParameterFileError, ScenarioError, OSError, UnicodeDecodeError,
               yaml.YAMLError, RecursionError, ValueError, TypeError)


def plain_value(value: Any) -> bool:
    """Whether ``value`` is what a parameter can hold: a bool, a finite or infinite
    number, a string, or a list of those (no dates, no mappings, no nesting)."""
    if isinstance(value, (bool, int, float, str)):
        return True
    return isinstance(value, list) and all(
        isinstance(item, (bool, int, float, str)) for item in value)


def base_values(reader: YamlReader, node: yaml.Node, here: Path) -> tuple[dict[str, Any], str]:
    """The parameters of the base file the ``parameters`` entry names (the node's own
    settings dropped), and the file's resolved path."""
    name = reader.value(node)
    if not isinstance(name, str) or not name:
        raise reader.error(node, 'parameters names a parameter file (path relative to the '
                           'sweep file)')
    path = str((here / name).resolve())
    try:
        base = file_values(path)
    except _UNREADABLE as exc:
        raise reader.error(node, f'{path}: cannot read: {_why(exc)}') from None
    for key in NODE_ONLY:
        base.pop(key, None)
    for key, value in base.items():
        if not isinstance(key, str) or not plain_value(value):
            raise reader.error(node, f'{path}: {key!r}: {value!r} is not a parameter value '
                               '(a number, a string, a bool or a list of them)')
    return base, path


def scenario_of(reader: YamlReader, node: yaml.Node, here: Path) -> tuple[Any, Path, str]:
    """The scenario the ``scenario`` entry names: the loaded scenario, its path and its
    text. A scenario that changes publish_rate after its start is refused here, as
    ``Scenario.run`` refuses it, before any run."""
    name = reader.value(node)
    if not isinstance(name, str) or not name:
        raise reader.error(node, 'scenario names a scenario file (path relative to the '
                           'sweep file)')
    path = here / name
    try:
        scenario = load_scenario(path)
        text = path.read_text(encoding='utf-8')
    except _UNREADABLE as exc:
        raise reader.error(node, f'scenario: {_why(exc)}') from None
    for action in scenario.actions:
        if action.kind == 'parameters' and 'publish_rate' in action.value:
            raise reader.error(node, f'scenario: {path}: line {action.line}: changes '
                               'publish_rate after its start, which an in-process run '
                               'refuses (its ticks are counted at the rate it starts with)')
    return scenario, path, text


def explicit_parameters(text: str) -> tuple[str, ...]:
    """The names of the parameters a scenario's text sets itself."""
    document = yaml.safe_load(text) or {}
    parameters = document.get('parameters') if isinstance(document, dict) else None
    return tuple(parameters) if isinstance(parameters, dict) else ()


def controller_sources(scenario: Any, directory: Path) -> tuple[tuple[str, str], ...]:
    """The controller's module file when it sits beside the scenario (shipped to the
    workers); an installed module is the workers' to have."""
    spec = scenario.controller
    if spec is None or spec.use == 'demo':
        return ()
    module = spec.use.partition(':')[0]
    candidate = directory / (module.replace('.', '/') + '.py')
    if '.' not in module and candidate.is_file():
        return ((candidate.name, candidate.read_text(encoding='utf-8')),)
    return ()


def finite_product(values: tuple[float, ...]) -> bool:
    """Whether every value and the width of the range they span are finite."""
    return all(math.isfinite(v) for v in values) and math.isfinite(max(values) - min(values))


def _why(exc: BaseException) -> str:
    if isinstance(exc, RecursionError):
        return 'nested too deeply'
    if isinstance(exc, UnicodeDecodeError):
        return f'not UTF-8 text (byte {exc.start})'
    if isinstance(exc, OSError):
        return exc.strerror or str(exc)
    return str(exc).splitlines()[0] if str(exc) else type(exc).__name__


__all__ = ['NODE_ONLY', 'base_values', 'controller_sources', 'explicit_parameters',
           'finite_product', 'plain_value', 'scenario_of']
