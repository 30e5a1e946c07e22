"""Old import paths of modules that moved into sub-packages, kept for one release.

``import screwgear_ros.simulation`` still works and gives the very module
``screwgear_ros.inprocess.simulation`` (the same object, so ``isinstance`` and pickling hold),
with a :class:`DeprecationWarning` naming the new path. The finder is installed by the
package's ``__init__`` and answers only for the names below.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
import warnings
from types import ModuleType

#: Old module path (below ``screwgear_ros``) -> where it lives now.
MOVED: dict[str, str] = {
    'batch': 'paper.batch',
    'cdr': 'bag.cdr',
    'commands': 'sim.commands',
    'control': 'sim.control',
    'declare': 'params.declarations',
    'dop853': 'numerics.dop853',
    'energy': 'sim.energy',
    'events': 'sim.events',
    'floquet': 'paper.floquet',
    'friction': 'physics.friction',
    'gym': 'envs.table_env',
    'integrator': 'numerics.integrator',
    'jit': 'physics.jit',
    'layout': 'view.layout',
    'metrics': 'inprocess.metrics',
    'normalized': 'paper.normalized',
    'pacing': 'sim.pacing',
    'parameter_docs': 'params.docs',
    'parameter_sets': 'sim.parameter_file',
    'plant': 'sim.plant',
    'quantities': 'physics.quantities',
    'ratelimit': 'sim.ratelimit',
    'reference': 'numerics.reference',
    'report': 'paper',
    'report.antibacklash': 'paper.antibacklash',
    'report.builder': 'paper.builder',
    'report.common': 'paper.common',
    'report.damping': 'paper.damping',
    'report.derived': 'paper.derived',
    'report.design': 'paper.design',
    'report.energy': 'paper.energy',
    'report.fluctuation': 'paper.fluctuation',
    'report.index': 'paper.index',
    'report.measures': 'paper.measures',
    'report.response': 'paper.response',
    'report.stability': 'paper.stability',
    'report.steady': 'paper.steady',
    'report.stiffness': 'paper.stiffness',
    'report.summary': 'paper.summary',
    'report.thermal': 'paper.thermal',
    'report.validation': 'paper.validation',
    'rk': 'numerics.rk',
    'run_parameters': 'sim.run_file',
    'runs.bagformat': 'bag.format',
    'runs.bagread': 'bag.reader',
    'runs.mcap_writer': 'bag.mcap_writer',
    'runs.recorder': 'bag.recorder',
    'runs.replay': 'inprocess.replay_compat',
    'runs.replay_plan': 'runs.lockstep_plan',
    'ros.markers': 'view.markers',
    'ros.replaying': 'ros.node_replay',
    'ros.run_io': 'runs.run_io',
    'ros.session_record': 'runs.session_record',
    'ros.urdf': 'view.urdf',
    'scenario': 'inprocess.scenario',
    'schedule': 'sim.schedule',
    'sensors': 'physics.sensors',
    'session': 'sim.session',
    'simtime': 'sim.simtime',
    'simulation': 'inprocess.simulation',
    'stability': 'numerics.stability',
    'status': 'sim.status',
    'warmup': 'cli.warmup',
    'yaml_reader': 'params.yaml_reader',
}


class _Alias(importlib.abc.Loader):
    """Loads an old name as the module at its new path."""

    def __init__(self, new: str) -> None:
        self.new = new

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        warnings.warn(f'{spec.name} moved to {self.new}; the old path goes in the next '
                      'release', DeprecationWarning, stacklevel=2)
        return importlib.import_module(self.new)

    def exec_module(self, module: ModuleType) -> None:
        """The module is already executed under its new name."""


class _MovedFinder(importlib.abc.MetaPathFinder):
    """Finds the old names of moved modules, and nothing else."""

    def __init__(self, package: str) -> None:
        self.prefix = package + '.'
        self.package = package

    def find_spec(self, fullname: str, path: object = None,
                  target: object = None) -> importlib.machinery.ModuleSpec | None:
        if not fullname.startswith(self.prefix):
            return None
        new = MOVED.get(fullname[len(self.prefix):])
        if new is None:
            return None
        return importlib.machinery.ModuleSpec(fullname, _Alias(f'{self.package}.{new}'))


def install(package: str) -> None:
    """Answer the old module paths of ``package`` (idempotent)."""
    if not any(isinstance(f, _MovedFinder) for f in sys.meta_path):
        sys.meta_path.append(_MovedFinder(package))
