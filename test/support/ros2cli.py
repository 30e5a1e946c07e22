"""The real ``ros2`` command line and ``launch`` for the tests, in an overlay of their own.

ROS 2's ``ros2cli``, ``launch`` and ``launch_ros`` have no PyPI wheels; the machines keep
wheels built from their Jazzy sources in ``../shared/ros2cli`` beside the checkout (or
where ``SCREWGEAR_ROS2CLI_WHEELS`` points), with ``composition_interfaces``, a message
package launch_ros imports, as an install prefix. They never go into the user's venv:
:func:`overlay` installs them, and from PyPI their pure-Python dependencies at the
versions of ``constraints.txt``, into a child venv under the user's cache directory that
sees the test run's venv through a ``.pth`` file. The child venv's name is a hash of the
wheels, the constraints and the base venv, so a change to any of them builds a new one
and nothing changed rebuilds nothing. Concurrent test runs build it once, under a file
lock; the first build says what it is doing on the terminal.

* :func:`overlay` (cached per process): the :class:`Overlay`, or None and
  :func:`why_not` says why (the tests skip with it: :data:`NEEDS_OVERLAY`).
* :meth:`Overlay.env`: the environment the ``ros2`` processes run in.
* :meth:`Overlay.run`: ``ros2 <verb> ...`` to the end, output captured.
* :meth:`Overlay.ask`: the same for a verb that asks a node over DDS, again while the
  ``ros2`` process did not yet discover the node (``Node not found``).
* :meth:`Overlay.start`: ``ros2 run``/``ros2 launch`` as a :class:`ros_procs.RosProcess`.
"""

from __future__ import annotations

import contextlib
import fcntl
import functools
import hashlib
import os
import signal
import subprocess
import sys
import sysconfig
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import pytest
from paths import ROOT
from ros_procs import RosProcess

#: The wheels' pure-Python dependencies from PyPI (their README's list), and filelock,
#: which ros2_control's stock spawner imports besides ros2param; pinned in constraints.txt.
DEPENDENCIES = ('argcomplete', 'psutil', 'lark', 'osrf-pycommon', 'PyYAML', 'packaging',
                'catkin-pkg', 'importlib-metadata', 'filelock')
CONSTRAINTS = ROOT / 'constraints.txt'
PYTHON = f'python{sys.version_info.major}.{sys.version_info.minor}'


def shared_folder() -> Path:
    """Where the wheels are looked for: ``SCREWGEAR_ROS2CLI_WHEELS`` or ../shared/ros2cli."""
    chosen = os.environ.get('SCREWGEAR_ROS2CLI_WHEELS')
    return Path(chosen) if chosen else ROOT.parent / 'shared' / 'ros2cli'


def cache_root() -> Path:
    cache = Path(os.environ.get('XDG_CACHE_HOME') or Path.home() / '.cache')
    return cache / 'screwgear_ros' / 'ros2cli'


@dataclass(frozen=True)
class Overlay:
    """A built overlay: its venv and the composition_interfaces prefix."""

    venv: Path
    interfaces: Path

    @property
    def ros2(self) -> Path:
        return self.venv / 'bin' / 'ros2'

    @property
    def python(self) -> Path:
        return self.venv / 'bin' / 'python'

    def env(self, extra: Mapping[str, str] | None = None,
            base: Mapping[str, str] | None = None) -> dict[str, str]:
        """``base`` (the test run's environment) with the overlay in front: its venv's
        bin on PATH and its prefix on the ament index (the wheels' share/ament_index lies
        there), composition_interfaces on AMENT_PREFIX_PATH, PYTHONPATH and
        LD_LIBRARY_PATH."""
        env = {**(os.environ if base is None else base), 'PYTHONUNBUFFERED': '1',
               'RCUTILS_COLORIZED_OUTPUT': '0'}

        def front(name: str, *paths: Path) -> None:
            old = env.get(name)
            env[name] = os.pathsep.join([*map(str, paths), *([old] if old else [])])

        front('PATH', self.venv / 'bin')
        front('AMENT_PREFIX_PATH', self.venv, self.interfaces)
        front('PYTHONPATH', self.interfaces / 'lib' / PYTHON / 'site-packages')
        front('LD_LIBRARY_PATH', self.interfaces / 'lib')
        env.update(extra or {})
        return env

    def run(self, *args: str, timeout: float = 60.0, check: bool = True,
            env: Mapping[str, str] | None = None,
            cwd: str | os.PathLike | None = None) -> subprocess.CompletedProcess:
        """``ros2 *args`` to its end; ``check``: AssertionError naming the output unless
        it returned 0."""
        done = subprocess.run([str(self.ros2), *args], capture_output=True, text=True,
                              env=self.env(env), timeout=timeout, check=False, cwd=cwd)
        if check and done.returncode != 0:
            raise AssertionError(f'ros2 {" ".join(args)} returned {done.returncode}:\n'
                                 f'{done.stdout[-3000:]}\n{done.stderr[-3000:]}')
        return done


    def ask(self, *args: str, timeout: float = 90.0) -> subprocess.CompletedProcess:
        """Like :meth:`run` (checked), again until the ``ros2`` process, a new DDS
        participant each time, has discovered the node it asks (``--no-daemon``: no
        daemon outlives a test)."""
        # The CLI's own discovery windows (0.5 s spin, 1 s for ``param``) are shorter
        # than a new participant needs on a busy machine. ``param`` waits for its node
        # and returns when found; the others spin their whole window, so it stays short.
        wait = ['--timeout', '15'] if args and args[0] == 'param' else ['--spin-time', '2']
        deadline = time.monotonic() + timeout
        while True:
            done = self.run(*args, '--no-daemon', *wait, check=False)
            said = done.stdout + done.stderr
            lost = ('Node not found' in said or 'Unable to find node' in said
                    or 'not available' in said
                    or 'Could not find' in said)
            if not lost or time.monotonic() > deadline:
                break
            time.sleep(0.5)
        if done.returncode != 0:
            raise AssertionError(f'ros2 {" ".join(args)} returned {done.returncode}:\n'
                                 f'{done.stdout[-3000:]}\n{done.stderr[-3000:]}')
        return done

    def start(self, *args: str, workdir: str | os.PathLike,
              env: Mapping[str, str] | None = None) -> RosProcess:
        """``ros2 *args`` started in ``workdir``, its output to files there, in a session
        of its own (its children, the nodes, can be found and signalled as a group)."""
        workdir = Path(workdir)
        workdir.mkdir(parents=True, exist_ok=True)
        command = [str(self.ros2), *args]
        with open(workdir / 'stdout.txt', 'w') as out, \
                open(workdir / 'stderr.txt', 'w') as err:       # the child keeps its copies
            popen = subprocess.Popen(command, stdout=out, stderr=err, env=self.env(env),
                                     cwd=workdir, start_new_session=True)
        return RosProcess(popen, workdir, command)


def stop_group(proc: RosProcess, sig: int = signal.SIGINT, timeout: float = 20.0) -> int:
    """``sig`` to the process group of ``proc`` (a started ``ros2`` and the nodes it
    started), as Ctrl-C in a terminal; the exit code of ``proc``. What is still running
    after ``timeout`` is killed and AssertionError raised."""
    if proc.alive():
        os.killpg(proc.pid, sig)
        try:
            proc.popen.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.popen.wait()
            proc.kill()
            raise AssertionError(f'{proc.command[1:3]} ignored signal {sig} for {timeout} s'
                                 ) from None
    deadline = time.monotonic() + timeout
    while group_alive(proc.pid) and time.monotonic() < deadline:
        time.sleep(0.1)
    if group_alive(proc.pid):
        os.killpg(proc.pid, signal.SIGKILL)
        proc.kill()
        raise AssertionError(f'a process of {proc.command[1:3]} outlived it by {timeout} s')
    proc.kill()
    return proc.popen.returncode


def kill_group(proc: RosProcess) -> None:
    """Teardown of last resort: SIGKILL to every process of ``proc``'s group (the nodes a
    ``ros2 run`` or ``ros2 launch`` started outlive a killed ``ros2``)."""
    if group_alive(proc.pid):
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
    proc.kill()


def group_alive(pgid: int) -> bool:
    """Whether a process of group ``pgid`` (zombies aside) still runs."""
    for entry in Path('/proc').iterdir():
        if not entry.name.isdigit():
            continue
        try:
            fields = (entry / 'stat').read_text().rpartition(')')[2].split()
        except OSError:
            continue
        if fields[0] != 'Z' and int(fields[2]) == pgid:
            return True
    return False


def _key(wheels: Sequence[Path]) -> str:
    digest = hashlib.sha256()
    for wheel in wheels:
        digest.update(wheel.name.encode())
        digest.update(hashlib.sha256(wheel.read_bytes()).digest())
    digest.update(CONSTRAINTS.read_bytes())
    digest.update(sys.prefix.encode())
    digest.update(sys.version.encode())
    return digest.hexdigest()[:16]


def _say(text: str) -> None:
    """What a build does: a first one takes a minute or more (:func:`ros2cli_overlay`
    builds with pytest's capture off, so this reaches the terminal or the CI log)."""
    print(f'\n[ros2cli overlay] {text}', file=sys.stderr, flush=True)


def _pip(python: Path, *args: str) -> None:
    done = subprocess.run([str(python), '-m', 'pip', 'install', '--disable-pip-version-check',
                           '-q', *args], capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise RuntimeError(f'pip install {" ".join(args)} failed:\n{done.stderr[-3000:]}')


def _build(venv: Path, wheels: Sequence[Path]) -> None:
    """The child venv: created beside ``venv`` and moved there when complete, so a run
    that was killed half way leaves nothing that looks built."""
    partial = venv.with_name(venv.name + f'.partial-{os.getpid()}')
    t0 = time.monotonic()
    _say(f'building the test overlay of the ros2 CLI in {venv} (once; about a minute)')
    subprocess.run([sys.executable, '-m', 'venv', '--without-pip', str(partial)], check=True)
    base = sysconfig.get_paths()['purelib']
    site = partial / 'lib' / PYTHON / 'site-packages'
    # addsitedir, not a plain path: the base venv's own .pth files (a light venv's link
    # to its parent's packages) are read too
    (site / 'zz_screwgear_base.pth').write_text(f'import site; site.addsitedir({base!r})\n')
    python = partial / 'bin' / 'python'
    _say('installing the wheels of ros2cli, launch and launch_ros')
    _pip(python, '--no-deps', '--no-index', *map(str, wheels))
    _say(f'installing their dependencies from PyPI: {", ".join(DEPENDENCIES)}')
    _pip(python, '-c', str(CONSTRAINTS), *DEPENDENCIES)
    # venv wrote the partial path into the scripts' first lines: point them at the
    # final place before the move
    for script in (partial / 'bin').iterdir():
        if script.is_file() and not script.is_symlink():
            text = script.read_bytes()
            if text.startswith(b'#!') and str(partial).encode() in text.split(b'\n', 1)[0]:
                script.write_bytes(text.replace(str(partial).encode(), str(venv).encode(), 1))
    for cfg in (partial / 'pyvenv.cfg',):
        cfg.write_text(cfg.read_text().replace(str(partial), str(venv)))
    partial.rename(venv)
    _say(f'overlay ready after {time.monotonic() - t0:.0f} s')


def why_not() -> str:
    """Why there is no overlay, '' where its wheels are there; builds nothing."""
    folder = shared_folder()
    if not any((folder / 'wheels').glob('*.whl')) or \
            not (folder / 'composition_interfaces').is_dir():
        return (f'no ros2cli wheels with composition_interfaces in {folder} (set '
                'SCREWGEAR_ROS2CLI_WHEELS or put them in ../shared/ros2cli)')
    return ''


@functools.cache
def overlay() -> Overlay | None:
    """The overlay, built if needed; None where no wheels are found (:func:`why_not`)."""
    if why_not():
        return None
    folder = shared_folder()
    wheels = sorted((folder / 'wheels').glob('*.whl'))
    root = cache_root()
    root.mkdir(parents=True, exist_ok=True)
    venv = root / _key(wheels)
    if not (venv / 'bin' / 'ros2').is_file():
        with open(root / '.lock', 'w') as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            if not (venv / 'bin' / 'ros2').is_file():
                _build(venv, wheels)
    return Overlay(venv, folder / 'composition_interfaces')


@pytest.fixture(scope='session')
def ros2cli_overlay(pytestconfig: pytest.Config) -> Overlay | None:
    """The overlay, built before the first test that uses it with pytest's output
    capture off: a first build says what it is doing as it goes. Import it into a test
    module (or take :data:`NEEDS_OVERLAY`) to use it."""
    capture = pytestconfig.pluginmanager.getplugin('capturemanager')
    with (capture.global_and_fixture_disabled() if capture is not None
          else contextlib.nullcontext()):
        return overlay()


#: The marks of a test that runs the real ros2 CLI: skipped with the reason where the
#: wheels are not found, the overlay built first (the module must import
#: :func:`ros2cli_overlay` too, for pytest to find the fixture).
NEEDS_OVERLAY = [pytest.mark.skipif(bool(why_not()), reason=why_not() or 'overlay found'),
                 pytest.mark.usefixtures('ros2cli_overlay')]


__all__ = ['DEPENDENCIES', 'NEEDS_OVERLAY', 'Overlay', 'group_alive', 'kill_group', 'overlay',
           'ros2cli_overlay', 'shared_folder', 'stop_group', 'why_not']
