"""The installed package is a real ROS 2 ament_python package.

Checks the pip/venv install this test run uses (ament index marker, package.xml,
launchers where `ros2 run` looks), the package manifest and setup.cfg in the source
tree, that the physics core imports no ROS, and the colcon route: colcon-core,
colcon-ros and colcon-python-setup-py from PyPI build a copy of the package.
"""

from __future__ import annotations

import configparser
import importlib.metadata
import os
import shutil
import stat
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

PACKAGE = 'screwgear_ros'
SOURCE = Path(__file__).resolve().parents[1]
PREFIX = Path(sys.prefix)
EXECUTABLES = ('table_sim', 'demo_controller', 'check_run', 'replay_run', 'paper_report')
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


def test_installed_config_loads_to_the_defaults():
    from screwgear_ros.params import SimSettings, TableParams, load_yaml
    assert load_yaml(PREFIX / 'share' / PACKAGE / 'config/paper.yaml') == (TableParams(),
                                                                           SimSettings())


@pytest.mark.parametrize('exe', EXECUTABLES)
def test_launchers_where_ros2_run_looks(exe):
    """$prefix/lib/screwgear_ros/<exe> is executable and execs the console script in bin/."""
    launcher = PREFIX / 'lib' / PACKAGE / exe
    assert _executable(launcher)
    text = launcher.read_text(encoding='utf-8')
    assert text.startswith('#!/bin/sh') and f'/../../bin/{exe}"' in text
    assert _executable(PREFIX / 'bin' / exe)
    assert subprocess.run(['sh', '-n', str(launcher)], check=False).returncode == 0


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


def test_physics_core_imports_no_ros():
    code = ('import sys\n'
            'import screwgear_ros.params, screwgear_ros.model, screwgear_ros.integrator\n'
            'import screwgear_ros.plant, screwgear_ros.reference, screwgear_ros.normalized\n'
            'import screwgear_ros.commands\n'
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
