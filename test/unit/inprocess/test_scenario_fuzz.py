"""Seeded fuzz of scenario files: control characters, bytes that are not UTF-8, deep
nesting, read-only parameters in actions and square setpoint periods below the tick all
end in ScenarioError naming the file and the line, at load; nothing is run."""

from __future__ import annotations

import random
import time
from pathlib import Path

import pytest

from screwgear_ros.inprocess.metrics import run_metrics
from screwgear_ros.inprocess.scenario import READ_ONLY, ScenarioError, load_scenario
from screwgear_ros.inprocess.setpoint_profile import SetpointProfile
from screwgear_ros.inprocess.simulation import Simulation

SEED = 3704
CASES = 300
BUDGET = 120.0
BASE = ('duration: 0.05\n'
        'parameters: {publish_rate: 1000.0}\n'
        'actions:\n'
        '  - {time: 0.0, cmd_torque: 100.0}\n'
        '  - {time: 0.01, parameters: {preload_torque: 300.0}}\n')


def _case(rng: random.Random) -> tuple[bytes, int | None, str]:
    """A scenario with one hostile thing; the line it is on (None: no line to say) and a
    word the refusal must contain ('' : it may load)."""
    kind = rng.randrange(6)
    if kind == 0:                       # a control character somewhere
        lines = BASE.splitlines(keepends=True)
        k = rng.randrange(len(lines))
        at = rng.randrange(len(lines[k]))
        lines[k] = lines[k][:at] + chr(rng.choice((1, 2, 7, 8, 0x1b, 0x7f))) + lines[k][at:]
        return ''.join(lines).encode(), k + 1, ''
    if kind == 1:                       # a byte that is not UTF-8
        lines = BASE.splitlines(keepends=True)
        k = rng.randrange(len(lines))
        data = ''.join(lines[:k]).encode() + bytes([rng.choice((0xff, 0xfe, 0x80))]) + \
            ''.join(lines[k:]).encode()
        return data, k + 1, 'UTF-8'
    if kind == 2:                       # deep flow nesting in an action's value
        depth = rng.randint(100, 5000)
        return (BASE + '  - {time: 0.02, cmd_torque: ' + '[' * depth + ']' * depth
                + '}\n').encode(), 6, 'deeper'
    if kind == 3:                       # a read-only parameter in an action
        name = rng.choice(sorted(READ_ONLY - {'joint_names', 'record'}))
        value = rng.choice(('conventional', 0.0, 1, 'true'))
        return (BASE + f'  - {{time: 0.02, parameters: {{{name}: {value}}}}}\n').encode(), 6, \
            'read-only'
    if kind == 4:                       # a square period from far below the tick to above it
        period = 10.0 ** rng.uniform(-323.5, -1.0)
        text = (BASE + 'controller: {use: demo}\n'
                f'setpoint: {{profile: square, amplitude: 0.01, period: {period:.6e}}}\n')
        return text.encode(), 7, '' if period >= 2e-3 else 'period'
    return BASE.encode(), None, ''


def test_a_hostile_scenario_is_refused_at_load_with_its_line(tmp_path: Path) -> None:
    rng = random.Random(SEED)
    started = time.monotonic()
    for case in range(CASES):
        data, line, word = _case(rng)
        path = tmp_path / f's{case}.yaml'
        path.write_bytes(data)
        try:
            load_scenario(path)
        except ScenarioError as exc:
            text = str(exc)
            assert text.startswith(f'{path}: '), f'seed {SEED} case {case}: {text}'
            if line is not None:
                assert f'line {line}:' in text, f'seed {SEED} case {case}: {text}'
            assert word in text, f'seed {SEED} case {case}: {text}'
        except Exception as exc:  # noqa: BLE001 - the finding: anything undocumented
            pytest.fail(f'seed {SEED} case {case}: {data[-120:]!r}: {type(exc).__name__}: {exc}')
        else:
            assert not word, f'seed {SEED} case {case}: loaded, expected a refusal ({word})'
        assert time.monotonic() - started < BUDGET, f'seed {SEED}: over budget at {case}'


def test_the_named_cases(tmp_path: Path) -> None:
    path = tmp_path / 'mode.yaml'
    path.write_text(BASE + '  - {time: 0.02, parameters: {mode: conventional}}\n')
    with pytest.raises(ScenarioError, match=r'line 6: .*mode is read-only'):
        load_scenario(path)
    path.write_text('duration: 1.0\nactions: [{time: 0.0, cmd_torque: "\x01"}]\n')
    with pytest.raises(ScenarioError, match=r'line 2: not valid YAML: control character'):
        load_scenario(path)
    for period in (1e-300, 5e-324):
        path.write_text(f'duration: 0.05\nsetpoint: {{profile: square, amplitude: 0.01, '
                        f'period: {period:.6e}}}\n')
        with pytest.raises(ScenarioError, match=r'line 2: .*period must be'):
            load_scenario(path)


def test_run_metrics_refuses_a_period_below_the_tick_at_once() -> None:
    """The metrics of a run against a square wave faster than its ticks: refused with the
    bound instead of a list of one jump per half period (seen: memory growing without end)."""
    run = Simulation().run(None, 0.005)
    started = time.monotonic()
    for period in (1e-300, 1e-9, 1e-4):
        with pytest.raises(ValueError, match='at least two ticks'):
            run_metrics(run, SetpointProfile('square', amplitude=0.01, period=period))
    assert time.monotonic() - started < 5.0
    with pytest.raises(ValueError, match='period'):
        SetpointProfile('square', amplitude=0.01, period=5e-324)
