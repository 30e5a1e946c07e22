"""Stamps of what setup_venv.sh installs, to redo only the steps whose inputs changed.

    python venv_stamp.py [ROOT]    prints three lines ``<step> <sha256>``:

* ``deps``: the requirement and constraint files and the venv's Python version: when
  it changes, the dependencies are installed again;
* ``package``: the ``deps`` stamp and every file the package's installation takes from
  the tree (the package's sources, setup.py/setup.cfg, package.xml and the data files
  setup.py installs): when it changes, the package is installed again and its numba
  cache dropped;
* ``kernels``: the ``package`` stamp and the CPU the kernels are compiled for (numba's
  ``NUMBA_CPU_NAME``/``NUMBA_CPU_FEATURES``, else the host's CPU): when it changes,
  the warm-up compiles what the cache lacks.

Each stamp includes the one before it, so a change upstream redoes every step after it.
Only contents count (never dates: a checkout or a copy changes those), and files outside
the installation (tests, docs, scripts) change nothing. Run it with the venv's Python,
whose version it records.
"""

from __future__ import annotations

import hashlib
import os
import platform
import sys
from pathlib import Path

#: Files whose contents decide which dependencies are installed.
DEPENDENCY_FILES = ('requirements.txt', 'requirements-ros.txt', 'constraints.txt')
#: Files and directories the package's installation reads (setup.py's packages and
#: data_files, with setup.cfg's options).
PACKAGE_FILES = ('setup.py', 'setup.cfg', 'package.xml')
PACKAGE_DIRS = ('screwgear_ros', 'resource', 'config', 'urdf', 'launch', 'launchers')
#: What numba compiles for instead of the host CPU when set.
CPU_VARIABLES = ('NUMBA_CPU_NAME', 'NUMBA_CPU_FEATURES')
#: Generated files beside the sources that the installation ignores.
SKIPPED_DIRS = {'__pycache__'}
SKIPPED_SUFFIXES = ('.pyc', '.pyo', '.nbi', '.nbc')


def _files(root: Path) -> list[Path]:
    """The installation's input files under ``root``, in a fixed order."""
    found = [root / name for name in PACKAGE_FILES if (root / name).is_file()]
    for name in PACKAGE_DIRS:
        for directory, dirs, files in os.walk(root / name):
            dirs[:] = sorted(d for d in dirs if d not in SKIPPED_DIRS)
            found += [Path(directory) / f for f in sorted(files)
                      if not f.endswith(SKIPPED_SUFFIXES)]
    return found


def _digest(parts: list[tuple[str, bytes]]) -> str:
    """sha256 over (name, content) pairs, each length-prefixed so no two lists collide."""
    h = hashlib.sha256()
    for name, content in parts:
        for piece in (name.encode(), content):
            h.update(len(piece).to_bytes(8, 'little'))
            h.update(piece)
    return h.hexdigest()


def _host_cpu() -> str:
    """The host CPU's model and flags as the kernel reports them ('' if unknown)."""
    try:
        lines = Path('/proc/cpuinfo').read_text(errors='replace').splitlines()
    except OSError:
        return platform.machine()
    keep = ('model name', 'flags', 'cpu family', 'model\t')
    first = [line for line in lines if line.startswith(keep)]
    return platform.machine() + '\n' + '\n'.join(dict.fromkeys(first))


def stamps(root: Path, environ: dict[str, str] | None = None) -> dict[str, str]:
    """The three stamps of the tree at ``root`` (see the module's docstring)."""
    environ = dict(os.environ if environ is None else environ)
    deps = _digest([('python', sys.version.encode())]
                   + [(name, (root / name).read_bytes() if (root / name).is_file() else b'')
                      for name in DEPENDENCY_FILES])
    package = _digest([('deps', deps.encode())]
                      + [(path.relative_to(root).as_posix(), path.read_bytes())
                         for path in _files(root)])
    cpu = [(name, environ.get(name, '').encode()) for name in CPU_VARIABLES]
    if not environ.get('NUMBA_CPU_NAME'):
        cpu.append(('host', _host_cpu().encode()))
    kernels = _digest([('package', package.encode())] + cpu)
    return {'deps': deps, 'package': package, 'kernels': kernels}


def main(argv: list[str]) -> int:
    root = Path(argv[1] if len(argv) > 1 else Path(__file__).resolve().parent.parent)
    for step, value in stamps(root).items():
        print(step, value)
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv))
