"""The package's layering, read from its source with ``ast`` (imports inside functions
included, since a lazy import is still a dependency): no module cycle; ``runs/`` never
reaches the ROS shell (``ros/``) or the tools (``cli/``); and no core module (outside
``ros/`` and ``cli/``) imports rclpy or a ROS message package, directly or through
another module of the package. And no source line names an issue: the code says why,
and history (which issue, what it replaced) goes stale there.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

import screwgear_ros

PACKAGE = 'screwgear_ros'
ROOT = Path(screwgear_ros.__file__).parent
SHELL = (f'{PACKAGE}.ros', f'{PACKAGE}.cli')
#: Where the core reaches into the ROS shell on purpose, each only inside the function
#: that needs it (so importing the core never loads ROS), with the reason.
LAZY_SHELL_EDGES = {
    (f'{PACKAGE}.sim.simulation', f'{PACKAGE}.ros.session_record'):
        "Simulation.run(record=...) writes the node's own messages: rclpy's message "
        'packages, loaded only when a run is recorded',
}


def _ros_package(top: str) -> bool:
    """A top-level import that is part of ROS 2 itself (rclpy, rosidl, a message
    package), not a pure-Python reader of its formats such as rosbags or mcap."""
    return (top.startswith(('rclpy', 'rcl_', 'rosidl', 'rmw', 'ament_', 'launch'))
            or top.endswith(('_msgs', '_srvs', '_interfaces')))


def _modules() -> dict[str, Path]:
    found = {}
    for path in ROOT.rglob('*.py'):
        parts = path.relative_to(ROOT.parent).with_suffix('').parts
        name = '.'.join(parts[:-1] if parts[-1] == '__init__' else parts)
        found[name] = path
    return found


MODULES = _modules()


def _imports(name: str) -> list[tuple[str, bool]]:
    """(imported module, lazy) for every import statement of module ``name``: package
    modules by full name, others by their top-level name."""
    path = MODULES[name]
    package = name if path.name == '__init__.py' else name.rpartition('.')[0]
    tree = ast.parse(path.read_text(encoding='utf-8'))
    lazy_nodes = {id(inner) for node in ast.walk(tree)
                  if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
                  for inner in ast.walk(node)}
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ''
            if node.level:
                anchor = package.split('.')
                anchor = anchor[:len(anchor) - node.level + 1]
                base = '.'.join(anchor + ([base] if base else []))
            targets = [f'{base}.{alias.name}' if f'{base}.{alias.name}' in MODULES else base
                       for alias in node.names]
        else:
            continue
        for target in targets:
            while target not in MODULES and '.' in target and target.startswith(PACKAGE):
                target = target.rpartition('.')[0]
            if target.startswith(PACKAGE) and target != name:
                found.append((target, id(node) in lazy_nodes))
            elif not target.startswith(PACKAGE):
                found.append((target.split('.')[0], id(node) in lazy_nodes))
    return found


IMPORTS = {name: _imports(name) for name in MODULES}
GRAPH = {name: {t for t, _ in found if t in MODULES} for name, found in IMPORTS.items()}


def _in_shell(name: str) -> bool:
    return name.startswith(tuple(f'{s}.' for s in SHELL)) or name in SHELL


def _reach(start: str, cut: set[tuple[str, str]]) -> set[str]:
    seen, todo = set(), [start]
    while todo:
        name = todo.pop()
        for target in GRAPH[name]:
            if target not in seen and (name, target) not in cut:
                seen.add(target)
                todo.append(target)
    return seen


def test_the_walk_sees_the_package_and_its_lazy_imports():
    assert {f'{PACKAGE}.params.table', f'{PACKAGE}.ros.run_io', f'{PACKAGE}.bag.reader'} <= set(
        MODULES)
    assert (f'{PACKAGE}.ros.session_record', True) in IMPORTS[f'{PACKAGE}.sim.simulation']
    assert ('rclpy', False) in [(t.split('.')[0], lazy) for t, lazy in
                                IMPORTS[f'{PACKAGE}.ros.run_io']]


def test_no_module_import_cycle():
    cycles = sorted(f'{name} → … → {name}' for name in MODULES if name in _reach(name, set()))
    assert not cycles, 'import cycles:\n' + '\n'.join(cycles)


@pytest.mark.parametrize('name', sorted(n for n in MODULES if n.startswith((f'{PACKAGE}.runs', f'{PACKAGE}.bag'))))
def test_runs_never_reach_the_ros_shell_or_the_tools(name):
    reached = sorted(n for n in _reach(name, set(LAZY_SHELL_EDGES)) if _in_shell(n))
    assert not reached, f'{name} imports (through the package) {reached}'


@pytest.mark.parametrize('name', sorted(n for n in MODULES if not _in_shell(n)))
def test_the_core_imports_no_ros(name):
    reached = {name, *_reach(name, set(LAZY_SHELL_EDGES))}
    found = sorted({f'{n} imports {t}' for n in reached for t, _ in IMPORTS[n]
                    if t not in MODULES and _ros_package(t)}
                   | {f'{n} is part of the ROS shell' for n in reached if _in_shell(n)})
    assert not found, '\n'.join(found)


@pytest.mark.parametrize('edge', sorted(LAZY_SHELL_EDGES))
def test_the_cores_way_into_the_shell_is_lazy_and_still_needed(edge):
    importer, target = edge
    kinds = {lazy for t, lazy in IMPORTS[importer] if t == target}
    assert kinds == {True}, f'{importer} must import {target} only inside a function'


def test_no_issue_numbers_in_the_package():
    found = [f'{path.relative_to(ROOT.parent)}:{number}: {line.strip()}'
             for path in MODULES.values()
             for number, line in enumerate(path.read_text(encoding='utf-8').splitlines(), 1)
             if re.search(r'\bissue [0-9]', line, re.IGNORECASE)]
    assert not found, '\n'.join(found)


#: The one class the tools' package holds: the error ladder their main() functions share.
CLI_CLASSES = {f'{PACKAGE}.cli': {'Failures'}}


@pytest.mark.parametrize('name', sorted(n for n in MODULES if n == f'{PACKAGE}.cli'
                                        or n.startswith(f'{PACKAGE}.cli.')))
def test_the_tools_hold_only_their_main_functions(name):
    """A node, a loop or a report belongs in ros/ or its sub-package; cli/ parses the
    command line and calls it."""
    tree = ast.parse(MODULES[name].read_text(encoding='utf-8'))
    classes = {node.name for node in tree.body if isinstance(node, ast.ClassDef)}
    assert classes <= CLI_CLASSES.get(name, set()), f'{name} defines {sorted(classes)}'
