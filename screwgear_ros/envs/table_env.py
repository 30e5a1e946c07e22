"""A Gymnasium environment of the table: ``ScrewgearTable-v0``, a thin layer over
:class:`~screwgear_ros.inprocess.simulation.Simulation` (``pip install screwgear_ros[gym]``).

One environment step is one tick of the node (1/``publish_rate`` s of simulation time):
the action takes effect at the tick's first step, as a lockstep controller's answer does.

* **Action**: ``Box(-max_torque, max_torque, (1,), float64)``, the signed drive torque,
  N·m, exactly cmd_effort's value: the sign is the direction (path), the magnitude the
  torque; 0 keeps the direction. An action outside the box is clipped to it (a drive's
  own torque limit). An action that is not one finite number (another shape, as
  ``[5., 6.]`` or ``[]``; not a number, as ``'abc'`` or a dict; NaN, ±inf or beyond
  float64) is refused with :class:`InvalidAction` (a ValueError), as Gymnasium's
  ``Box.contains`` refuses it, and nothing is integrated.
* **Observation**: ``Box(-inf, inf, (9,), float64)``: θ1, θ2, θ3 (rad), ω1, ω2, ω3
  (rad/s) of pinion 1, the table and pinion 3; the transmission error of the active path
  (m); the target table angle at this instant (rad); the tracking error target − θ2 (rad).
* **Reward**: ``−(1 − exp(−½ (e / error_scale)²)) − effort_weight · (u / max_torque)²``
  per step, with e the tracking error after the step (rad) and u the action (clipped):
  a Gaussian tracking cost, 0 on target and −1 far from it, with a little effort
  penalty. Each step's reward is in [−1 − effort_weight, 0] and an episode's return in
  [−(1 + effort_weight) · steps, 0], so the mean reward per step reads as a score: with
  the defaults (``error_scale`` 0.01 rad, a tracking error of 10 mrad costs 0.39) and
  the default target over 3 s, no drive scores about −1.0 per step, uniformly random
  actions about −0.99, the demo controller about −0.11. ``error_scale`` is a finite
  number > 0, ``effort_weight`` a finite number >= 0 (ValueError otherwise).
* **Target**: ``target(t)``, t in s from the episode's start → table angle in rad; any
  callable, e.g. a :class:`~screwgear_ros.inprocess.scenario.SetpointProfile` (a square period
  under two ticks is refused, ValueError naming the bound). Default: a square wave
  ±0.05 rad with a 3 s period (the demo controller's profile).
* **Episode**: ends (``truncated``) after ``duration`` s of simulation time;
  ``terminated`` when the model diverges (the plant then stands still, ``info['fault']``
  says why).
* **Making it**: ``gymnasium.make('screwgear_ros.envs:ScrewgearTable-v0')`` imports
  the package's environments and makes it in one call (Gymnasium 1.x loads no plugin
  entry points, so the module part of the id is what registers it); after
  ``import screwgear_ros.envs``, ``gymnasium.make('ScrewgearTable-v0')`` works too.
* **Randomness**: none unless asked. ``randomize`` maps parameter names to uniform ranges
  (low, high), or to ``{'times': OTHER, 'ratio': (low, high)}`` (derived: OTHER's value
  times a drawn ratio, :mod:`.randomize`); :meth:`~ScrewgearTableEnv.reset` with a seed
  draws each from the environment's ``np_random`` (the same seed, the same draw) and
  validates the result as the node would, drawing again a draw the node refuses
  (``info['redraws']`` counts them, ``redraws`` over all resets). Nothing else is random:
  without ``randomize`` every episode is the same.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from ..errors import ScrewgearError
from ..inprocess.scenario import SetpointProfile
from ..inprocess.simulation import Observation, Simulation
from .randomize import Randomizer

ENV_ID = 'ScrewgearTable-v0'
#: The observation's entries, in order.
OBSERVATION = ('theta_1', 'theta_2', 'theta_3', 'omega_1', 'omega_2', 'omega_3',
               'transmission_error', 'target', 'tracking_error')
DEFAULT_TARGET = SetpointProfile('square', amplitude=0.05, period=3.0)
#: The default error scale of the reward, rad (module docstring).
ERROR_SCALE = 1e-2
#: The default weight of the effort penalty.
EFFORT_WEIGHT = 1e-3


class InvalidAction(ScrewgearError, ValueError):
    """An action that is not one finite number of N·m; the message says what it was."""


def _setting(name: str, value: Any, low: float, strict: bool) -> float:
    """A reward setting as a finite float >= ``low`` (> if ``strict``); ValueError."""
    try:
        number = float(value)
    except (TypeError, ValueError, OverflowError):
        number = math.nan
    if isinstance(value, bool) or not math.isfinite(number) or (
            number <= low if strict else number < low):
        raise ValueError(f'{name} must be a finite number {">" if strict else ">="} {low:g}, '
                         f'not {value!r:.60}')
    return number


def _action(action: Any) -> float:
    """The one number of an action (InvalidAction for anything else)."""
    try:
        values = np.asarray(action, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as exc:
        raise InvalidAction(f'an action is one finite torque, N·m (shape (1,)); got '
                            f'{type(action).__name__} {action!r:.60}: {exc}') from None
    if values.size != 1 or values.ndim > 1:
        raise InvalidAction(f'an action is one finite torque, N·m (shape (1,)); got shape '
                            f'{values.shape}')
    u = float(values.reshape(-1)[0])
    if not math.isfinite(u):
        raise InvalidAction(f'an action is one finite torque, N·m; got {u!r}')
    return u


class ScrewgearTableEnv(gymnasium.Env):
    """The table as a Gymnasium environment; see the module docstring."""

    metadata: dict[str, Any] = {'render_modes': []}  # noqa: RUF012 - gymnasium.Env's own declaration

    def __init__(self, simulation: Simulation | None = None, *, duration: float = 3.0,
                 target: Callable[[float], float] | None = None,
                 error_scale: float = ERROR_SCALE, effort_weight: float = EFFORT_WEIGHT,
                 randomize: Mapping[str, Any] | None = None,
                 parameters: Mapping[str, Any] | None = None,
                 render_mode: str | None = None) -> None:
        if render_mode is not None:
            raise ValueError(f'{ENV_ID} renders nothing (render_mode {render_mode!r})')
        base = simulation or Simulation()
        if parameters:
            base = base.with_values(**parameters)
        self.base = base
        self.randomizer = Randomizer(base, randomize)
        self.randomize = dict(randomize or {})
        self.redraws = 0                   # draws the node refused, over all resets
        self.duration = _setting('duration', duration, 0.0, strict=True)
        self.target = target or DEFAULT_TARGET
        if not callable(self.target):
            raise TypeError(f'target must be a callable t -> rad, not {self.target!r:.60}')
        check_tick = getattr(self.target, 'check_tick', None)
        if check_tick is not None:
            check_tick(base.tick_period)
        self.error_scale = _setting('error_scale', error_scale, 0.0, strict=True)
        self.effort_weight = _setting('effort_weight', effort_weight, 0.0, strict=False)
        limit = base.params.max_torque
        self._limit = float(limit)
        self.action_space = spaces.Box(-limit, limit, shape=(1,), dtype=np.float64)
        self.observation_space = spaces.Box(-np.inf, np.inf, shape=(len(OBSERVATION),),
                                            dtype=np.float64)
        self.render_mode = None
        self.simulation = base
        self._t0 = 0.0
        self._steps = 0
        self._max_steps = max(1, round(self.duration / base.tick_period))

    def _observe(self, o: Observation) -> np.ndarray:
        target = self.target(o.time - self._t0)
        return np.array([*o.position, *o.velocity, o.transmission_error, target,
                         target - o.position[1]], dtype=np.float64)

    def reset(self, *, seed: int | None = None,
              options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        drawn, self.simulation, redraws = self.randomizer.draw(self.np_random)
        self.redraws += redraws
        limit = self.simulation.params.max_torque
        if limit != self._limit:
            raise ValueError('randomize must not change max_torque (it is the action space)')
        first = self.simulation.reset()
        self._t0 = first.time
        self._steps = 0
        return self._observe(first), {'parameters': drawn, 'time': first.time,
                                      'redraws': redraws}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        u = _action(action)
        limit = self._limit
        u = min(limit, max(-limit, u))
        o = self.simulation.step(u)
        self._steps += 1
        observation = self._observe(o)
        error = observation[-1]
        reward = (-(1.0 - math.exp(-0.5 * (error / self.error_scale) ** 2))
                  - self.effort_weight * (u / limit) ** 2)
        terminated = o.fault is not None
        truncated = self._steps >= self._max_steps and not terminated
        return observation, float(reward), terminated, truncated, {
            'time': o.time, 'active_path': o.active_path, 'fault': o.fault}


gymnasium.register(id=ENV_ID, entry_point='screwgear_ros.envs.table_env:ScrewgearTableEnv')

__all__ = ['DEFAULT_TARGET', 'EFFORT_WEIGHT', 'ENV_ID', 'ERROR_SCALE', 'OBSERVATION',
           'InvalidAction', 'ScrewgearTableEnv']
