"""The README's "Python API" example runs exactly as printed and says check_run passes."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys

import pytest
from paths import ROOT


def readme_example() -> str:
    text = (ROOT / 'README.md').read_text(encoding='utf-8')
    section = text.split('\n## Python API\n', 1)[1].split('\n## ', 1)[0]
    blocks = re.findall(r'```python\n(.*?)```', section, flags=re.DOTALL)
    assert blocks, 'no python block in the README section "Python API"'
    return blocks[0]


@pytest.mark.ros
def test_the_readme_example_is_short_and_runs_as_printed(tmp_path):
    code = readme_example()
    lines = [line for line in code.splitlines() if line.strip()]
    assert len(lines) <= 10, f'{len(lines)} lines'
    assert 'Simulation' in code and 'record=' in code and 'check_run' in code
    (tmp_path / 'config').mkdir()
    shutil.copy(ROOT / 'config' / 'paper.yaml', tmp_path / 'config' / 'paper.yaml')
    proc = subprocess.run([sys.executable, '-P', '-c', code], cwd=tmp_path, capture_output=True,
                          text=True, timeout=600, check=False)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip().endswith('check_run: True'), proc.stdout
    angle = float(proc.stdout.split(' rad')[0])
    assert abs(angle - 0.02) < 2e-3                # the PD loop held its target
    assert (tmp_path / 'pd_run' / 'metadata.yaml').is_file()
