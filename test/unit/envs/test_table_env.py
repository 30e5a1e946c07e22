"""screwgear_ros.envs.table_env: Gymnasium's own checker (with nothing to warn of),
determinism, the env as a thin layer over Simulation, and a reward that sees a
precision table's last encoder counts."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

gymnasium = pytest.importorskip('gymnasium')
from gymnasium.utils.env_checker import check_env

from screwgear_ros import Simulation, config_path
from screwgear_ros.envs.table_env import ENV_ID, OBSERVATION, InvalidAction, ScrewgearTableEnv
from screwgear_ros.inprocess.scenario import SetpointProfile

COUNT = 2.0 * math.pi / 2 ** 26         # one count of the realistic table's encoder, rad


def test_gymnasium_check_env_passes_without_a_warning():
    """The real checker, warnings recorded: a finite, normalised observation box and a
    [-1, 1] action box leave it nothing to warn of (it warned of three before)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter('always')
        check_env(ScrewgearTableEnv(duration=0.05), skip_render_check=True)
        env = gymnasium.make(ENV_ID, duration=0.05, randomize={'backlash': (0.0, 1e-4)})
        check_env(env.unwrapped, skip_render_check=True)
    assert [str(w.message) for w in caught] == []
    assert env.observation_space.shape == (len(OBSERVATION),)
    assert np.all(np.isfinite(env.observation_space.low))
    assert np.all(np.isfinite(env.observation_space.high))


def test_the_env_steps_the_simulation_tick_by_tick():
    target = SetpointProfile('steps', points=((0.0, 0.02),))
    env = ScrewgearTableEnv(duration=0.02, target=target,
                            parameters={'command_timeout': 0.0, 'table_damping': 8867.0})
    sim = Simulation.from_values(command_timeout=0.0, table_damping=8867.0)
    first = sim.reset()
    obs, info = env.reset(seed=3)
    assert info['parameters'] == {}
    assert info['observation'].position == first.position
    # the scaled entries, from the table's own numbers: half turns, the no-load speed
    # (240 r/min) at the pinions and over r2/r1 at the table, mm, and the error's decades
    pinion = 8.0 * math.pi
    table = pinion * 0.078 / 0.582
    scale, limit = 2.0 * math.pi / 2 ** 26, 0.05

    def expected(o) -> list[float]:
        def wrap(a):
            return math.remainder(a, 2.0 * math.pi) / math.pi
        e = 0.02 - o.position[1]
        cost = min(1.0, math.log1p(abs(e) / scale) / math.log1p(limit / scale))
        return [wrap(o.position[0]), o.position[1] / math.pi, wrap(o.position[2]),
                o.velocity[0] / pinion, o.velocity[1] / table, o.velocity[2] / pinion,
                o.transmission_error / 1e-3, 0.02 / math.pi, math.copysign(cost, e)]

    np.testing.assert_allclose(obs, expected(first), rtol=1e-12, atol=1e-15)
    actions = [0.375, -2.5, 0.2] + [0.0] * 17     # -2.5 is clipped to -1: -max_torque
    for k, a in enumerate(actions):
        obs, reward, terminated, truncated, info = env.step(np.array([a]))
        o = sim.step(400.0 * max(-1.0, a))
        assert info['observation'].position == o.position
        assert obs in env.observation_space
        np.testing.assert_allclose(obs, expected(o), rtol=1e-12, atol=1e-15)
        assert reward == pytest.approx(-abs(expected(o)[-1]) - 1e-3 * max(-1.0, a) ** 2,
                                       rel=1e-12)
        assert not terminated and truncated == (k == len(actions) - 1)
    assert info['time'] == pytest.approx(0.02)


def test_a_pd_stuck_hundreds_of_counts_off_scores_clearly_worse_than_a_precise_pid():
    """The realistic table (26-bit table encoder, bearing friction) held at 1 mrad for
    2 s, each law run in the environment on the exact values of info['observation']: the
    quick start's PD sticks thousands of counts short (the bearings hold it), a PID ends
    within a few counts; the mean reward per step tells them apart by a wide margin (with
    the former default, a Gaussian of 0.01 rad, both scored about 0)."""
    target = 1e-3
    sim = Simulation.from_yaml(config_path('realistic.yaml'))
    env = ScrewgearTableEnv(sim, duration=2.0, target=lambda t: target)
    limit = sim.params.max_torque

    def pd(o, _):
        return 2000.0 * (target - o.position[1]) - 300.0 * o.velocity[1]

    def pid(o, state):
        state[0] += (target - o.position[1]) * sim.tick_period
        return 1e5 * (target - o.position[1]) + 1e6 * state[0] - 3000.0 * o.velocity[1]

    scores, final = {}, {}
    for name, law in (('pd', pd), ('pid', pid)):
        _, info = env.reset(seed=0)
        state, rewards, done = [0.0], [], False
        while not done:
            u = max(-300.0, min(300.0, law(info['observation'], state)))
            _, reward, terminated, truncated, info = env.step(np.array([u / limit]))
            rewards.append(reward)
            done = terminated or truncated
        scores[name] = float(np.mean(rewards))
        final[name] = abs(target - info['observation'].position[1]) / COUNT
    assert final['pd'] > 300.0 and final['pid'] < 10.0, final
    assert scores['pid'] - scores['pd'] > 0.25, scores
    assert -1.0 < scores['pd'] < scores['pid'] < 0.0, scores


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
