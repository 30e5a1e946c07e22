"""screwgear_ros: a real-time ROS 2 plant of a double screw gear anti-backlash rotary table.

The physics core (params, model, integrator, reference, normalized, plant) imports no
ROS; the node and command-line tools in this package drive it. The Python API
(``screwgear_ros.Simulation``, :mod:`screwgear_ros.inprocess.simulation`) runs the node's own
simulation loop in-process, without ROS; its names are imported on first use, so that
``import screwgear_ros`` alone loads neither ROS nor the compiled model.
"""

from importlib import import_module
from typing import Any

__version__ = '0.2.0'

#: Public names and the module that defines each.
_API = {
    'Simulation': 'inprocess.simulation', 'Observation': 'inprocess.simulation',
    'Run': 'inprocess.simulation',
    'InputRejected': 'sim.commands', 'ParameterError': 'params.table',
    'TableParams': 'params.table', 'SimSettings': 'params.table',
    'Scenario': 'inprocess.scenario', 'load_scenario': 'inprocess.scenario',
    'ScenarioError': 'inprocess.scenario',
    'run_metrics': 'inprocess.metrics', 'Metrics': 'inprocess.metrics',
    'DemoController': 'sim.control', 'config_path': 'params.config_files',
    'identify': 'identification', 'IdentifyResult': 'identification',
    'IdentifyError': 'identification',
}


def __getattr__(name: str) -> Any:
    module = _API.get(name)
    if module is None:
        raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
    value = getattr(import_module(f'.{module}', __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_API])


__all__ = ['__version__', *_API]  # noqa: PLE0604 (_API's keys are the names)
