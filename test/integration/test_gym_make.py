"""gymnasium.make finds the table's environment in a fresh interpreter, by the id that
names its module (Gymnasium 1.x loads no plugin entry points)."""

from __future__ import annotations

import subprocess
import sys

import pytest

pytest.importorskip('gymnasium')
pytestmark = pytest.mark.ros


def test_gym_make_by_the_module_qualified_id_in_a_fresh_interpreter() -> None:
    code = ("import gymnasium; env = gymnasium.make('screwgear_ros.envs:ScrewgearTable-v0', "
            "duration=0.01); obs, _ = env.reset(seed=0); print(obs.shape, "
            "-1.01 <= env.step([0.0])[1] <= 0.0)")
    result = subprocess.run([sys.executable, '-P', '-c', code], capture_output=True,
                            text=True, timeout=300, check=False)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ['(9,)', 'True']
