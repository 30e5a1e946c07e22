"""Seeded fuzz of the Gymnasium env's inputs: every action that is not one finite number
is refused with InvalidAction (nothing integrated), as Gymnasium's Box refuses it; every
keyword argument that breaks its rule is refused at construction with a message naming
it and the rule; a target without a finite angle is refused before the step."""

from __future__ import annotations

import math
import random
import time
from typing import Any

import numpy as np
import pytest

gymnasium = pytest.importorskip('gymnasium')

from screwgear_ros.envs.table_env import EnvArgumentError, InvalidAction, ScrewgearTableEnv
from screwgear_ros.inprocess.setpoint_profile import SetpointProfile

SEED = 3706
CASES = 300
BUDGET = 120.0


def _action(rng: random.Random) -> tuple[Any, bool]:
    """An action and whether the box takes it (one finite number)."""
    kind = rng.randrange(10)
    if kind == 0:
        return np.array([]), False
    if kind == 1:
        return rng.choice(('abc', '', 'nan?')), False
    if kind == 2:
        return {'u': 1.0}, False
    if kind == 3:
        return rng.choice((1, -1)) * 10 ** rng.randint(309, 3000), False
    if kind == 4:
        return [rng.uniform(-500, 500) for _ in range(rng.randint(2, 4))], False
    if kind == 5:
        return [rng.uniform(-500, 500), rng.choice((math.nan, math.inf))], False
    if kind == 6:
        return np.array([rng.choice((math.nan, math.inf, -math.inf))]), False
    if kind == 7:
        return np.full((1, 1, rng.randint(2, 3)), 1.0), False
    if kind == 8:
        return rng.uniform(-1e3, 1e3), True                    # a bare number: as [u]
    return np.array([rng.uniform(-1e3, 1e3)]), True


def test_an_action_that_is_not_one_finite_number_is_refused() -> None:
    rng = random.Random(SEED)
    env = ScrewgearTableEnv(duration=10.0)
    env.reset(seed=0)
    started = time.monotonic()
    for case in range(CASES):
        action, valid = _action(rng)
        step = env.simulation.session.step
        try:
            out = env.step(action)
        except InvalidAction:
            assert not valid, f'seed {SEED} case {case}: a valid action refused'
            assert env.simulation.session.step == step, f'seed {SEED} case {case}'
        except Exception as exc:  # noqa: BLE001 - the finding: anything undocumented
            pytest.fail(f'seed {SEED} case {case}: {type(exc).__name__}: {exc}')
        else:
            assert valid, f'seed {SEED} case {case}: took an action the box refuses'
            assert math.isfinite(out[1]) and -1.0 - env.effort_weight <= out[1] <= 0.0
        assert time.monotonic() - started < BUDGET, f'seed {SEED}: over budget at {case}'


#: Values a hostile caller passes for a number.
NUMBERS = (0.0, -1.0, math.nan, math.inf, -math.inf, 'abc', None, True, 10 ** 400, [1.0],
           1e-300, 1e300)


def _number(rng: random.Random, good: float) -> Any:
    return rng.choice((*NUMBERS, good, good, good))


def _finite(value: Any) -> bool:
    return isinstance(value, float) and math.isfinite(value)


def _kwargs(rng: random.Random) -> tuple[dict[str, Any], set[str]]:
    """Keyword arguments, some hostile, and the names of those the env must refuse
    (the rules, written here from the module docstring, not from the code)."""
    kwargs: dict[str, Any] = {}
    bad: set[str] = set()
    if rng.random() < 0.5:
        kwargs['duration'] = d = _number(rng, 0.01)
        if not (_finite(d) and d > 0.0) or d > 1.0:
            if not (_finite(d) and d > 0.0):
                bad.add('duration')
            else:
                kwargs['duration'] = 0.01       # a long valid one would only cost time
    if rng.random() < 0.5:
        kwargs['error_scale'] = s = _number(rng, 1e-7)
        if not (_finite(s) and s > 0.0):
            bad.add('error_scale')
    if rng.random() < 0.5:
        kwargs['error_limit'] = lim = _number(rng, 0.05)
        scale = kwargs.get('error_scale', 2.0 * math.pi / 2 ** 26)
        if not (_finite(lim) and lim > 0.0) or ('error_scale' not in bad and lim <= scale):
            bad.add('error_limit')
    elif _finite(kwargs.get('error_scale')) and kwargs['error_scale'] >= 0.05:
        bad.add('error_limit')                      # the default limit is not above it
    if rng.random() < 0.5:
        kwargs['effort_weight'] = w = _number(rng, 1e-3)
        if not (_finite(w) and w >= 0.0):
            bad.add('effort_weight')
    if rng.random() < 0.3:
        kwargs['render_mode'] = rng.choice(('human', 'rgb_array', '', 3))
        bad.add('render_mode')
    if rng.random() < 0.3:
        kwargs['simulation'] = rng.choice(('paper.yaml', 3, {'dt': 1e-4}))
        bad.add('simulation')
    if rng.random() < 0.4:
        kwargs['parameters'] = p = rng.choice((
            {'inertia_table': 40.0}, {'inertia_table': -1.0}, {'no_such': 1.0}, {3: 1.0},
            ['inertia_table'], 'inertia_table=40', {'backlash': math.nan}))
        if p != {'inertia_table': 40.0}:
            bad.add('parameters')
    if rng.random() < 0.3:
        period = 10.0 ** rng.uniform(-323.5, 1.0)
        kwargs['target'] = rng.choice((
            3.0, 'square', SetpointProfile('square', amplitude=0.01, period=period)))
        if not isinstance(kwargs['target'], SetpointProfile) or period < 2e-3:
            bad.add('target')
    return kwargs, bad


def test_keyword_arguments_are_refused_naming_the_argument_and_its_rule() -> None:
    """A seeded family over every keyword argument (randomize has its own tests): a set
    with a hostile value is refused with EnvArgumentError naming one of the hostile
    arguments and its rule; a valid set makes an env that resets and steps to finite
    values."""
    rng = random.Random(SEED + 1)
    started = time.monotonic()
    for case in range(CASES):
        kwargs, bad = _kwargs(rng)
        where = f'seed {SEED + 1} case {case}: {kwargs!r:.160}'
        try:
            env = ScrewgearTableEnv(**{'duration': 0.01, **kwargs})
        except EnvArgumentError as exc:
            text = str(exc)
            assert bad, f'{where}: refused: {text}'
            assert any(text.startswith(name) for name in bad), f'{where}: {text}'
            assert 'must' in text or 'refused' in text, f'{where}: {text}'   # the rule
        except Exception as exc:  # noqa: BLE001 - the finding: anything undocumented
            pytest.fail(f'{where}: {type(exc).__name__}: {exc}')
        else:
            assert not bad, f'{where}: accepted, though {sorted(bad)} break their rules'
            obs, _ = env.reset(seed=case)
            obs, reward, *_ = env.step(np.array([0.5]))
            assert obs in env.observation_space and math.isfinite(reward), where
        assert time.monotonic() - started < BUDGET, f'seed {SEED + 1}: over budget at {case}'


def _target(rng: random.Random) -> tuple[Any, bool]:
    """A target callable and whether it always returns a finite angle."""
    kind = rng.randrange(9)
    if kind == 0:
        return (lambda t: math.nan), False
    if kind == 1:
        return (lambda t: rng.choice((math.inf, -math.inf))), False
    if kind == 2:
        return (lambda t: None), False
    if kind == 3:
        return (lambda t: '0.01'), False
    if kind == 4:
        return (lambda t: 1.0 / 0.0), False                 # it raises
    if kind == 5:
        return (lambda t: 10 ** 400), False
    if kind == 6:                                            # NaN from a later time on
        return (lambda t: 0.01 if t < 0.004 else np.float64('nan')), False
    if kind == 7:
        return (lambda t: np.float32(0.01)), True
    return (lambda t: 0.01 * math.sin(t)), True


def test_a_target_that_returns_no_finite_angle_is_refused_before_the_step() -> None:
    """A seeded family of targets: NaN, ±inf, None, text, an exception, an int beyond
    float64, NaN only later. Each is refused with EnvArgumentError naming ``target`` and
    the time, before the step is integrated; no observation or reward is ever NaN."""
    rng = random.Random(SEED + 2)
    for case in range(60):
        target, valid = _target(rng)
        env = ScrewgearTableEnv(duration=0.01, target=target)
        where = f'seed {SEED + 2} case {case}'
        try:
            obs, _ = env.reset(seed=0)
            for _ in range(10):
                step = env.simulation.session.step
                try:
                    obs, reward, *_ = env.step(np.array([0.1]))
                except EnvArgumentError:
                    assert env.simulation.session.step == step, f'{where}: integrated'
                    raise
                assert math.isfinite(reward), where
                assert np.all(np.isfinite(obs)), where
        except EnvArgumentError as exc:
            assert not valid, f'{where}: {exc}'
            assert str(exc).startswith('target') and 't = ' in str(exc), f'{where}: {exc}'
        except Exception as exc:  # noqa: BLE001
            pytest.fail(f'{where}: {type(exc).__name__}: {exc}')
        else:
            assert valid, f'{where}: a target without a finite angle was taken'


def test_rewards_are_bounded_and_no_drive_scores_near_minus_one() -> None:
    """Mean reward per step in [-1, 0]: no drive scores near -1 (the module docstring)."""
    env = ScrewgearTableEnv(duration=0.3)
    env.reset(seed=0)
    rewards = [env.step(np.array([0.0]))[1] for _ in range(300)]
    assert -1.0 <= np.mean(rewards) < -0.9
    assert all(-1.0 - env.effort_weight <= r <= 0.0 for r in rewards)
