"""Every executable the package installs answers ``--help`` with its usage and exits 0,
without starting a node or waiting for anything."""

from __future__ import annotations

import shutil
import subprocess
from importlib import metadata

import pytest
from paths import setup_executables

HELP_TIMEOUT = 60.0     # s of wall time: an import of rclpy and NumPy, under load


def test_every_installed_entry_point_is_in_setup_py():
    installed = {e.name for e in metadata.distribution('screwgear_ros').entry_points
                 if e.group == 'console_scripts'}
    assert installed == set(setup_executables())


@pytest.mark.ros
@pytest.mark.parametrize('exe', setup_executables())
def test_every_executable_answers_help_with_its_usage(exe, tmp_path):
    path = shutil.which(exe)
    assert path is not None, f'{exe} is not on PATH'
    done = subprocess.run([path, '--help'], cwd=tmp_path, capture_output=True, text=True,
                          timeout=HELP_TIMEOUT, check=False)
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith(f'usage: {exe}'), done.stdout[:200]
    assert list(tmp_path.iterdir()) == [], 'the --help wrote files'
