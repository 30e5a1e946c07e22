"""scripts/venv_stamp.py, which decides what setup_venv.sh redoes: each stamp changes
when an input of its step (or of a step before it) changes, and not otherwise.

Run as setup_venv.sh runs it (a separate process, the tree's root as argument), on a
copy of the tree's installation inputs in a temporary directory.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from paths import ROOT

SCRIPT = ROOT / 'scripts' / 'venv_stamp.py'
COPIED = ('setup.py', 'setup.cfg', 'package.xml', 'requirements.txt', 'requirements-ros.txt',
          'constraints.txt', 'README.md', 'screwgear_ros', 'resource', 'config', 'urdf',
          'launch', 'launchers', 'test/conftest.py', 'docs')


def stamps(root: Path, **env: str) -> dict[str, str]:
    environ = {k: v for k, v in os.environ.items() if not k.startswith('NUMBA_CPU_')}
    proc = subprocess.run([sys.executable, '-P', str(SCRIPT), str(root)], capture_output=True,
                          text=True, env={**environ, **env}, timeout=60, check=True)
    lines = dict(line.split() for line in proc.stdout.splitlines())
    assert list(lines) == ['deps', 'package', 'kernels']
    assert all(len(v) == 64 for v in lines.values())
    return lines


@pytest.fixture
def tree(tmp_path: Path) -> Path:
    root = tmp_path / 'tree'
    for name in COPIED:
        source, target = ROOT / name, root / name
        target.parent.mkdir(parents=True, exist_ok=True)
        if source.is_dir():
            shutil.copytree(source, target, ignore=shutil.ignore_patterns('__pycache__'))
        elif source.exists():
            shutil.copy2(source, target)
    return root


def changed(before: dict[str, str], after: dict[str, str]) -> list[str]:
    return [step for step in before if before[step] != after[step]]


@pytest.mark.ros
def test_the_stamps_follow_only_their_inputs(tree: Path):
    base = stamps(tree)
    assert stamps(tree) == base                                   # deterministic

    # Not inputs: dates, files outside the installation, numba's and Python's caches.
    model = tree / 'screwgear_ros' / 'physics' / 'motion.py'
    os.utime(model, (1.0, 1.0))
    (tree / 'README.md').write_text('edited\n')
    (tree / 'test' / 'conftest.py').write_text('# edited\n')
    (tree / 'docs' / 'new.md').write_text('new\n')
    cache = tree / 'screwgear_ros' / 'physics' / '__pycache__'
    cache.mkdir()
    (cache / 'motion.cpython-311.pyc').write_bytes(b'x')
    (cache / 'motion.rhs-1.py311.nbi').write_bytes(b'x')
    assert stamps(tree) == base

    # A source of the package: reinstall and recompile, dependencies kept.
    text = model.read_text()
    model.write_text(text + '\n# edited\n')
    edited = stamps(tree)
    assert changed(base, edited) == ['package', 'kernels']
    model.write_text(text)
    assert stamps(tree) == base                                   # content, not history

    # An installed data file, a new module: the same.
    for path in (tree / 'config' / 'paper.yaml', tree / 'screwgear_ros' / 'new_module.py'):
        old = path.read_bytes() if path.exists() else None
        path.write_text((old or b'').decode() + '\n# x\n')
        assert changed(base, stamps(tree)) == ['package', 'kernels'], path
        path.write_bytes(old) if old is not None else path.unlink()
    assert stamps(tree) == base

    # A dependency file: everything.
    constraints = tree / 'constraints.txt'
    constraints.write_text(constraints.read_text() + 'six==1.0\n')
    assert changed(base, stamps(tree)) == ['deps', 'package', 'kernels']


@pytest.mark.ros
def test_the_cpu_numba_compiles_for_changes_only_the_kernels(tree: Path):
    base = stamps(tree)
    generic = stamps(tree, NUMBA_CPU_NAME='generic')
    assert changed(base, generic) == ['kernels']
    assert changed(generic, stamps(tree, NUMBA_CPU_NAME='skylake')) == ['kernels']
    assert stamps(tree, NUMBA_CPU_NAME='generic') == generic
