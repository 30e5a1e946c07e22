"""The installed package is a real ROS 2 ament_python package.

Checks the pip/venv install this test run uses (ament index marker, package.xml,
launchers where `ros2 run` looks), the package manifest and setup.cfg in the source
tree, that the physics core imports no ROS, and the colcon route: colcon-core,
colcon-ros and colcon-python-setup-py from PyPI build a copy of the package.
"""

from __future__ import annotations

import ast
import configparser
import importlib
import importlib.metadata
import importlib.util
import os
import py_compile
import re
import shutil
import stat
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import yaml
from paths import ROOT, setup_executables

PACKAGE = 'screwgear_ros'
SOURCE = ROOT
PREFIX = Path(sys.prefix)
EXECUTABLES = setup_executables()
REQUIRED_EXEC_DEPENDS = {'rclpy', 'std_msgs', 'sensor_msgs', 'rosgraph_msgs', 'diagnostic_msgs',
                         'python3-numpy'}


def _executable(path: Path) -> bool:
    return path.is_file() and bool(path.stat().st_mode & stat.S_IXUSR)


def test_installed_ament_index_marker_and_share(monkeypatch):
    marker = PREFIX / 'share/ament_index/resource_index/packages' / PACKAGE
    assert marker.is_file()
    share = PREFIX / 'share' / PACKAGE
    assert (share / 'package.xml').read_bytes() == (SOURCE / 'package.xml').read_bytes()
    assert {f.name for f in (share / 'config').glob('*.yaml')} >= {'paper.yaml',
                                                                  'paper_normalized.yaml'}
    # the ament index itself (the library `ros2 run` / `ros2 pkg` use) finds it here
    from ament_index_python.packages import get_package_prefix, get_package_share_directory
    monkeypatch.setenv('AMENT_PREFIX_PATH', str(PREFIX))
    assert Path(get_package_prefix(PACKAGE)) == PREFIX
    assert Path(get_package_share_directory(PACKAGE)) == share


def test_urdf_launch_files_and_ros2_control_config_are_installed():
    share = PREFIX / 'share' / PACKAGE
    for name in ('urdf/screwgear_table.urdf', 'config/ros2_control.yaml',
                 'launch/table_sim.launch.py', 'launch/ros2_control.launch.py'):
        assert (share / name).read_bytes() == (SOURCE / name).read_bytes(), name


def test_installed_config_loads_to_the_defaults():
    from screwgear_ros.params.table import SimSettings, TableParams
    from screwgear_ros.sim.parameter_file import load_yaml
    assert load_yaml(PREFIX / 'share' / PACKAGE / 'config/paper.yaml') == (TableParams(),
                                                                           SimSettings())


@pytest.mark.ros
@pytest.mark.parametrize('exe', EXECUTABLES)
def test_launchers_where_ros2_run_looks(exe):
    """$prefix/lib/screwgear_ros/<exe> is executable and execs the console script in bin/."""
    launcher = PREFIX / 'lib' / PACKAGE / exe
    assert _executable(launcher)
    text = launcher.read_text(encoding='utf-8')
    assert text.startswith('#!/bin/sh') and f'/../../bin/{exe}"' in text
    assert _executable(PREFIX / 'bin' / exe)
    assert subprocess.run(['sh', '-n', str(launcher)], check=False).returncode == 0


@pytest.mark.ros
@pytest.mark.parametrize('exe', ('check_run', 'replay_run', 'paper_report'))
def test_a_launcher_runs_its_console_script(exe):
    """What `ros2 run screwgear_ros <exe> --help` executes, run as ros2 run would."""
    proc = subprocess.run([str(PREFIX / 'lib' / PACKAGE / exe), '--help'], capture_output=True,
                          text=True, check=False, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith(f'usage: {exe}')


def test_package_xml_format_3_ament_python_with_exec_depends():
    root = ET.parse(SOURCE / 'package.xml').getroot()
    assert root.tag == 'package' and root.get('format') == '3'
    assert root.findtext('name') == PACKAGE
    assert root.findtext('version') == importlib.metadata.version(PACKAGE)
    assert root.findtext('export/build_type') == 'ament_python'
    assert {e.text for e in root.findall('exec_depend')} >= REQUIRED_EXEC_DEPENDS
    assert root.findtext('license') and root.find('maintainer').get('email')
    assert (SOURCE / 'resource' / PACKAGE).is_file()


def test_setup_cfg_puts_scripts_where_ros2_run_looks():
    cfg = configparser.ConfigParser()
    cfg.read(SOURCE / 'setup.cfg', encoding='utf-8')
    assert cfg.get('develop', 'script_dir') == '$base/lib/screwgear_ros'
    assert cfg.get('install', 'install_scripts') == '$base/lib/screwgear_ros'


def test_ros_wheels_are_not_install_requires():
    """On a ROS apt install, PyPI ROS wheels would shadow the system rclpy."""
    requires = importlib.metadata.requires(PACKAGE) or []
    assert not [r for r in requires if r.lower().startswith(('ros-', 'rclpy'))]


@pytest.mark.ros
def test_physics_core_imports_no_ros():
    code = ('import sys\n'
            'import screwgear_ros.params.table, screwgear_ros.physics.motion, screwgear_ros.numerics.integrator\n'
            'import screwgear_ros.sim.plant, screwgear_ros.numerics.reference, screwgear_ros.paper.normalized\n'
            'import screwgear_ros.sim.commands, screwgear_ros.sim.session, screwgear_ros.sim.events\n'
            'import screwgear_ros.sim.energy, screwgear_ros.params.declarations, screwgear_ros.numerics.dop853\n'
            'bad = sorted(m for m in sys.modules if m.split(".")[0] in '
            '("rclpy", "rosidl_runtime_py", "std_msgs", "sensor_msgs"))\n'
            'assert not bad, bad\n')
    proc = subprocess.run([sys.executable, '-P', '-c', code], capture_output=True, text=True,
                          check=False, timeout=120)
    assert proc.returncode == 0, proc.stderr


def _copy_package(dest: Path) -> None:
    shutil.copytree(SOURCE, dest, ignore=shutil.ignore_patterns(
        '.git', '.venv', 'build', 'install', 'log', 'out', '*.egg-info', '__pycache__',
        '.pytest_cache', '*.mcap'))


@pytest.mark.ros
def test_colcon_build_installs_a_ros_package(tmp_path, monkeypatch):
    """colcon (from PyPI, setuptools<80) builds a copy; the install has the ROS layout."""
    venv = tmp_path / 'colcon_venv'
    subprocess.run([sys.executable, '-m', 'venv', str(venv)], check=True, timeout=300)
    pip = subprocess.run(
        [str(venv / 'bin/python'), '-m', 'pip', 'install', '--quiet',
         '--disable-pip-version-check', 'setuptools<80', 'colcon-core', 'colcon-ros',
         'colcon-python-setup-py'],
        capture_output=True, text=True, check=False, timeout=600)
    assert pip.returncode == 0, pip.stderr[-3000:]
    ws = tmp_path / 'ws'
    _copy_package(ws / 'src' / PACKAGE)
    # the workspace holds only this package (no --packages-select: that is another extension)
    build = subprocess.run([str(venv / 'bin/colcon'), 'build'],
                           cwd=ws, capture_output=True, text=True, check=False, timeout=600,
                           env={**os.environ, 'PATH': f'{venv / "bin"}:{os.environ["PATH"]}'})
    assert build.returncode == 0, build.stdout[-3000:] + build.stderr[-3000:]
    install = ws / 'install' / PACKAGE
    assert (install / 'share/ament_index/resource_index/packages' / PACKAGE).is_file()
    assert (install / 'share' / PACKAGE / 'package.xml').is_file()
    assert (install / 'share' / PACKAGE / 'config/paper.yaml').is_file()
    for exe in EXECUTABLES:
        script = install / 'lib' / PACKAGE / exe
        assert _executable(script)
        # colcon's own console script wins over the pip launcher of the same name
        text = script.read_text(encoding='utf-8')
        assert text.startswith('#!') and 'console_scripts' in text and exe in text
    from ament_index_python.packages import get_package_prefix
    monkeypatch.setenv('AMENT_PREFIX_PATH', str(install))
    assert Path(get_package_prefix(PACKAGE)) == install


# ---------------------------------------------------------------- URDF, ros2_control, launch

def _installed_urdf() -> Path:
    return PREFIX / 'share' / PACKAGE / 'urdf/screwgear_table.urdf'


def test_the_shipped_urdf_is_what_the_node_describes_for_the_defaults():
    """One declaration: urdf/screwgear_table.urdf is screwgear_ros.view.urdf's output
    (regenerate: python -m screwgear_ros.view.urdf > urdf/screwgear_table.urdf)."""
    from screwgear_ros.view.urdf import shipped_description
    assert _installed_urdf().read_text(encoding='utf-8') == shipped_description()


def test_the_urdf_parses_and_its_joints_are_those_of_joint_states():
    import yourdfpy

    from screwgear_ros.params.table import SimSettings, TableParams
    from screwgear_ros.view.layout import BASE_LINK, wheels
    urdf = yourdfpy.URDF.load(_installed_urdf(), load_meshes=False, build_scene_graph=True)
    assert urdf.validate()
    names = list(SimSettings().joint_names)             # what joint_states names
    assert urdf.actuated_joint_names == names and urdf.base_link == BASE_LINK
    p = TableParams()
    for wheel, radius, inertia in zip(wheels(p, names),
                                      (p.radius_pinion_1, p.radius_table, p.radius_pinion_3),
                                      (p.inertia_pinion_1, p.inertia_table, p.inertia_pinion_3),
                                      strict=True):
        joint = urdf.joint_map[wheel.joint]
        assert joint.type == 'continuous' and joint.parent == BASE_LINK   # revolute, no limits
        link = urdf.link_map[joint.child]
        disc = next(v for v in link.visuals if v.geometry.cylinder is not None)
        assert disc.geometry.cylinder.radius == pytest.approx(radius)
        assert link.inertial.inertia[2, 2] == pytest.approx(inertia)
    # pinions on opposite sides, touching the table; forward turns the table clockwise
    x1, x3 = (urdf.joint_map[n].origin[0, 3] for n in (names[0], names[2]))
    assert x1 == pytest.approx(p.radius_pinion_1 + p.radius_table)
    assert x3 == pytest.approx(-(p.radius_pinion_3 + p.radius_table))
    assert list(urdf.joint_map[names[1]].axis) == [0.0, 0.0, -1.0]
    assert urdf.joint_map[names[0]].limit.effort == p.max_torque


def test_the_ros2_control_block_names_the_stock_plugin_and_this_nodes_topics():
    from screwgear_ros.interface import topic_names
    from screwgear_ros.view.urdf import PLANT_NAMESPACE
    block = ET.parse(_installed_urdf()).getroot().find('ros2_control')
    assert block.get('type') == 'system'
    hardware = block.find('hardware')
    assert hardware.findtext('plugin') == \
        'joint_state_topic_hardware_interface/JointStateTopicSystem'
    params = {e.get('name'): e.text for e in hardware.findall('param')}
    node = topic_names(PLANT_NAMESPACE)                 # table_sim's topics in that namespace
    assert params == {'joint_commands_topic': node['joint_commands'],
                      'joint_states_topic': node['joint_states'],
                      'trigger_joint_command_threshold': '-1'}
    assert node['joint_commands'] == '/screwgear/joint_commands'
    joints = block.findall('joint')
    assert [j.get('name') for j in joints] == ['pinion_1', 'table', 'pinion_3']
    commands = [(j.get('name'), c.get('name')) for j in joints
                for c in j.findall('command_interface')]
    assert commands == [('pinion_1', 'effort')]         # one effort command interface
    for joint in joints:
        assert [s.get('name') for s in joint.findall('state_interface')] == [
            'position', 'velocity', 'effort']
        assert joint.find('state_interface/param') is None   # no initial values: NaN
    # all joints of the block are joints of the URDF (ros2_control Jazzy requires it)
    urdf_joints = {j.get('name') for j in ET.parse(_installed_urdf()).getroot().findall('joint')}
    assert {j.get('name') for j in joints} <= urdf_joints


def test_ros2_control_yaml_has_the_broadcaster_and_an_effort_group_on_the_commanded_joint():
    from screwgear_ros.params.table import SimSettings
    from screwgear_ros.sim.commands import COMMAND_INTERFACE, COMMANDED_JOINT
    config = yaml.safe_load((PREFIX / 'share' / PACKAGE / 'config/ros2_control.yaml')
                            .read_text(encoding='utf-8'))
    manager = config['controller_manager']['ros__parameters']
    assert manager['update_rate'] > 0 and not manager.get('use_sim_time', False)
    # the node, not the controller manager, refuses a torque beyond max_torque (README)
    assert manager['enforce_command_limits'] is False
    assert manager['joint_state_broadcaster']['type'] == \
        'joint_state_broadcaster/JointStateBroadcaster'
    assert manager['effort_controller']['type'] == 'effort_controllers/JointGroupEffortController'
    assert config['effort_controller']['ros__parameters']['joints'] == [
        SimSettings().joint_names[COMMANDED_JOINT]]
    block = ET.parse(_installed_urdf()).getroot().find('ros2_control')
    joint = next(j for j in block.findall('joint')
                 if j.get('name') == SimSettings().joint_names[COMMANDED_JOINT])
    assert joint.find('command_interface').get('name') == COMMAND_INTERFACE == 'effort'


def _launch_references(path: Path) -> tuple[list[str], list[tuple[str, str]], list[str],
                                            list[str]]:
    """From a launch file: the share-relative files it joins onto the package share
    (os.path.join(share, 'dir', 'file')), its (module, name) imports from this package,
    the executables it starts from this package and the launch arguments it declares."""
    tree = ast.parse(path.read_text(encoding='utf-8'))
    files, imports, executables, arguments = [], [], [], []
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and ast.unparse(node.func) == 'DeclareLaunchArgument':
            arguments.append(ast.literal_eval(node.args[0]))
        if isinstance(node, ast.Call) and ast.unparse(node.func) == 'os.path.join' and \
                node.args and ast.unparse(node.args[0]) == 'share' and \
                all(isinstance(a, ast.Constant) for a in node.args[1:]):
            files.append('/'.join(ast.literal_eval(a) for a in node.args[1:]))
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and \
                re.fullmatch(r'[a-z_]+/[\w.-]+\.(urdf|yaml|py)', node.value):
            files.append(node.value)           # a share-relative name used elsewhere
        elif isinstance(node, ast.ImportFrom) and (node.module or '').startswith(PACKAGE):
            imports += [(node.module, alias.name) for alias in node.names]
        elif isinstance(node, ast.Call) and ast.unparse(node.func) == 'Node':
            kw = {k.arg: k.value for k in node.keywords}
            if ast.unparse(kw['package']) in ('PACKAGE', repr(PACKAGE)):
                executables.append(ast.literal_eval(kw['executable']))
    return files, imports, executables, arguments


@pytest.mark.ros
@pytest.mark.parametrize('launch', ['table_sim.launch.py', 'ros2_control.launch.py'])
def test_launch_files_compile_and_their_references_exist_where_installed(launch, tmp_path):
    """`launch` is not on PyPI: compile each installed launch file and check that every
    file it takes from the share directory, every name it imports from this package and
    every executable of this package it starts exists in this install."""
    share = PREFIX / 'share' / PACKAGE
    path = share / 'launch' / launch
    py_compile.compile(str(path), cfile=str(tmp_path / 'launch.pyc'), doraise=True)
    assert 'def generate_launch_description' in path.read_text(encoding='utf-8')
    files, imports, executables, arguments = _launch_references(path)
    assert files, 'no file references found'
    for name in files:
        assert (share / name).is_file(), name
    for module, name in imports:
        assert hasattr(importlib.import_module(module), name) or \
            importlib.util.find_spec(f'{module}.{name}') is not None, f'{module}.{name}'
    for exe in executables:
        assert _executable(PREFIX / 'lib' / PACKAGE / exe), exe
    if launch == 'ros2_control.launch.py':
        assert set(files) == {'urdf/screwgear_table.urdf', 'config/ros2_control.yaml',
                              'launch/table_sim.launch.py', 'config/paper.yaml'}
        text = path.read_text(encoding='utf-8')
        for needed in ('robot_state_publisher', 'ros2_control_node', 'spawner',
                       'joint_state_broadcaster', 'effort_controller'):
            assert needed in text, needed
        assert arguments == ['namespace', 'params_file', 'record']
    else:
        assert files == ['config/paper.yaml'] and executables == ['table_sim']
        assert arguments == ['params_file', 'namespace', 'record']
