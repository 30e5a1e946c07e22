"""Linear models of a table with bearing friction (design/friction_state.py): refused at
rest, sliding in steady rotation with the speed the simulation reaches, left out only on
request, and never the frozen model's kHz "poles" of differences across stiction."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from screwgear_ros import Simulation
from screwgear_ros.cli.linearize import load_params, main
from screwgear_ros.design.friction_state import (
    FrictionState,
    FrictionUndefined,
    linearize_with_friction,
    without_friction,
)
from screwgear_ros.design.linearize import linearize

REALISTIC = Path(__file__).parents[3] / 'config' / 'realistic.yaml'


@pytest.fixture(scope='module')
def params():
    return load_params(str(REALISTIC))


@pytest.mark.parametrize('mesh', ['average', 'frozen'])
def test_at_rest_stuck_bearings_are_refused_with_the_reason(params, mesh):
    with pytest.raises(FrictionUndefined) as caught:
        linearize_with_friction(params, 0.0, 0.0, 1, mesh)
    text = str(caught.value)
    assert 'stuck' in text and 'table_static_torque 4 N·m' in text and '--torque' in text


def test_the_tool_exits_2_naming_the_friction(capsys, tmp_path):
    assert main(['--params', str(REALISTIC), '--mesh', 'frozen',
                 '-o', str(tmp_path / 'm.npz')]) == 2
    assert 'stuck' in capsys.readouterr().err
    assert not (tmp_path / 'm.npz').exists()


def test_ignore_is_the_table_without_friction_and_says_so(params):
    model, state, note = linearize_with_friction(params, 0.0, 0.0, 1, 'frozen', ignore=True)
    bare = linearize(without_friction(params), 0.0, 0.0, 1, 'frozen')
    assert state is FrictionState.IGNORED and 'left out' in note
    assert np.array_equal(model.a, bare.a)
    # a frictionless frozen model has its mesh modes, no stiction "poles" above 100 kHz
    assert max(abs(np.linalg.eigvals(model.a))) < 2 * np.pi * 1e4


def test_sliding_in_rotation_slows_the_point_as_the_friction_slows_the_simulation(params):
    """The steady speed of the linear model's point with the Coulomb torques counted,
    against the table without friction: the drop matches the drop of the simulation's
    mean table speed under the same constant command (over 2 s after 1 s; the slowest
    mode's time constant is 13 ms, the mean over thousands of mesh periods) within 25 %.
    (The operating point's speed itself is some 6 % above the simulation's on this
    table, friction or not: that is the operating point's, not the friction's.)"""
    torque = 300.0
    model, state, note = linearize_with_friction(params, torque, 0.0, 1, 'average')
    assert state is FrictionState.SLIDING and 'sliding' in note and model.point.load == 0.0
    bare = without_friction(params)
    drop = linearize(bare, torque, 0.0, 1).point.state[4] - model.point.state[4]
    speeds = []
    for overrides in ({}, {name: 0.0 for name in ('table_coulomb_torque',
                                                  'table_static_torque',
                                                  'pinion_coulomb_torque',
                                                  'pinion_static_torque')}):
        simulation = Simulation.from_yaml(REALISTIC, command_timeout=0.0, **overrides)
        run = simulation.run(lambda o: torque, 3.0)
        speeds.append(float(np.mean(run.true_velocity[1000:, 1])))
    assert drop == pytest.approx(speeds[1] - speeds[0], rel=0.25)
    # sliding friction has no slope there: the same A as the table without it
    assert np.allclose(model.a, linearize(bare, torque, 0.0, 1).a,
                       rtol=1e-9, atol=1e-9 * np.abs(model.a).max())
