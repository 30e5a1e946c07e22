"""The real ``ros2 bag`` (rosbag2 0.26.5, Jazzy) for the tests, on the ros2 CLI's overlay.

``../shared/rosbag2`` holds rosbag2 built on the ROS wheels and relocatable (its README
gives the environment); it needs ``../shared/ros2_control`` (rclcpp and friends) and the
ros2cli wheels, which :func:`ros2cli.overlay` already installs into a cached child venv.
This module adds nothing to that venv: :func:`rosbag2` takes the overlay and returns a
:class:`Bag2` whose environment puts rosbag2's prefix, ros2_control's and the links to
the ROS wheels' bundled libraries (made once, under the cache, as
``scripts/ros2_control_stack.sh`` makes them) in front, so ``ros2 bag`` finds its verbs,
its storage and compression plugins (pluginlib, through AMENT_PREFIX_PATH) and librclcpp.

The folder is always there where the suite runs (CI included): a missing one fails the
tests that need it, with the reason, rather than skipping them.
"""

from __future__ import annotations

import fcntl
import functools
import hashlib
import os
import subprocess
import sys
import sysconfig
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from ros2cli import PYTHON, Overlay, cache_root, overlay, shared_folder
from ros_procs import RosProcess

#: ../shared beside the checkout (or the parent of SCREWGEAR_ROS2CLI_WHEELS' folder)
SHARED = shared_folder().parent


def _wheel_libs() -> Path:
    """A directory of links to the ROS wheels' bundled libraries (``ros_*.libs``), which
    the C++ of rosbag2 and ros2_control needs on LD_LIBRARY_PATH; one per base venv."""
    site = Path(sysconfig.get_paths()['purelib'])
    libs = sorted(site.glob('ros_*.libs/*'))
    key = hashlib.sha256('\n'.join([sys.prefix, *map(str, libs)]).encode()).hexdigest()[:16]
    root = cache_root().parent / 'rosbag2'
    folder = root / f'wheel_libs-{key}'
    if not folder.is_dir():
        root.mkdir(parents=True, exist_ok=True)
        with open(root / '.lock', 'w') as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            if not folder.is_dir():
                partial = root / f'.partial-{os.getpid()}'
                partial.mkdir()
                for lib in libs:        # the first of a name, as the script does
                    if not (partial / lib.name).exists():
                        (partial / lib.name).symlink_to(lib)
                partial.rename(folder)
    return folder


@dataclass(frozen=True)
class Bag2:
    """``ros2 bag`` on the ros2 CLI's overlay."""

    cli: Overlay
    libs: Path

    def env(self, extra: Mapping[str, str] | None = None) -> dict[str, str]:
        """The test run's environment with rosbag2 and ros2_control in front."""
        base = dict(os.environ)

        def front(name: str, *paths: Path | str) -> None:
            old = base.get(name)
            base[name] = os.pathsep.join([*map(str, paths), *([old] if old else [])])

        rosbag2, control = SHARED / 'rosbag2', SHARED / 'ros2_control'
        front('LD_LIBRARY_PATH', self.libs, sysconfig.get_config_var('LIBDIR'),
              rosbag2 / 'lib', control / 'lib')
        front('AMENT_PREFIX_PATH', rosbag2, control)
        front('PYTHONPATH', rosbag2 / 'lib' / PYTHON / 'site-packages',
              control / 'lib' / PYTHON / 'site-packages')
        base.update({'ROS_DISTRO': 'jazzy', 'PYTHONDONTWRITEBYTECODE': '1', **(extra or {})})
        return self.cli.env(base=base)

    def run(self, *args: str, timeout: float = 120.0, check: bool = True,
            cwd: str | os.PathLike | None = None) -> subprocess.CompletedProcess:
        """``ros2 bag *args`` to its end; ``check``: AssertionError with its output
        unless it returned 0."""
        done = subprocess.run([str(self.cli.ros2), 'bag', *args], capture_output=True,
                              text=True, env=self.env(), timeout=timeout, check=False, cwd=cwd)
        if check and done.returncode != 0:
            raise AssertionError(f'ros2 bag {" ".join(args)} returned {done.returncode}:\n'
                                 f'{done.stdout[-3000:]}\n{done.stderr[-3000:]}')
        return done

    def start(self, *args: str, workdir: str | os.PathLike) -> RosProcess:
        """``ros2 bag *args`` started in ``workdir`` (output to files there), in a
        session of its own (:func:`ros2cli.stop_group` stops it as Ctrl-C would)."""
        workdir = Path(workdir)
        workdir.mkdir(parents=True, exist_ok=True)
        command = [str(self.cli.ros2), 'bag', *args]
        with open(workdir / 'stdout.txt', 'w') as out, \
                open(workdir / 'stderr.txt', 'w') as err:
            popen = subprocess.Popen(command, stdout=out, stderr=err, env=self.env(),
                                     cwd=workdir, start_new_session=True)
        return RosProcess(popen, workdir, command)


@functools.cache
def rosbag2() -> Bag2:
    """``ros2 bag``; AssertionError naming what is missing (never a skip)."""
    for needed in (SHARED / 'rosbag2' / 'share' / 'ros2bag', SHARED / 'ros2_control' / 'lib'):
        assert needed.is_dir(), f'{needed} is missing: the real rosbag2 tests need ../shared'
    cli = overlay()
    assert cli is not None, 'no ros2cli overlay: the real rosbag2 tests need ../shared/ros2cli'
    return Bag2(cli, _wheel_libs())


__all__ = ['Bag2', 'rosbag2']
