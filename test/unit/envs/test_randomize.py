"""The environment's domain randomization (envs/randomize.py): derived parameters and
the redraw of draws the node refuses, counted (issue #45 item 8)."""

from __future__ import annotations

import pytest

pytest.importorskip('gymnasium')

from screwgear_ros.envs.table_env import ScrewgearTableEnv


@pytest.mark.parametrize('seed', [0, 1, 2])
def test_randomize_draws_again_what_the_node_refuses_and_derives_static_from_coulomb(seed):
    """Seeded: independent ranges that cross are drawn again until the node takes them,
    counted in info['redraws']; a derived static torque is Coulomb × the drawn ratio."""
    crossing = ScrewgearTableEnv(duration=0.01, randomize={
        'table_coulomb_torque': (2.0, 4.0), 'table_static_torque': (2.5, 4.5)})
    total = 0
    for episode in range(20):
        _, info = crossing.reset(seed=seed * 100 + episode)
        drawn = info['parameters']
        assert drawn['table_static_torque'] >= drawn['table_coulomb_torque'], seed
        total += info['redraws']
    assert total == crossing.redraws and total > 0, seed
    derived = ScrewgearTableEnv(duration=0.01, randomize={
        'table_coulomb_torque': (2.0, 4.0),
        'table_static_torque': {'times': 'table_coulomb_torque', 'ratio': (1.2, 1.4)}})
    _, info = derived.reset(seed=seed)
    drawn = info['parameters']
    assert 1.2 <= drawn['table_static_torque'] / drawn['table_coulomb_torque'] <= 1.4
    assert info['redraws'] == 0
    assert derived.simulation.params.table_static_torque == drawn['table_static_torque']


@pytest.mark.parametrize('randomize, words', [
    ({'table_static_torque': {'times': 'nope', 'ratio': (1, 2)}}, 'must name another'),
    ({'table_static_torque': {'ratio': (1, 2)}}, 'a derived parameter is'),
    ({'backlash': ('a', 'b')}, 'a range (low, high) of two numbers'),
    ({'backlash': (0.0, float('nan'))}, 'finite'),
])
def test_bad_randomize_entries_name_the_entry_and_the_rule(randomize, words):
    with pytest.raises(ValueError) as caught:
        ScrewgearTableEnv(randomize=randomize)
    assert words in str(caught.value) and 'randomize' in str(caught.value)
