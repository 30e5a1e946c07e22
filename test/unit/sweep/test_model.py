"""sweep.model: a run's seed depends on the sweep seed and its index alone, a drawn axis
samples its law and a grid axis has nothing to draw, and a digest is of the value, not of
its Python spelling."""

from __future__ import annotations

import numpy as np
import pytest

from screwgear_ros.sweep.model import Axis, Draw, Law, digest, plain, run_seed


def test_a_runs_seed_is_numpys_spawned_seed_of_its_index():
    expected = np.random.SeedSequence(7, spawn_key=(3,)).generate_state(1, np.uint32)[0]
    assert run_seed(7, 3) == int(expected)
    assert len({run_seed(7, i) for i in range(100)}) == 100


def test_a_drawn_axis_samples_its_law_and_a_grid_axis_refuses():
    axis = Axis('mesh_damping', 3, draw=Draw(Law.UNIFORM, (2.0, 4.0)))
    assert axis.sample(np.random.default_rng(5)) == np.random.default_rng(5).uniform(2.0, 4.0)
    with pytest.raises(ValueError, match='grid axis'):
        Axis('mesh_damping', 3, values=(1.0, 2.0)).sample(np.random.default_rng(5))


def test_a_truncated_normal_stays_in_its_bounds():
    draw = Draw(Law.TRUNCATED_NORMAL, (0.0, 10.0, -1.0, 0.5))
    rng = np.random.default_rng(0)
    values = [draw.sample(rng) for _ in range(200)]
    assert min(values) >= -1.0 and max(values) <= 0.5


def test_plain_and_digest_see_values_not_their_types():
    assert plain({'a': (np.float64(1.5), Law.NORMAL)}) == {'a': [1.5, 'normal']}
    assert digest({'a': (1, 2), 'b': np.int64(3)}) == digest({'b': 3, 'a': [1, 2]})
    assert digest({'a': 1}) != digest({'a': 2})
