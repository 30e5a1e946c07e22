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


def test_a_truncated_normal_far_in_its_tail_draws_next_to_its_near_edge():
    # beyond its edge a, a normal's tail is nearly exponential with rate a: the excess
    # over the edge has a mean of about 1 / a (Mills' ratio), here 0.0100
    draw = Draw(Law.TRUNCATED_NORMAL, (0.0, 1.0, 100.0, 200.0))
    rng = np.random.default_rng(12)
    excess = np.array([draw.sample(rng) for _ in range(2000)]) - 100.0
    assert excess.min() >= 0.0 and excess.max() < 0.2
    assert abs(excess.mean() - 1.0 / 100.0) < 0.1 / 100.0
    mirrored = Draw(Law.TRUNCATED_NORMAL, (5.0, 2.0, -1e6, 5.0 - 2.0 * 60.0))
    below = np.array([mirrored.sample(rng) for _ in range(500)])
    assert ((5.0 - 120.0) - below).mean() == pytest.approx(2.0 / 60.0, rel=0.15)


def test_a_truncated_normal_near_its_mean_keeps_its_draws_bit_for_bit():
    from scipy.special import ndtr, ndtri

    draw = Draw(Law.TRUNCATED_NORMAL, (1.0, 0.3, 0.5, 1.5))
    rng, again = np.random.default_rng(11), np.random.default_rng(11)
    lo, hi = ndtr((0.5 - 1.0) / 0.3), ndtr((1.5 - 1.0) / 0.3)
    for _ in range(50):
        expected = 1.0 + 0.3 * float(ndtri(lo + (hi - lo) * again.random()))
        assert draw.sample(rng) == min(max(expected, 0.5), 1.5)


def test_a_grid_point_is_itertools_product_order_without_the_product():
    import itertools

    from screwgear_ros.sweep.resolve import grid_point, run_count

    grid = (Axis('a', 1, values=(1, 2, 3)), Axis('b', 2, values=('x', 'y')),
            Axis('c', 3, values=(0.5, 0.25, 0.125, 0.0625)))
    assert [grid_point(grid, k) for k in range(24)] == \
        list(itertools.product(*(a.values for a in grid)))
    wide = tuple(Axis(f'p{k}', k, values=tuple(range(100))) for k in range(6))
    assert run_count(wide, 7) == 7 * 100 ** 6
    assert grid_point(wide, 100 ** 6 - 1) == (99,) * 6
