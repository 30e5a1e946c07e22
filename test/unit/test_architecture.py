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
from paths import ROOT as REPOSITORY  # the checkout; ROOT below is the package under test

import screwgear_ros

PACKAGE = 'screwgear_ros'
ROOT = Path(screwgear_ros.__file__).parent
SHELL = (f'{PACKAGE}.ros', f'{PACKAGE}.cli')
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
    # ``if TYPE_CHECKING:`` imports are read by the type checker only, never run
    typing_only = {id(inner) for node in ast.walk(tree)
                   if isinstance(node, ast.If) and isinstance(node.test, ast.Name)
                   and node.test.id == 'TYPE_CHECKING'
                   for inner in ast.walk(node)}
    found = []
    for node in ast.walk(tree):
        if id(node) in typing_only:
            continue
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
    assert {f'{PACKAGE}.params.table', f'{PACKAGE}.runs.run_io', f'{PACKAGE}.bag.reader'} <= set(
        MODULES)
    assert (f'{PACKAGE}.runs.session_record', True) in IMPORTS[f'{PACKAGE}.inprocess.simulation']
    assert ('rclpy', False) in [(t.split('.')[0], lazy) for t, lazy in
                                IMPORTS[f'{PACKAGE}.ros.node']]


def test_no_module_import_cycle():
    cycles = sorted(f'{name} → … → {name}' for name in MODULES if name in _reach(name, set()))
    assert not cycles, 'import cycles:\n' + '\n'.join(cycles)


@pytest.mark.parametrize('name', sorted(n for n in MODULES if n.startswith((f'{PACKAGE}.runs', f'{PACKAGE}.bag'))))
def test_runs_never_reach_the_ros_shell_or_the_tools(name):
    reached = sorted(n for n in _reach(name, set()) if _in_shell(n))
    assert not reached, f'{name} imports (through the package) {reached}'


@pytest.mark.parametrize('name', sorted(n for n in MODULES if not _in_shell(n)))
def test_the_core_imports_no_ros(name):
    reached = {name, *_reach(name, set())}
    found = sorted({f'{n} imports {t}' for n in reached for t, _ in IMPORTS[n]
                    if t not in MODULES and _ros_package(t)}
                   | {f'{n} is part of the ROS shell' for n in reached if _in_shell(n)})
    assert not found, '\n'.join(found)


def test_no_issue_numbers_in_the_package():
    found = [f'{path.relative_to(ROOT.parent)}:{number}: {line.strip()}'
             for path in MODULES.values()
             for number, line in enumerate(path.read_text(encoding='utf-8').splitlines(), 1)
             if re.search(r'\bissue [0-9]', line, re.IGNORECASE)]
    assert not found, '\n'.join(found)


def _folder(name: str) -> str:
    """The sub-package a module belongs to (the package itself for root modules)."""
    parts = name.split('.')
    return '.'.join(parts[:2]) if len(parts) > 2 or MODULES[name].name == '__init__.py' else PACKAGE


def test_no_folder_import_cycle():
    """Sub-packages import each other along one direction only (lazy imports included):
    the folder tree is the architecture's layering."""
    edges = {(_folder(a), _folder(b)) for a, targets in GRAPH.items() for b in targets
             if _folder(a) != _folder(b) and PACKAGE not in (_folder(a), _folder(b))}
    folders = {f for edge in edges for f in edge}
    reach = {f: {b for a, b in edges if a == f} for f in folders}
    changed = True
    while changed:
        changed = False
        for f in folders:
            more = set().union(*(reach[g] for g in reach[f])) - reach[f]
            if more:
                reach[f] |= more
                changed = True
    cycles = sorted(f for f in folders if f in reach[f])
    paths = sorted(f'{a} → {b}' for a, b in edges if a in cycles and b in cycles and a in reach[b])
    assert not cycles, 'folders in an import cycle:\n' + '\n'.join(paths)


def test_the_root_holds_only_the_public_face():
    root = sorted(p.name for p in ROOT.glob('*.py') if p.name != '__init__.py')
    assert len(root) <= 6, f'{len(root)} modules at the package root: {root}'


def test_every_module_has_one_job_and_at_most_450_lines():
    long = sorted(f'{p.relative_to(ROOT.parent)}: {n}' for p in MODULES.values()
                  if (n := len(p.read_text(encoding='utf-8').splitlines())) > 450)
    assert not long, 'split by job:\n' + '\n'.join(long)


def _string_comparisons(tree: ast.AST, values: set[str]) -> list[tuple[int, str]]:
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Compare):
            operands = [node.left, *node.comparators]
        elif isinstance(node, ast.match_case) and isinstance(node.pattern, ast.MatchValue):
            operands = [node.pattern.value]
        else:
            continue
        for operand in operands:
            items = operand.elts if isinstance(operand, (ast.Tuple, ast.List, ast.Set)) else [operand]
            found += [(node.lineno if hasattr(node, 'lineno') else operand.lineno, item.value)
                      for item in items
                      if isinstance(item, ast.Constant) and item.value in values]
    return found


def test_no_input_name_is_compared_as_a_string():
    """Inputs are compared with :class:`screwgear_ros.interface.Input` members; a string
    literal would not follow a rename of the input."""
    from screwgear_ros.interface import Input
    values = {member.value for member in Input}
    found = [f'{path.relative_to(ROOT.parent)}:{line}: {value!r}'
             for name, path in MODULES.items() if name != f'{PACKAGE}.interface'
             for line, value in _string_comparisons(ast.parse(path.read_text(encoding='utf-8')),
                                                    values)]
    assert not found, 'compare with interface.Input instead:\n' + '\n'.join(found)


def test_the_string_comparison_finder_sees_what_it_must():
    tree = ast.parse("a == 'cmd_effort'\nb in ('x', 'cmd_torque')\nmatch c:\n    case 'setpoint': pass\n"
                     "d == 'other'\n")
    assert [v for _, v in _string_comparisons(tree, {'cmd_effort', 'cmd_torque', 'setpoint'})] \
        == ['cmd_effort', 'cmd_torque', 'setpoint']


def test_every_exception_derives_from_the_package_error_base():
    import importlib

    from screwgear_ros.errors import ScrewgearError
    outside = []
    for name in MODULES:
        if _in_shell(name):
            continue  # the shell imports rclpy at module level; checked below by source
        module = importlib.import_module(name)
        outside += [f'{name}.{obj.__name__}' for obj in vars(module).values()
                    if isinstance(obj, type) and issubclass(obj, BaseException)
                    and obj.__module__ == name and not issubclass(obj, ScrewgearError)]
    for name in MODULES:
        if not _in_shell(name):
            continue
        tree = ast.parse(MODULES[name].read_text(encoding='utf-8'))
        for node in tree.body:
            if isinstance(node, ast.ClassDef) and any(
                    isinstance(b, ast.Name) and (b.id.endswith(('Error', 'Exception')) or b.id in
                                                 ('Exception', 'ValueError', 'RuntimeError'))
                    for b in node.bases):
                module = importlib.import_module(name)
                if not issubclass(getattr(module, node.name), ScrewgearError):
                    outside.append(f'{name}.{node.name}')
    assert not outside, 'derive from screwgear_ros.errors.ScrewgearError:\n' + '\n'.join(outside)


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


#: Module paths the package had before its sub-packages (the package has had no release, so
#: nothing answers for them): each must stay unimportable, not come back as an alias.
OLD_PATHS = (
    'batch', 'cdr', 'commands', 'control', 'declare', 'dop853', 'energy', 'events', 'floquet',
    'friction', 'gym', 'integrator', 'jit', 'layout', 'metrics', 'model', 'normalized',
    'pacing', 'parameter_docs', 'parameter_sets', 'plant', 'quantities', 'ratelimit',
    'reference', 'report', 'report.antibacklash', 'report.builder', 'report.common',
    'report.damping', 'report.derived', 'report.design', 'report.energy', 'report.fluctuation',
    'report.index', 'report.measures', 'report.response', 'report.stability', 'report.steady',
    'report.stiffness', 'report.summary', 'report.thermal', 'report.validation', 'rk',
    'run_parameters', 'runs.bagformat', 'runs.bagread', 'runs.mcap_writer', 'runs.recorder',
    'runs.replay', 'runs.replay_plan', 'ros.markers', 'ros.replaying', 'ros.run_io',
    'ros.session_record', 'ros.urdf', 'scenario', 'schedule', 'sensors', 'session', 'simtime',
    'simulation', 'stability', 'status', 'warmup', 'yaml_reader',
)

#: Modules whose deprecated names other changes of the same issue remove; each must still
#: hold one (a stale entry fails), so the set empties as they land.
DEPRECATIONS_BEING_REMOVED: set[str] = set()


def test_the_old_module_paths_are_gone():
    """No finder, module or alias answers an old path: an import of one fails."""
    import importlib.util

    answered = []
    for old in OLD_PATHS:
        try:
            spec = importlib.util.find_spec(f'{PACKAGE}.{old}')
        except ModuleNotFoundError:          # its parent package is gone too
            spec = None
        if spec is not None:
            answered.append(f'{PACKAGE}.{old} ({spec.origin or spec.loader})')
    assert not answered, 'old module paths still answer:\n' + '\n'.join(answered)


def test_no_module_keeps_a_deprecated_name():
    """The package has had no release: a name that moved is updated at every caller, not
    kept behind a DeprecationWarning or an import hook."""
    found = set()
    for name, path in MODULES.items():
        for node in ast.walk(ast.parse(path.read_text(encoding='utf-8'))):
            if ((isinstance(node, ast.Name) and node.id == 'DeprecationWarning')
                    or (isinstance(node, ast.Attribute) and node.attr == 'meta_path')):
                found.add(name)
    assert found == DEPRECATIONS_BEING_REMOVED, (
        f'deprecated names kept in {sorted(found - DEPRECATIONS_BEING_REMOVED)}; '
        f'removed, so drop from DEPRECATIONS_BEING_REMOVED: '
        f'{sorted(DEPRECATIONS_BEING_REMOVED - found)}')


def _documented_order() -> list[str]:
    """The folders of docs/architecture.md's table "The folders, bottom to top", in its
    order: each may import only the folders on rows above its own."""
    doc = (REPOSITORY / 'docs' / 'architecture.md').read_text(encoding='utf-8')
    section = doc.split('## The folders, bottom to top', 1)[1].split('\n## ', 1)[0]
    return [f'{PACKAGE}.{m.group(1)}' for m in re.finditer(r'^\| `(\w+)/` \|', section, re.MULTILINE)]


def test_every_folder_imports_only_the_folders_the_doc_puts_above_it():
    """The documented order itself, not only the absence of cycles: an import from a folder
    the table puts below (or beside, on a later row) is a layering the doc does not show."""
    order = _documented_order()
    assert len(order) >= 10, f'the table of docs/architecture.md was not read: {order}'
    rank = {folder: i for i, folder in enumerate(order)}
    actual = {_folder(name) for name in MODULES} - {PACKAGE}
    assert actual == set(order), ('folders missing from the doc\'s table, or named there and '
                                  f'gone: {sorted(actual ^ set(order))}')
    wrong = sorted(f'{a} imports {b}' for a, targets in GRAPH.items() for b in targets
                   if PACKAGE not in (_folder(a), _folder(b)) and _folder(a) != _folder(b)
                   and rank[_folder(b)] > rank[_folder(a)])
    assert not wrong, 'imports against docs/architecture.md\'s folder order:\n' + '\n'.join(wrong)
