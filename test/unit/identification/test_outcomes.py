"""What a fit reports, against ground truth made here: a linear least-squares problem
whose intervals have a closed form (rank-deficient, on a bound, two data sets that
disagree), and tiny fits of recordings made here (a model that diverges everywhere, a
parameter with no effect, a trial point the node refuses, two tables, several starts,
Ctrl-C while writing)."""

from __future__ import annotations

import math
import random
import signal

import numpy as np
import pytest
from identify_truth import truth_simulation, write_base

import screwgear_ros
from screwgear_ros.cli.identify import main
from screwgear_ros.identification import api
from screwgear_ros.identification.adapter import base_values, model
from screwgear_ros.identification.command import summary
from screwgear_ros.identification.output import write_fitted
from screwgear_ros.identification.parameters import fit_parameters
from screwgear_ros.identification.stats import (
    Estimate,
    disagreements,
    start_disagreements,
    statistics,
)
from screwgear_ros.inprocess.simulation import Simulation
from screwgear_ros.physics.quantities import natural_frequency

SEED = 5209


def _linear(rng: np.random.Generator, slope: float, m: int = 400, noise: float = 0.01
            ) -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0.0, 1.0, m)
    return t, slope * t + noise * rng.standard_normal(m)


def test_a_parameter_with_no_effect_leaves_the_others_their_interval():
    """y = a·t + noise, fitted in x = ln a with a second parameter that changes nothing:
    a's σ is the one-parameter closed form σ_r / ‖∂r/∂x‖."""
    fitted = fit_parameters(['inertia_table', 'thermal_coefficient'], {},
                            {'thermal_coefficient': (0.0, 1.0)})
    for seed in range(SEED, SEED + 5):
        rng = np.random.default_rng(seed)
        t, y = _linear(rng, 40.0)
        a = float(t @ y / (t @ t))                          # least squares
        residual = a * t - y
        column = a * t                                      # ∂r/∂ln a
        jacobian = np.column_stack([column, np.zeros_like(t)])
        stats = statistics(fitted, np.array([math.log(a), 0.5]), residual, jacobian)
        sigma = math.sqrt(residual @ residual / (len(t) - 2))
        sd = sigma / np.linalg.norm(column)
        inertia, thermal = stats.estimates
        assert inertia.low == pytest.approx(a * math.exp(-2 * sd), rel=1e-9), f'seed {seed}'
        assert inertia.high == pytest.approx(a * math.exp(2 * sd), rel=1e-9), f'seed {seed}'
        assert not inertia.undetermined and inertia.verdict == 'yes', f'seed {seed}'
        assert 'do not depend on it' in thermal.undetermined, f'seed {seed}'
        assert stats.directions == ('1.00·thermal_coefficient',), f'seed {seed}'


def test_parameters_the_data_cannot_tell_apart_are_named_as_a_direction():
    fitted = fit_parameters(['inertia_table', 'preload_torque'], {})
    rng = np.random.default_rng(SEED)
    t, y = _linear(rng, 40.0)
    jacobian = np.column_stack([t, 2.0 * t])
    stats = statistics(fitted, np.log([40.0, 300.0]), 40.0 * t - y, jacobian)
    assert [bool(e.undetermined) for e in stats.estimates] == [True, True]
    direction, = stats.directions
    assert 'inertia_table' in direction and 'preload_torque' in direction
    assert all(e.verdict.startswith('no: in a direction') for e in stats.estimates)


def test_a_value_on_its_bound_is_flagged_and_an_interrupted_fit_is_not_judged():
    fitted = fit_parameters(['inertia_table'], {}, {'inertia_table': (50.0, 60.0)})
    rng = np.random.default_rng(SEED)
    t, y = _linear(rng, 46.0)                       # the truth is below the bound
    residual = 50.0 * t - y
    stats = statistics(fitted, np.log([50.0]), residual, (50.0 * t)[:, None])
    e, = stats.estimates
    assert 'at its lower bound 50: widen --bounds' in e.undetermined and e.at_bound
    assert e.advice.startswith('widen --bounds inertia_table=')
    unfinished, = statistics(fitted, np.log([55.0]), residual, None).estimates
    assert unfinished.verdict.startswith('not judged') and 'yes' not in unfinished.verdict


def test_recordings_that_disagree_are_named_and_consistent_ones_are_not():
    """Two data sets y = a·t: with a = 40 and 55 the joint fit holds for neither; with one
    a, 20 seeded noise draws never raise the 4σ alarm."""
    fitted = fit_parameters(['inertia_table'], {})
    for seed, slopes, expected in [(SEED, (40.0, 55.0), 2)] + [
            (s, (46.0, 46.0), 0) for s in range(SEED + 1, SEED + 21)]:
        rng = np.random.default_rng(seed)
        parts = [_linear(rng, slope) for slope in slopes]
        t = np.concatenate([p[0] for p in parts])
        y = np.concatenate([p[1] for p in parts])
        a = float(t @ y / (t @ t))
        found = disagreements(fitted, np.log([a]), a * t - y, (a * t)[:, None],
                              [len(p[0]) for p in parts], ['one', 'two'])
        assert len(found) == expected, f'seed {seed}: {found}'
    assert 'recording two alone puts inertia_table at 5' in found[1] if expected else True


def test_starts_at_another_minimum_make_the_intervals_local():
    fitted = fit_parameters(['inertia_table'], {})
    best = Estimate('inertia_table', 46.0, 46.1, 45.9, 46.1, 'kg·m²')
    found = start_disagreements(fitted, [best], [np.log([46.0]), np.log([52.0])],
                                [1.0, 7.0])
    assert len(found) == 1 and found[0].startswith('start 2 ended at another minimum')


def test_the_fitted_file_carries_the_joint_names_and_no_stale_value(tmp_path):
    base = tmp_path / 'base.yaml'
    base.write_text('/**:\n  ros__parameters:\n    # the bearing\'s 4 N·m breakaway, 4.5 N·m '
                    'nowhere\n    table_static_torque: 4.0   # N·m, breakaway\n'
                    '    table_coulomb_torque: 3.0\n', encoding='utf-8')
    fitted = Estimate('table_static_torque', 3.03, 4.0, 2.9, 3.1, 'N·m')
    names = ['motor_a', 'axis', 'motor_b']
    out = write_fitted(base, tmp_path / 'fitted.yaml', [fitted], ['test'],
                       {'joint_names': names})
    simulation = Simulation.from_yaml(out)
    assert simulation.params.table_static_torque == 3.03
    assert list(simulation.settings.joint_names) == names
    text = out.read_text(encoding='utf-8')
    assert '4 N·m (base; fitted 3.03 N·m) breakaway' in text and '4.5 N·m nowhere' in text
    assert not list(tmp_path.glob('.*partial'))


@pytest.fixture(scope='module')
def tiny(tmp_path_factory):
    root = tmp_path_factory.mktemp('outcomes')
    bag = root / 'tiny'
    truth_simulation().run(lambda o: 5.0 if o.time < 0.4 else -5.0, 0.8, record=bag)
    return {'root': root, 'bag': bag, 'base': write_base(root / 'base.yaml', ['inertia_table'])}


def test_a_model_that_diverges_everywhere_is_exit_2_naming_where(tiny, capsys):
    """A parametric pump of the mesh stiffness at twice the natural frequency, without
    mesh damping (test/support/diverging.py's), in the base file: no fit, no file."""
    root = tiny['root']
    base = base_values(tiny['base'])
    pump = {'mode': 'conventional', 'backlash': 0.0, 'mesh_phase': 'time',
            'mesh_stiffness_amplitude': 5.0e6, 'mesh_damping': 0.0}
    params, _ = model({**base, **pump})
    pump['mesh_frequency'] = 2.0 * natural_frequency(params)
    unstable = write_base(root / 'unstable.yaml', ['inertia_table'], pump)
    code = main([str(tiny['bag']), '--params', str(unstable), '--fit', 'inertia_table',
                 '--starts', '2', '--max-evaluations', '4', '--no-progress', '-o',
                 str(root / 'diverged.yaml')])
    err = capsys.readouterr().err
    assert code == 2, err
    assert 'diverged at every point' in err and 'non-finite between t = ' in err, err
    assert str(tiny['bag']) in err and not (root / 'diverged.yaml').exists()


def test_no_effect_refused_points_and_starts_are_reported(tiny):
    """inertia_table with a parameter of no effect keeps its interval from the fit of it
    alone; max_torque below the recorded ±5 N·m is a refused trial point, a large
    residual; two starts are both listed."""
    alone = screwgear_ros.identify([tiny['bag']], tiny['base'], ['inertia_table'],
                                   starts_count=1, max_evaluations=8)
    both = screwgear_ros.identify([tiny['bag']], tiny['base'],
                                  ['inertia_table', 'thermal_coefficient'],
                                  bounds={'thermal_coefficient': (0.0, 1e-3)},
                                  starts_count=2, max_evaluations=8, seed=3)
    inertia = both.estimates[0]
    assert not inertia.undetermined and abs(inertia.value / 48.0 - 1) < 1e-3
    assert inertia.low == pytest.approx(alone.estimates[0].low, rel=1e-4)
    assert both.undetermined == ['thermal_coefficient']
    lines = summary(both)
    assert sum(line.startswith('start ') for line in lines) == 2, lines
    refused = screwgear_ros.identify([tiny['bag']], tiny['base'], ['max_torque'],
                                     bounds={'max_torque': (1.0, 8.0)}, starts_count=1,
                                     max_evaluations=6)
    assert refused.finished and refused.values['max_torque'] >= 5.0


def test_two_tables_fitted_together_are_said_to_disagree(tiny):
    root = tiny['root']
    bags = []
    for inertia in (40.0, 55.0):
        bag = root / f'table_{inertia:g}'
        truth_simulation(inertia_table=inertia).run(
            lambda o: 5.0 if o.time < 0.4 else -5.0, 0.8, record=bag)
        bags.append(bag)
    result = screwgear_ros.identify(bags, tiny['base'], ['inertia_table'], starts_count=1,
                                    max_evaluations=8)
    warnings = result.statistics.warnings
    assert any('disagree' in w and str(bags[0]) in w for w in warnings), warnings
    assert any(line.startswith('WARNING: recording') for line in summary(result))


def test_ctrl_c_while_writing_names_what_is_written(tiny, capsys, monkeypatch):
    written = tiny['root'] / 'stopped.yaml'
    real = api.write_report

    def interrupted(*args, **kwargs):
        signal.raise_signal(signal.SIGINT)          # Ctrl-C as the report is written
        return real(*args, **kwargs)
    monkeypatch.setattr(api, 'write_report', interrupted)
    code = main([str(tiny['bag']), '--params', str(tiny['base']), '--fit', 'inertia_table',
                 '--starts', '1', '--max-evaluations', '3', '--no-progress', '-o',
                 str(written)])
    err = capsys.readouterr().err
    assert code == 130 and f'{written} written complete' in err, err
    assert 'nothing written' not in err
    assert Simulation.from_yaml(written).params.inertia_table > 0
    assert random.Random(SEED).random() < 1      # the seed's module constant is used

