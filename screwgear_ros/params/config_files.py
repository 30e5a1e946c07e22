"""Where the parameter files shipped with the package (``config/*.yaml``) are, from any
working directory: an install's share directory, else the source tree."""

from __future__ import annotations

import os
import sys
import sysconfig
from pathlib import Path

from ..errors import ScrewgearError

PACKAGE = 'screwgear_ros'


class ConfigNotFound(ScrewgearError, FileNotFoundError):
    """No shipped parameter file of that name; says where it looked."""


def config_dirs() -> list[Path]:
    """The directories :func:`config_path` looks in, in order: the package's share
    directory under each prefix of the ament index (``AMENT_PREFIX_PATH``: a colcon
    install, or the venv once ``scripts/env.sh`` is sourced; read as the index's
    layout, ``share/ament_index/resource_index/packages/<package>``, without importing
    ROS), the share directory of the Python environment (a pip install: setup.py's
    data_files), the source tree this module lies in."""
    found = []
    for prefix in filter(None, os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep)):
        marker = Path(prefix) / 'share' / 'ament_index' / 'resource_index' / 'packages'
        if (marker / PACKAGE).is_file():
            found.append(Path(prefix) / 'share' / PACKAGE / 'config')
    for prefix in (sysconfig.get_paths()['data'], sys.prefix):
        found.append(Path(prefix) / 'share' / PACKAGE / 'config')
    found.append(Path(__file__).resolve().parents[2] / 'config')
    return list(dict.fromkeys(found))


def config_path(name: str) -> Path:
    """The shipped parameter file ``name`` (e.g. ``'paper.yaml'``), from any directory.

    Parameters
    ----------
    name : str
        A file name of the package's ``config/`` directory.

    Returns
    -------
    pathlib.Path
        The first existing file of that name in :func:`config_dirs`.

    Raises
    ------
    ConfigNotFound
        No such file in any of those directories (a FileNotFoundError naming them).

    Examples
    --------
    >>> from screwgear_ros import Simulation, config_path
    >>> sim = Simulation.from_yaml(config_path('paper.yaml'))
    """
    dirs = config_dirs()
    for directory in dirs:
        if (directory / name).is_file():
            return directory / name
    raise ConfigNotFound(f'no shipped parameter file {name!r}: looked in '
                         f'{", ".join(str(d) for d in dirs)}')


__all__ = ['ConfigNotFound', 'config_dirs', 'config_path']
