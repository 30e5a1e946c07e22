"""The installed executables on ROS arguments rcl cannot parse, and replay_run --script on
a scenario it must refuse: exit 2 with one line, nothing started, no bag left behind
(test/unit/cli/test_ros_args_fuzz.py runs the seeded family in-process)."""

from __future__ import annotations

import random
from pathlib import Path

import pytest
from bag_runs import installed

pytestmark = pytest.mark.ros
SEED = 3710


@pytest.mark.parametrize('exe', ['table_sim', 'demo_controller', 'replay_run'])
def test_an_unparsable_ros_argument_ends_the_tool_with_exit_2(exe: str) -> None:
    rng = random.Random(SEED)
    bad = rng.choice((['-p', 'inertia_table:='], ['-p', 'mode:='], ['-r', 'x'],
                      ['--params-file', '/nonexistent.yaml']))
    args = (['some.bag'] if exe == 'replay_run' else []) + ['--ros-args', *bad]
    result = installed(exe, *args, timeout=120.0)
    assert result.returncode == 2, f'seed {SEED}: {exe} {args}: {result.stderr}'
    ours = [line for line in result.stderr.splitlines() if line.startswith(f'{exe}: ')]
    assert len(ours) == 1 and 'invalid ROS arguments' in ours[0], result.stderr
    assert 'Traceback' not in result.stderr


def test_replay_run_script_refuses_a_read_only_action_before_it_starts(tmp_path: Path) -> None:
    script = tmp_path / 'mode.yaml'
    script.write_text('duration: 0.05\nactions:\n  - {time: 0.01, parameters: '
                      '{mode: conventional}}\n')
    bag = tmp_path / 'out'
    result = installed('replay_run', '--script', str(script), '--record', str(bag),
                       timeout=120.0)
    assert result.returncode == 2, result.stderr
    assert 'line 3:' in result.stderr and 'mode is read-only' in result.stderr
    assert not bag.exists()
