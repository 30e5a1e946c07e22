"""screwgear_ros.envs.table_env: Gymnasium's own checker, determinism, and the env as a thin layer
over Simulation."""

from __future__ import annotations

import math

import numpy as np
import pytest

gymnasium = pytest.importorskip('gymnasium')
from gymnasium.utils.env_checker import check_env

from screwgear_ros import Simulation
from screwgear_ros.envs.table_env import ENV_ID, OBSERVATION, InvalidAction, ScrewgearTableEnv
from screwgear_ros.inprocess.scenario import SetpointProfile


def test_gymnasium_check_env_passes():
    check_env(ScrewgearTableEnv(duration=0.05), skip_render_check=True)
    env = gymnasium.make(ENV_ID, duration=0.05, randomize={'backlash': (0.0, 1e-4)})
    check_env(env.unwrapped, skip_render_check=True)
    assert env.observation_space.shape == (len(OBSERVATION),)


def test_the_env_steps_the_simulation_tick_by_tick():
    target = SetpointProfile('steps', points=((0.0, 0.02),))
    env = ScrewgearTableEnv(duration=0.02, target=target,
                            parameters={'command_timeout': 0.0, 'table_damping': 8867.0})
    sim = Simulation.from_values(command_timeout=0.0, table_damping=8867.0)
    first = sim.reset()
    obs, info = env.reset(seed=3)
    assert info['parameters'] == {}
    assert obs.tolist() == [*first.position, *first.velocity, first.transmission_error, 0.02,
                            0.02 - first.position[1]]
    actions = [150.0, -999.0, 80.0] + [0.0] * 17     # -999 is clipped to -max_torque
    for k, u in enumerate(actions):
        obs, reward, terminated, truncated, info = env.step(np.array([u]))
        o = sim.step(max(-400.0, u))
        assert obs[:6].tolist() == [*o.position, *o.velocity]
        error = 0.02 - o.position[1]
        assert reward == pytest.approx(-(1.0 - math.exp(-0.5 * (error / 1e-2) ** 2))
                                       - 1e-3 * (max(-400.0, u) / 400.0) ** 2,
                                       rel=1e-12)
        assert not terminated and truncated == (k == len(actions) - 1)
    assert info['time'] == pytest.approx(0.02)


def test_the_seed_draws_only_what_randomize_names():
    plain = ScrewgearTableEnv(duration=0.01)
    a, _ = plain.reset(seed=1)
    b, _ = plain.reset(seed=2)
    assert a.tobytes() == b.tobytes()              # nothing random without randomize
    env = ScrewgearTableEnv(duration=0.01, randomize={'preload_torque': (200.0, 350.0),
                                                      'backlash': (0.0, 1e-4)})
    draws = [env.reset(seed=s)[1]['parameters'] for s in (7, 7, 8)]
    assert draws[0] == draws[1] != draws[2]
    assert set(draws[0]) == {'preload_torque', 'backlash'}
    assert 200.0 <= draws[2]['preload_torque'] <= 350.0
    assert env.simulation.params.preload_torque == draws[2]['preload_torque']
    # everything else is the base simulation's
    assert env.simulation.params.replace(preload_torque=350.0, backlash=75e-6) == \
        Simulation().params


def test_bad_settings_are_refused():
    with pytest.raises(ValueError, match='backlash'):
        ScrewgearTableEnv(randomize={'backlash': (-1.0, 1.0)})
    with pytest.raises(ValueError, match='no_such'):
        ScrewgearTableEnv(randomize={'no_such': (0.0, 1.0)})
    env = ScrewgearTableEnv()
    env.reset(seed=0)
    with pytest.raises(InvalidAction):
        env.step(np.array([math.nan]))
