"""Seeded fuzz of the Gymnasium env's inputs: every action that is not one finite number
is refused with InvalidAction (nothing integrated), as Gymnasium's Box refuses it; reward
settings and targets that make no reward are refused at construction."""

from __future__ import annotations

import math
import random
import time
from typing import Any

import numpy as np
import pytest

gymnasium = pytest.importorskip('gymnasium')

from screwgear_ros.envs.table_env import InvalidAction, ScrewgearTableEnv
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


def _setting(rng: random.Random) -> tuple[dict[str, Any], bool]:
    name = rng.choice(('error_scale', 'effort_weight'))
    value = rng.choice((0.0, -1.0, math.nan, math.inf, 'abc', None, True,
                        10 ** 400, rng.uniform(1e-6, 10.0)))
    if isinstance(value, float) and math.isfinite(value):
        valid = value > 0.0 or (name == 'effort_weight' and value == 0.0)
    else:
        valid = False
    return {name: value}, valid


def test_reward_settings_and_targets_that_make_no_reward_are_refused() -> None:
    rng = random.Random(SEED + 1)
    started = time.monotonic()
    for case in range(CASES):
        if rng.random() < 0.5:
            kwargs, valid = _setting(rng)
        else:
            period = 10.0 ** rng.uniform(-323.5, 1.0)
            kwargs = {'target': SetpointProfile('square', amplitude=0.01, period=period)
                      if period > 1e-300 else period}
            valid = period >= 2e-3
        try:
            ScrewgearTableEnv(duration=0.01, **kwargs)
        except (ValueError, TypeError) as exc:
            assert not valid, f'seed {SEED + 1} case {case}: {kwargs!r:.80} refused: {exc}'
        except Exception as exc:  # noqa: BLE001
            pytest.fail(f'seed {SEED + 1} case {case}: {type(exc).__name__}: {exc}')
        else:
            assert valid, f'seed {SEED + 1} case {case}: {kwargs!r:.80} accepted'
        assert time.monotonic() - started < BUDGET, f'seed {SEED + 1}: over budget at {case}'


def test_rewards_are_bounded_and_no_drive_scores_near_minus_one() -> None:
    """Mean reward per step in [-1, 0]: no drive scores near -1 (the module docstring)."""
    env = ScrewgearTableEnv(duration=0.3)
    env.reset(seed=0)
    rewards = [env.step(np.array([0.0]))[1] for _ in range(300)]
    assert -1.0 <= np.mean(rewards) < -0.9
    assert all(-1.0 - env.effort_weight <= r <= 0.0 for r in rewards)
