"""The controller a scenario names (``controller:`` in a scenario file): ``demo``, the demo
law, or ``module:callable`` of the user's, resolved as ``python -m`` would from the
scenario's directory."""

from __future__ import annotations

import importlib
import numbers
import sys
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import yaml

from ..errors import ScrewgearError
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
        return make_checked(f'controller {self.use} (line {self.line})', factory, setpoint,
                            **values)


class ControllerFailed(ScrewgearError, RuntimeError):
    """A user's controller (or its factory) raised, or answered with something that is no
    effort; the message names the controller, the tick and the rule."""


#: What a controller must answer, said in every refusal of an answer.
ANSWER_RULE = ('a controller answers each observation with the signed drive torque in N·m '
               '(a real number) or None (no command this tick)')


def _where(exc: BaseException) -> str:
    """The file and line of the innermost frame of ``exc``'s traceback (the user's own
    code, where the failure is)."""
    frames = traceback.extract_tb(exc.__traceback__)
    return f' ({frames[-1].filename}, line {frames[-1].lineno})' if frames else ''


def make_checked(name: str, factory: Callable[..., Any], *args: Any,
                 **kwargs: Any) -> CheckedController:
    """``factory(*args, **kwargs)`` as a :class:`CheckedController` named ``name``; a
    factory that raises or returns no callable is a :class:`ControllerFailed`.

    Examples
    --------
    >>> make_checked('mine', lambda setpoint: (lambda obs: 1.0), None).name
    'mine'
    """
    try:
        controller = factory(*args, **kwargs)
    except ScrewgearError:
        raise
    except Exception as exc:  # noqa: BLE001 - the user's code: named, not shown raw
        raise ControllerFailed(f'{name}: its factory raised {type(exc).__name__}: {exc}'
                               f'{_where(exc)}; a factory returns the controller, a '
                               'callable') from None
    return CheckedController(name, controller)


class CheckedController:
    """A user's controller whose failures are named (:class:`ControllerFailed`): one that
    raises, by its exception, tick and line; one that answers anything but a real number
    or None (text, a list), by the answer and :data:`ANSWER_RULE`. The value of a number
    is the session's to judge, as the node judges a message.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> checked = CheckedController('mine', lambda obs: 'left')
    >>> try:
    ...     checked(SimpleNamespace(step=3, time=0.003))
    ... except ControllerFailed as exc:
    ...     print(str(exc)[:47])
    mine answered 'left' (str) at t = 0.003 s (step
    """

    __slots__ = ('controller', 'name')

    def __init__(self, name: str, controller: Any) -> None:
        if not callable(controller):
            raise ControllerFailed(f'{name}: the factory returned {controller!r:.60} '
                                   f'({type(controller).__name__}), not a controller: '
                                   f'{ANSWER_RULE}')
        self.name, self.controller = name, controller

    def __call__(self, observation: Any) -> Any:
        try:
            effort = self.controller(observation)
        except ScrewgearError:
            raise
        except Exception as exc:  # noqa: BLE001 - the user's code: named, not shown raw
            raise ControllerFailed(f'{self.name} raised {type(exc).__name__} at t = '
                                   f'{observation.time:.6g} s (step {observation.step}): '
                                   f'{exc}{_where(exc)}') from None
        if effort is None or type(effort) is float or (
                isinstance(effort, numbers.Real) and not isinstance(effort, bool)):
            return effort
        raise ControllerFailed(f'{self.name} answered {effort!r:.60} '
                               f'({type(effort).__name__}) at t = {observation.time:.6g} s '
                               f'(step {observation.step}): {ANSWER_RULE}')


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


__all__ = ['ANSWER_RULE', 'CONTROLLER_KEYS', 'CheckedController', 'ControllerFailed',
           'ControllerSpec', 'make_checked', 'read_controller', 'resolve_callable']
