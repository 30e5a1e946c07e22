"""Seeded fuzz of the ROS arguments of table_sim, demo_controller and replay_run: any
argument rcl cannot parse ends the tool with exit 2 and one line giving rcl's reason,
before anything starts (in-process: each main refuses before rclpy.init)."""

from __future__ import annotations

import random
import string
import time
from pathlib import Path

import pytest

from screwgear_ros.cli import demo_controller, replay_run, table_sim

SEED = 3709
CASES = 300
BUDGET = 120.0
#: Parameter files rcl's parser refuses.
BAD_FILES = ('a: : b\n', '/**:\n  ros__parameters:\n    a: [1, "x"]\n',
             '/**:\n  ros__parameters:\n    a: [\n', '- 1\n- 2\n', '\t: x\n')


def _word(rng: random.Random) -> str:
    return ''.join(rng.choice(string.ascii_lowercase) for _ in range(rng.randint(1, 8)))


def _bad(rng: random.Random, tmp: Path, case: int) -> list[str]:
    """ROS arguments of which at least one rcl cannot parse."""
    kind = rng.randrange(7)
    if kind == 0:
        return ['-p', f'{_word(rng)}:=']
    if kind == 1:
        return ['-p']
    if kind == 2:
        return ['-r', _word(rng)]
    if kind == 3:
        return ['--params-file', f'/nonexistent/{_word(rng)}.yaml']
    if kind == 4:
        path = tmp / f'bad{case}.yaml'
        path.write_text(rng.choice(BAD_FILES))
        return ['--params-file', str(path)]
    if kind == 5:
        return ['--log-level', f'{rng.randint(0, 9)}{_word(rng)}']
    return [f'--bogus-{_word(rng)}']


def _valid(rng: random.Random) -> list[str]:
    return rng.choice(([], ['-p', 'publish_rate:=500.0'], ['-r', '__node:=table_sim']))


def test_rosargs_rcl_refuses_end_each_tool_with_exit_2_and_one_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rng = random.Random(SEED)
    started = time.monotonic()
    tools = (('table_sim', lambda a: table_sim.main(['table_sim', *a])),
             ('demo_controller', lambda a: demo_controller.main(['demo_controller', *a])),
             ('replay_run', lambda a: replay_run.main(['some.bag', *a])))
    for case in range(CASES):
        name, main = rng.choice(tools)
        args = ['--ros-args', *_valid(rng), *_bad(rng, tmp_path, case), *_valid(rng)]
        try:
            code = main(args)
        except BaseException as exc:  # noqa: BLE001 - the finding: a traceback or exit
            pytest.fail(f'seed {SEED} case {case}: {name} {args}: {type(exc).__name__}: {exc}')
        err = capsys.readouterr().err
        ours = [line for line in err.splitlines() if line.startswith(f'{name}: ')]
        assert code == 2, f'seed {SEED} case {case}: {name} {args}: exit {code}\n{err}'
        assert len(ours) == 1 and 'ROS arguments' in ours[0], \
            f'seed {SEED} case {case}: {name} {args}: {err}'
        assert ', at /' not in ours[0], f'seed {SEED} case {case}: {ours[0]}'
        assert time.monotonic() - started < BUDGET, f'seed {SEED}: over budget at {case}'


def test_the_named_cases(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / 'bad.yaml'
    bad.write_text(BAD_FILES[1])
    for args, words in ((['-p', 'inertia_table:='], "'-p inertia_table:='"),
                        (['-p', 'mode:='], "'-p mode:='"),
                        (['--params-file', '/nonexistent.yaml'], 'Error opening YAML file'),
                        (['--params-file', str(bad)], 'Sequence should be of same type'),
                        (['-r', 'x'], "Couldn't parse remap rule")):
        assert table_sim.main(['table_sim', '--ros-args', *args]) == 2
        assert words in capsys.readouterr().err
