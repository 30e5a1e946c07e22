"""The README's "Python API" example runs exactly as printed and says check_run passes."""

from __future__ import annotations

import re
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
def test_the_readme_example_is_short_and_runs_as_printed_from_anywhere_twice(tmp_path):
    """From an empty directory (no config/ beside it), twice: it finds the shipped
    parameter file, records into a fresh directory each time and leaves nothing in the
    working directory."""
    code = readme_example()
    lines = [line for line in code.splitlines() if line.strip()]
    assert len(lines) <= 10, f'{len(lines)} lines'
    assert 'Simulation' in code and 'record=' in code and 'check_run' in code
    for attempt in range(2):
        proc = subprocess.run([sys.executable, '-P', '-c', code], cwd=tmp_path,
                              capture_output=True, text=True, timeout=600, check=False)
        assert proc.returncode == 0, f'run {attempt + 1}: {proc.stderr}'
        assert proc.stdout.strip().endswith('check_run: True'), proc.stdout
        angle = float(proc.stdout.split(' rad')[0])
        assert abs(angle - 0.02) < 2e-3                # the PD loop held its target
    assert list(tmp_path.iterdir()) == [], 'the example left files in its directory'


def test_overwrite_replaces_an_earlier_recording_and_nothing_else(tmp_path):
    from screwgear_ros import Simulation, config_path
    from screwgear_ros.bag.reader import read_run

    sim = Simulation.from_yaml(config_path('paper.yaml'))
    bag = tmp_path / 'pd_run'
    sim.run(lambda o: 10.0, duration=0.01, record=bag)
    with pytest.raises(FileExistsError):
        sim.run(lambda o: 10.0, duration=0.02, record=bag)
    run = sim.run(lambda o: 10.0, duration=0.02, record=bag, overwrite=True)
    assert len(read_run(bag).joint_states) == len(run.time)
    other = tmp_path / 'notes'
    other.mkdir()
    (other / 'keep.txt').write_text('mine')
    with pytest.raises(FileExistsError, match='not a recording'):
        sim.run(None, duration=0.01, record=other, overwrite=True)
    assert (other / 'keep.txt').read_text() == 'mine'


def test_config_path_finds_every_shipped_file_from_another_directory(tmp_path, monkeypatch):
    from screwgear_ros import config_path
    from screwgear_ros.params.config_files import ConfigNotFound

    monkeypatch.chdir(tmp_path)
    for shipped in sorted((ROOT / 'config').glob('*.yaml')):
        found = config_path(shipped.name)
        assert found.is_absolute() and found.read_bytes() == shipped.read_bytes(), found
    with pytest.raises(ConfigNotFound, match='looked in'):
        config_path('no_such.yaml')
