"""Correlated draws in sweeps (shared factors, derived parameters, redraws of refused
draws), the worst runs when some never settle, the drawn values in the results, and the
message for a changed text (issue #45 items 8 and 9, issue #43)."""

from __future__ import annotations

import csv
import math
import textwrap
from pathlib import Path

import numpy as np
import pytest

from screwgear_ros.sweep.model import SweepError
from screwgear_ros.sweep.spec import load_sweep
from screwgear_ros.sweep.store import _difference
from screwgear_ros.sweep.summary import worst


def _files(directory: Path, monte_carlo: str, scenario: str = 'duration: 0.005\n') -> Path:
    (directory / 'scenario.yaml').write_text(scenario, encoding='utf-8')
    path = directory / 'sweep.yaml'
    path.write_text('scenario: scenario.yaml\nmetrics: [max_abs_te_m]\n'
                    + textwrap.dedent(monte_carlo), encoding='utf-8')
    return path


FRICTION = '''\
    monte_carlo:
      count: 60
      seed: {seed}
      parameters:
        table_coulomb_torque: {{uniform: [2.0, 4.0]}}
        table_static_torque: {{uniform: [2.5, 4.5]}}
    '''


@pytest.mark.parametrize('seed', [1, 2, 3])
def test_crossing_independent_draws_are_drawn_again_and_counted(tmp_path, seed):
    """Seeded: ranges that cross; every run kept meets static >= Coulomb, the redraws
    are counted (about P(cross) of the draws: 0.28 per draw for these ranges), the same
    seed gives the same runs."""
    sweep = load_sweep(_files(tmp_path, FRICTION.format(seed=seed)))
    for run in sweep.runs:
        values = dict(run.overrides)
        assert values['table_static_torque'] >= values['table_coulomb_torque'], seed
    assert 0 < sweep.redraws < 60, seed
    assert 'must be >= table_coulomb_torque' in sweep.first_refusal
    assert sweep.resolved()['monte_carlo']['redraws'] == sweep.redraws
    again = load_sweep(_files(tmp_path, FRICTION.format(seed=seed)))
    assert [r.key for r in again.runs] == [r.key for r in sweep.runs]


def test_redraw_0_refuses_as_before(tmp_path):
    text = FRICTION.format(seed=1).replace('count: 60\n', 'count: 60\n      redraw: 0\n')
    with pytest.raises(SweepError, match='is refused by table_sim'):
        load_sweep(_files(tmp_path, text))


def test_a_grid_value_no_draw_can_cure_is_refused_after_the_redraws(tmp_path):
    path = _files(tmp_path, '''\
        grid:
          table_static_torque: [1.0]
        monte_carlo:
          count: 2
          redraw: 3
          parameters:
            table_coulomb_torque: {uniform: [2.0, 3.0]}
        ''')
    with pytest.raises(SweepError, match='after 3 redraws'):
        load_sweep(path)


def test_a_shared_factor_moves_its_parameters_together_and_a_ratio_derives_one(tmp_path):
    sweep = load_sweep(_files(tmp_path, '''\
        monte_carlo:
          count: 40
          seed: 5
          factors:
            friction: {uniform: [0.5, 1.5]}
          parameters:
            table_coulomb_torque: {factor: friction}
            pinion_coulomb_torque: {scale: {factor: friction}}
            table_static_torque: {times: table_coulomb_torque, ratio: {uniform: [1.2, 1.4]}}
            pinion_static_torque: {times: pinion_coulomb_torque, ratio: {uniform: [1.0, 1.1]}}
        ''', 'parameters: {pinion_coulomb_torque: 0.05, pinion_static_torque: 0.07}\n'
             'duration: 0.005\n'))
    assert sweep.redraws == 0
    factors = []
    for run in sweep.runs:
        swept, values = dict(run.swept), dict(run.overrides)
        factor = swept['factor_friction']
        factors.append(factor)
        assert values['table_coulomb_torque'] == factor
        assert values['pinion_coulomb_torque'] == pytest.approx(0.05 * factor, rel=1e-15)
        ratio = values['table_static_torque'] / values['table_coulomb_torque']
        assert ratio == pytest.approx(swept['table_static_torque_ratio'], rel=1e-15)
        assert 1.2 <= ratio <= 1.4
    assert min(factors) >= 0.5 and max(factors) <= 1.5 and np.std(factors) > 0.2


@pytest.mark.parametrize('entry, words', [
    ('{factor: nope}', 'not one of monte_carlo factors'),
    ('{times: no_such, ratio: {uniform: [1, 2]}}', 'not a parameter of table_sim'),
    ('{times: table_static_torque, ratio: {uniform: [1, 2]}}', 'times itself'),
    ('{times: table_coulomb_torque}', 'a derived parameter is'),
    ('{times: table_coulomb_torque, ratio: {uniform: [2, 1]}}', 'low must be below high'),
])
def test_bad_correlated_entries_name_their_line(tmp_path, entry, words):
    path = _files(tmp_path, f'''\
        monte_carlo:
          count: 2
          parameters:
            table_static_torque: {entry}
        ''')
    with pytest.raises(SweepError, match=words) as caught:
        load_sweep(path)
    assert 'line' in str(caught.value)


def test_runs_that_never_settle_are_the_worst_and_nan_is_never():
    table = {'index': [0, 1, 2, 3, 4], 'm': [1.0, math.inf, math.nan, 3.0, math.inf]}
    assert worst(table, 'm') == [1, 4, 3, 0]
    assert worst({'index': [0, 1], 'm': [math.inf, math.inf]}, 'm') == [0, 1]


def test_a_changed_text_names_the_line_that_changed():
    old = {'controller_sources': {'pid.py': 'import math\n' * 30 + 'KP = 1.0\n'}}
    new = {'controller_sources': {'pid.py': 'import math\n' * 30 + 'KP = 2.0\n'}}
    said = _difference(old, new)
    assert said == ("controller_sources.pid.py changed at line 31: now 'KP = 2.0', was "
                    "'KP = 1.0'")
    assert 'different text' not in said


def test_results_carry_the_drawn_values_beside_factors_and_ratios(tmp_path, capsys):
    from screwgear_ros.cli.sweep import main
    path = _files(tmp_path, '''\
        monte_carlo:
          count: 3
          seed: 2
          parameters:
            table_coulomb_torque: {scale: {uniform: [0.5, 1.0]}}
            table_static_torque: {times: table_coulomb_torque, ratio: {uniform: [1.2, 1.4]}}
        ''', 'parameters: {table_coulomb_torque: 3.0, table_static_torque: 4.0}\n'
             'duration: 0.005\n')
    assert main([str(path), '--out', str(tmp_path / 'out'), '--workers', '1',
                 '--no-plot']) == 0
    with open(tmp_path / 'out' / 'results.csv', newline='', encoding='utf-8') as stream:
        rows = list(csv.DictReader(stream))
    assert len(rows) == 3
    for row in rows:
        coulomb = float(row['table_coulomb_torque'])
        assert coulomb == pytest.approx(3.0 * float(row['table_coulomb_torque_scale']),
                                        rel=1e-15)
        assert float(row['table_static_torque']) == pytest.approx(
            coulomb * float(row['table_static_torque_ratio']), rel=1e-15)
