"""The launch files: light to load, and ros2_control.launch.py refuses to start anything
when a package it needs is missing.

* What the ``ros2 launch`` process imports: the launch files import only launch,
  launch_ros, ament_index_python and :mod:`screwgear_ros.ros.launch_support`, which
  pulls in no numba, rclpy or model (checked in a fresh interpreter). launch and
  launch_ros have no wheel on PyPI: the tests' overlay of the real ones
  (test/support/ros2cli.py) loads each file's ``generate_launch_description()`` and its
  arguments (what ``ros2 launch --show-args`` prints) in a fresh interpreter too; where
  the overlay's wheels are not found, those tests are skipped with the reason.
* The package check: against a real ament index built in a temporary prefix and read by
  ament_index_python, no launch needed.
* The real ``ros2 launch`` of the overlay: ros2_control.launch.py on an install without
  ros2_control fails with one message naming every missing package, and no process
  outlives it.
"""

from __future__ import annotations

import ast
import os
import shutil
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import yaml
from ros2cli import (
    NEEDS_OVERLAY,
    overlay,
    ros2cli_overlay,  # noqa: F401  (the fixture NEEDS_OVERLAY uses)
)

from screwgear_ros.ros import launch_support as support

PACKAGE = 'screwgear_ros'
SHARE = Path(sys.prefix) / 'share' / PACKAGE
LAUNCH_FILES = ('table_sim.launch.py', 'ros2_control.launch.py')
#: What a launch file may import: the launch system and the light helper module.
LIGHT = ('os', 'ament_index_python', 'launch', 'launch_ros', 'screwgear_ros.ros.launch_support')
#: Modules that must not be loaded into the `ros2 launch` process by our files (rclpy is
#: not among them: launch_ros loads it anyway).
HEAVY = ('numba', 'llvmlite', 'scipy', 'matplotlib', 'screwgear_ros.physics.motion',
         'screwgear_ros.sim.plant', 'screwgear_ros.sim.session', 'screwgear_ros.view.urdf',
         'screwgear_ros.runs.run_io')
NEEDS_LAUNCH, USES_OVERLAY = NEEDS_OVERLAY


def _run(code: str, in_overlay: bool) -> str:
    """``code`` in a fresh interpreter (the overlay's, with launch and launch_ros, when
    ``in_overlay``); what it printed last."""
    python, env = ((str(overlay().python), overlay().env()) if in_overlay
                   else (sys.executable, None))
    proc = subprocess.run([python, '-P', '-c', code], capture_output=True, text=True,
                          check=False, timeout=120, env=env)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc.stdout.strip().splitlines()[-1]


def _loaded(code: str, heavy: tuple[str, ...] = HEAVY, in_overlay: bool = False) -> list[str]:
    """Run ``code`` in a fresh interpreter; the ``heavy`` modules it left loaded."""
    probe = (code + '\nimport sys\n'
             f'print(sorted(m for m in sys.modules if any(m == h or m.startswith(h + ".") '
             f'for h in {heavy!r})))\n')
    return ast.literal_eval(_run(probe, in_overlay))


@pytest.mark.parametrize('name', LAUNCH_FILES)
def test_launch_files_import_only_the_launch_system_and_the_light_helper(name):
    tree = ast.parse((SHARE / 'launch' / name).read_text(encoding='utf-8'))
    imported = [a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names]
    imported += [f'{n.module}.{a.name}' for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)
                 for a in n.names]
    assert imported
    for module in imported:
        assert any(module == ok or module.startswith(ok + '.') for ok in LIGHT), module


@pytest.mark.ros
def test_the_light_helper_loads_nothing_heavy():
    assert _loaded('import screwgear_ros.ros.launch_support', (*HEAVY, 'rclpy')) == []


@pytest.mark.ros
@NEEDS_LAUNCH
@USES_OVERLAY
@pytest.mark.parametrize('name', LAUNCH_FILES)
def test_generate_launch_description_and_its_arguments_load_nothing_heavy(name):
    code = ('import importlib.util\n'
            f'spec = importlib.util.spec_from_file_location("lf", {str(SHARE / "launch" / name)!r})\n'
            'module = importlib.util.module_from_spec(spec)\n'
            'spec.loader.exec_module(module)\n'
            'description = module.generate_launch_description()\n'
            'names = [a.name for a in description.get_launch_arguments()]\n'
            'assert names, names\n')
    assert _loaded(code, in_overlay=True) == []


@pytest.mark.ros
@NEEDS_LAUNCH
@USES_OVERLAY
def test_ros2_control_launch_arguments_and_the_namespace_default():
    code = ('import importlib.util\n'
            'spec = importlib.util.spec_from_file_location(\n'
            f'    "lf", {str(SHARE / "launch" / "ros2_control.launch.py")!r})\n'
            'module = importlib.util.module_from_spec(spec)\n'
            'spec.loader.exec_module(module)\n'
            'arguments = module.generate_launch_description().get_launch_arguments()\n'
            'print({a.name: [t.describe() for t in a.default_value] for a in arguments})\n')
    arguments = ast.literal_eval(_run(code, in_overlay=True))
    assert list(arguments) == ['namespace', 'params_file', 'record']
    from screwgear_ros.view.urdf import PLANT_NAMESPACE
    assert arguments['namespace'] == [repr(PLANT_NAMESPACE)]


# ------------------------------------------------------------------ the package check

def _prefix(root: Path, packages: dict[str, str | None],
            executables: dict[str, tuple[str, ...]] | None = None) -> Path:
    """A real ament prefix: index markers, a package.xml where a version is given, and
    executables in lib/<package>/ (by default those the needs name)."""
    if executables is None:
        executables = {n.package: n.executables for n in _needs()}
    index = root / 'share/ament_index/resource_index/packages'
    index.mkdir(parents=True)
    for name, version in packages.items():
        (index / name).write_text('')
        if version is not None:
            (root / 'share' / name).mkdir(parents=True)
            (root / 'share' / name / 'package.xml').write_text(
                f'<package format="3"><name>{name}</name><version>{version}</version>'
                '</package>')
        for exe in executables.get(name, ()):
            (root / 'lib' / name).mkdir(parents=True, exist_ok=True)
            (root / 'lib' / name / exe).write_text('#!/bin/sh\n')
            (root / 'lib' / name / exe).chmod(0o755)
    return root


def _processes() -> list[tuple[str, str]]:
    """The (package, executable) constants of ros2_control.launch.py, read from it."""
    tree = ast.parse((SHARE / 'launch' / 'ros2_control.launch.py').read_text(encoding='utf-8'))
    pairs = []
    for node in tree.body:
        if isinstance(node, ast.Assign) and isinstance(node.value, ast.Tuple) and \
                len(node.value.elts) == 2:
            value = ast.literal_eval(node.value)
            if all(isinstance(v, str) for v in value):
                pairs.append(value)
    return pairs


def _needs() -> list[support.Need]:
    return support.ros2_control_needs(
        _processes(),
        (SHARE / 'urdf/screwgear_table.urdf').read_text(encoding='utf-8'),
        (SHARE / 'config/ros2_control.yaml').read_text(encoding='utf-8'),
        (SHARE / 'package.xml').read_text(encoding='utf-8'))


def test_the_needs_are_the_plugins_of_the_urdf_and_yaml_and_all_are_exec_depends():
    needs = _needs()
    names = [n.package for n in needs]
    assert len(set(names)) == len(names)
    urdf = ET.parse(SHARE / 'urdf/screwgear_table.urdf').getroot()
    plugin = urdf.findtext('ros2_control/hardware/plugin').strip()
    manager = yaml.safe_load((SHARE / 'config/ros2_control.yaml').read_text())[
        'controller_manager']['ros__parameters']
    types = [v['type'] for v in manager.values() if isinstance(v, dict)]
    assert len(types) == 2
    for lookup_name in (plugin, *types):        # pluginlib's package/Class
        assert lookup_name.split('/')[0] in names, lookup_name
    # rosdep installs what package.xml declares: every need is declared there
    manifest = ET.parse(SHARE / 'package.xml').getroot()
    depends = {e.text: e.get('version_gte') for e in manifest.iter('exec_depend')}
    for need in needs:
        assert need.package in depends, need
        assert need.minimum == depends[need.package]
    assert any(n.minimum for n in needs)        # the topic plugin's version is declared


def test_a_bare_install_is_told_every_missing_package_and_how_to_install_it(tmp_path,
                                                                            monkeypatch):
    monkeypatch.setenv('AMENT_PREFIX_PATH', str(_prefix(tmp_path / 'p', {'rclpy': '7.1.6'})))
    needs = _needs()
    with pytest.raises(support.MissingPackages) as caught:
        support.require('ros2_control.launch.py', needs, str(SHARE))
    assert {n.package for n in needs} >= {'robot_state_publisher', 'controller_manager'}
    text = str(caught.value)
    assert 'nothing was started' in text
    for need in needs:
        assert f'{need.package}: not found' in text
        assert f'ros-jazzy-{need.package.replace("_", "-")}' in text
    assert f'rosdep install --from-paths {SHARE} --ignore-src -y' in text


def test_too_old_a_plugin_is_refused_and_present_packages_are_not_named(tmp_path,
                                                                        monkeypatch):
    needs = _needs()
    versioned = next(n for n in needs if n.minimum)
    old = '0.2.1'                               # a Jazzy release of the topic plugin
    assert support._version(old) < support._version(versioned.minimum)
    present = {n.package: '99.0.0' for n in needs}
    present[versioned.package] = old
    missing = needs[0].package
    del present[missing]
    monkeypatch.setenv('AMENT_PREFIX_PATH', str(_prefix(tmp_path / 'p', present)))
    problems = support.unmet(needs, support.installed_version)
    assert {(p.need.package, p.found) for p in problems} == {(missing, None),
                                                            (versioned.package, old)}
    text = support.message('x.launch.py', problems, str(SHARE))
    assert f'{versioned.package}: {old} installed, needs >= {versioned.minimum}' in text
    present[versioned.package] = versioned.minimum
    monkeypatch.setenv('AMENT_PREFIX_PATH', str(_prefix(tmp_path / 'q', present)))
    assert [p.need.package for p in support.unmet(needs, support.installed_version)] == \
        [missing]


def test_a_package_without_the_executable_launch_would_start_is_named(tmp_path,
                                                                    monkeypatch):
    """What launch would fail on only after table_sim had been started."""
    needs = _needs()
    with_exes = [n for n in needs if n.executables]
    assert {e for n in with_exes for e in n.executables} >= {
        'robot_state_publisher', 'ros2_control_node', 'spawner'}
    lacking = with_exes[0]
    present = {n.package: n.minimum or '1.0.0' for n in needs}
    executables = {n.package: n.executables for n in needs}
    executables[lacking.package] = lacking.executables[1:]
    monkeypatch.setenv('AMENT_PREFIX_PATH',
                       str(_prefix(tmp_path / 'p', present, executables)))
    problems = support.unmet(needs, support.installed_version, support.installed_executable)
    assert [(p.need.package, p.missing_executables) for p in problems] == [
        (lacking.package, lacking.executables[:1])]
    assert f'installed without {lacking.executables[0]}' in str(problems[0])
    monkeypatch.setenv('AMENT_PREFIX_PATH', str(_prefix(tmp_path / 'q', present)))
    assert support.unmet(needs, support.installed_version, support.installed_executable) == []


def test_versions_compare_as_numbers():
    need = support.Need('x', '1.9.0')
    assert support.unmet([need], {'x': '1.10.0'}.get) == []
    assert support.unmet([need], {'x': '1.8.12'}.get) == [support.Unmet(need, '1.8.12')]
    assert support.unmet([need], {}.get) == [support.Unmet(need, None)]
    assert support.unmet([support.Need('x')], {'x': '0.0.1'}.get) == []


# ------------------------------------------------------------------ namespace

def test_the_urdf_is_pointed_at_another_namespace_and_never_at_the_root():
    from screwgear_ros.interface import topic_names
    from screwgear_ros.view.urdf import PLANT_NAMESPACE
    shipped = (SHARE / 'urdf/screwgear_table.urdf').read_text(encoding='utf-8')
    assert support.urdf_namespace(shipped) == PLANT_NAMESPACE
    assert support.in_namespace(shipped, PLANT_NAMESPACE.strip('/')) == shipped
    moved = support.in_namespace(shipped, 'axis_c')
    params = {e.get('name'): e.text for e in
              ET.fromstring(moved).iterfind('ros2_control/hardware/param')}
    node = topic_names('/axis_c')               # what table_sim in /axis_c subscribes to
    assert params['joint_commands_topic'] == node['joint_commands']
    assert params['joint_states_topic'] == node['joint_states']
    assert support.urdf_namespace(moved) == '/axis_c'
    for root in ('', '/', ' / '):
        with pytest.raises(ValueError, match='joint_state_broadcaster'):
            support.in_namespace(shipped, root)


# ------------------------------------------------------------------ ros2 launch, for real

def _processes_with(marker: str) -> list[tuple[int, str]]:
    found = []
    for entry in Path('/proc').iterdir():
        if not entry.name.isdigit():
            continue
        try:
            cmdline = (entry / 'cmdline').read_bytes().replace(b'\0', b' ').decode()
        except OSError:
            continue
        if marker in cmdline and int(entry.name) != os.getpid():
            found.append((int(entry.name), cmdline))
    return found


@pytest.mark.ros
@NEEDS_LAUNCH
@USES_OVERLAY
def test_ros2_launch_without_ros2_control_starts_nothing_and_names_every_package(tmp_path):
    needs = [n.package for n in _needs()]
    if not support.unmet(_needs(), support.installed_version):
        pytest.skip('ros2_control is installed here: nothing is missing')
    params = tmp_path / 'marker_params.yaml'              # a mark on table_sim's command line
    shutil.copy(SHARE / 'config/paper.yaml', params)
    proc = overlay().run('launch', PACKAGE, 'ros2_control.launch.py',
                         f'params_file:={params}', check=False, timeout=120)
    out = proc.stdout + proc.stderr
    assert proc.returncode != 0, out
    for name in needs:
        if support.installed_version(name) is None:
            assert f'{name}: not found' in out, out
    deadline = time.monotonic() + 5.0
    while _processes_with(str(params)) and time.monotonic() < deadline:
        time.sleep(0.1)
    left = _processes_with(str(params))
    for pid, _ in left:                       # never leave one behind, even failing
        os.kill(pid, signal.SIGTERM)
    assert left == []
    assert 'table_sim' not in out.split('nothing was started')[0]
