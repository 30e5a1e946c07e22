"""The controller a scenario names (``controller:`` in a scenario file): ``demo``, the demo
law, or ``module:callable`` of the user's, resolved as ``python -m`` would from the
scenario's directory."""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import yaml

from ..params.yaml_reader import YamlReader
from ..sim.control import DemoController, DemoGains
from .setpoint_profile import SetpointProfile
from .simulation import Controller, Simulation

#: A scenario's controller: its keys.
CONTROLLER_KEYS = ('use', 'parameters')


@dataclass(frozen=True)
class ControllerSpec:
    """``use``: 'demo' or 'module:callable'; ``parameters``: its keyword arguments."""

    use: str
    parameters: tuple[tuple[str, Any], ...] = ()
    line: int = 0
    directory: str = ''      # the scenario file's: searched first for the module

    def make(self, simulation: Simulation, setpoint: SetpointProfile | None) -> Controller:
        """A fresh controller for one run of ``simulation``."""
        values = dict(self.parameters)
        if self.use == 'demo':
            if setpoint is not None:
                values['joint'] = setpoint.joint
            return DemoController(DemoGains(**values), dt=simulation.settings.dt,
                                  joint_names=simulation.settings.joint_names, setpoint=setpoint)
        factory = resolve_callable(self.use, self.directory)
        return factory(setpoint, **values)


def resolve_callable(text: str, directory: str = '') -> Callable[..., Any]:
    """The callable 'package.module:name' names, the module looked for in ``directory``
    first (ImportError/AttributeError say why it is not there)."""
    module, _, name = text.partition(':')
    if directory and directory not in sys.path:
        sys.path.insert(0, directory)
    target: Any = importlib.import_module(module)
    for part in name.split('.'):
        target = getattr(target, part)
    if not callable(target):
        raise TypeError(f'{text} is not callable')
    return target


def read_controller(reader: YamlReader, node: yaml.Node) -> ControllerSpec:
    entries = reader.mapping(node, 'controller')
    reader.known(entries, CONTROLLER_KEYS, 'controller key')
    if 'use' not in entries:
        raise reader.error(node, "controller needs 'use': demo or module:callable")
    use_node = entries['use'][1]
    use = reader.value(use_node)
    if not isinstance(use, str) or (use != 'demo' and (
            use.count(':') != 1 or not all(use.split(':')))):
        raise reader.error(use_node, f"controller 'use' must be demo or module:callable, "
                           f'not {use!r}')
    parameters: dict[str, Any] = {}
    if 'parameters' in entries:
        pnode = entries['parameters'][1]
        pentries = reader.mapping(pnode, 'controller parameters')
        if use == 'demo':
            known = tuple(n for n in DemoGains.names() if n != 'joint')
            reader.known(pentries, known, 'demo controller parameter')
        parameters = {name: reader.value(value) for name, (_, value) in pentries.items()}
        if use == 'demo':
            try:
                DemoGains(**parameters)
            except (TypeError, ValueError) as exc:
                raise reader.error(pnode, str(exc)) from None
    directory = str(reader.path.resolve().parent)
    if use != 'demo':
        try:
            resolve_callable(use, directory)
        except Exception as exc:  # noqa: BLE001 - any import failure is the file's problem
            raise reader.error(use_node, f'controller {use!r} cannot be loaded: '
                               f'{type(exc).__name__}: {exc}') from None
    return ControllerSpec(use, tuple(parameters.items()), use_node.start_mark.line + 1,
                          directory)


__all__ = ['CONTROLLER_KEYS', 'ControllerSpec', 'read_controller', 'resolve_callable']
