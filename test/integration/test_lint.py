"""The linter and the type checker, as configured in pyproject.toml, pass on the tree.

Both are pinned in constraints.txt, so a new release of either cannot fail the suite
by itself.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from paths import ROOT

pytestmark = pytest.mark.ros


def _tool(name: str) -> str:
    found = shutil.which(name, path=str(Path(sys.executable).parent)) or shutil.which(name)
    if found is None:
        pytest.fail(f'{name} is not installed in the test venv (requirements.txt lists it)')
    return found


def test_ruff_check_is_clean():
    result = subprocess.run([_tool('ruff'), 'check', '--no-cache', '.'], cwd=ROOT,
                            capture_output=True, text=True, timeout=300, check=False)
    assert result.returncode == 0, result.stdout + result.stderr


def test_mypy_is_clean_on_the_package():
    # The source tree's package, so that what is checked is what the commit holds.
    result = subprocess.run([_tool('mypy'), '--no-incremental'], cwd=ROOT,
                            capture_output=True, text=True, timeout=900, check=False)
    assert result.returncode == 0, result.stdout[-6000:] + result.stderr
