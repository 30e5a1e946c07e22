"""A Gymnasium environment of the table: ``ScrewgearTable-v0``, a thin layer over
:class:`~screwgear_ros.inprocess.simulation.Simulation` (``pip install screwgear_ros[gym]``).

One environment step is one tick of the node (1/``publish_rate`` s of simulation time):
the action takes effect at the tick's first step, as a lockstep controller's answer does.

* **Action**: ``Box(-1, 1, (1,), float64)``, the signed drive torque as a fraction of
  ``max_torque`` (the torque is ``action · max_torque``, cmd_effort's value): the sign is
  the direction (path), the magnitude the torque; 0 keeps the direction. An action
  outside the box is clipped to it (a drive's own torque limit). An action that is not
  one finite number (another shape, as ``[5., 6.]`` or ``[]``; not a number, as ``'abc'``
  or a dict; NaN, ±inf or beyond float64) is refused with :class:`InvalidAction` (a
  ValueError), as Gymnasium's ``Box.contains`` refuses it, and nothing is integrated.
* **Observation**: a ``Box`` of finite bounds, each entry of order one
  (:mod:`screwgear_ros.envs.normalized`), so Gymnasium's ``check_env`` has nothing to
  warn of: θ1 and θ3 wrapped to a fraction of half a turn ([−1, 1)); θ2 / π; ω1, ω3 over
  the drive's no-load speed and ω2 over it times r1/r2; the transmission error of the
  active path / 1 mm; the target / π (all these clipped to ±10); and the tracking error
  target − θ2 compressed to [−1, 1] as the reward weighs it (below). The exact values,
  SI units, are ``info['observation']`` (an :class:`~screwgear_ros.inprocess.samples.Observation`),
  so a classic controller can run in the environment too.
* **Reward**: ``−min(1, ln(1 + |e|/error_scale) / ln(1 + error_limit/error_scale))
  − effort_weight · a²`` per step, with e the tracking error after the step (rad) and
  a the action (clipped): a tracking cost that weighs every decade of the error alike,
  0 on target and −1 at ``error_limit`` (default 0.05 rad) and beyond, with a little
  effort penalty. The default ``error_scale`` is one count of a 26-bit table encoder
  (2π/2²⁶ rad), so the last counts of a precision table count: on the realistic table,
  holding a 1 mrad target for 2 s, the quick start's PD sticks 3,500 counts short and
  scores −0.63 per step, a PID that ends within 3 counts −0.22 (with the former
  Gaussian of 0.01 rad both scored about 0). Each step's reward is in
  [−1 − effort_weight, 0] and an episode's return in [−(1 + effort_weight) · steps, 0],
  so the mean reward per step reads as a score: with the default target over 3 s, no
  drive scores −1.0 per step, uniformly random actions about −1.0, the demo controller
  about −0.32.
  ``error_scale`` is a finite number > 0, ``error_limit`` one > ``error_scale``,
  ``effort_weight`` a finite number >= 0.
* **Target**: ``target(t)``, t in s from the episode's start → table angle in rad; any
  callable, e.g. a :class:`~screwgear_ros.inprocess.scenario.SetpointProfile` (a square period
  under two ticks is refused, ValueError naming the bound). Default: a square wave
  ±0.05 rad with a 3 s period (the demo controller's profile). A target that fails or
  returns anything but a finite number is refused with :class:`EnvArgumentError` naming
  ``target`` and the time, before the step is integrated (never a NaN observation or
  reward).
* **Arguments**: a keyword argument the environment cannot use is refused at
  construction with :class:`EnvArgumentError` (a ValueError) naming it and its rule.
* **Episode**: ends (``truncated``) after ``duration`` s of simulation time;
  ``terminated`` when the model diverges (the plant then stands still, ``info['fault']``
  says why).
* **Making it**: ``gymnasium.make('screwgear_ros.envs:ScrewgearTable-v0')`` imports
  the package's environments and makes it in one call (Gymnasium 1.x loads no plugin
  entry points, so the module part of the id is what registers it); after
  ``import screwgear_ros.envs``, ``gymnasium.make('ScrewgearTable-v0')`` works too.
* **Randomness**: none unless asked. ``randomize`` maps parameter names to uniform ranges
  (low, high); :meth:`~ScrewgearTableEnv.reset` with a seed draws each from the
  environment's ``np_random`` (the same seed, the same draw) and validates the result as
  the node would. Nothing else is random: without ``randomize`` every episode is the same.
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
from ..inprocess.simulation import Simulation
from ..params.table import ParameterError
from .normalized import ERROR_LIMIT, ERROR_SCALE, Scales

ENV_ID = 'ScrewgearTable-v0'
#: The observation's entries, in order.
OBSERVATION = ('theta_1', 'theta_2', 'theta_3', 'omega_1', 'omega_2', 'omega_3',
               'transmission_error', 'target', 'tracking_error')
DEFAULT_TARGET = SetpointProfile('square', amplitude=0.05, period=3.0)
#: The default weight of the effort penalty.
EFFORT_WEIGHT = 1e-3


class InvalidAction(ScrewgearError, ValueError):
    """An action that is not one finite number; the message says what it was."""


class EnvArgumentError(ScrewgearError, ValueError):
    """A keyword argument (or a target's value) the environment cannot use; names it and
    the rule."""


def _setting(name: str, value: Any, low: float, strict: bool, bound: str = '') -> float:
    """A reward setting as a finite float >= ``low`` (> if ``strict``); EnvArgumentError
    (``bound`` names what ``low`` is)."""
    try:
        number = float(value)
    except (TypeError, ValueError, OverflowError):
        number = math.nan
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating,
                                                         np.integer)) \
            or not math.isfinite(number) or (number <= low if strict else number < low):
        raise EnvArgumentError(f'{name} must be a finite number {">" if strict else ">="} '
                               f'{bound}{low:g}, not {value!r:.60}')
    return number


def _simulation(simulation: Any, parameters: Any) -> Simulation:
    """The base simulation: ``simulation`` (default: the paper's table) with
    ``parameters`` on top; EnvArgumentError naming the argument."""
    if simulation is None:
        simulation = Simulation()
    elif not isinstance(simulation, Simulation):
        raise EnvArgumentError(f'simulation must be a screwgear_ros.Simulation (or None: '
                               f'the paper\'s table), not {type(simulation).__name__}')
    if parameters is None:
        return simulation
    if not isinstance(parameters, Mapping) or not all(isinstance(k, str) for k in parameters):
        raise EnvArgumentError(f'parameters must map parameter names (text) to values, not '
                               f'{parameters!r:.60}')
    try:
        return simulation.with_values(**parameters) if parameters else simulation
    except ParameterError as exc:
        raise EnvArgumentError(f'parameters: {exc}') from None


def _action(action: Any) -> float:
    """The one number of an action (InvalidAction for anything else)."""
    try:
        values = np.asarray(action, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as exc:
        raise InvalidAction(f'an action is one finite torque, N·m (shape (1,)); got '
                            f'{type(action).__name__} {action!r:.60}: {exc}') from None
    if values.size != 1 or values.ndim > 1:
        raise InvalidAction(f'an action is one finite number, the torque / max_torque '
                            f'(shape (1,)); got shape {values.shape}')
    u = float(values.reshape(-1)[0])
    if not math.isfinite(u):
        raise InvalidAction(f'an action is one finite number, the torque / max_torque; '
                            f'got {u!r}')
    return u


class ScrewgearTableEnv(gymnasium.Env):
    """The table as a Gymnasium environment; see the module docstring."""

    metadata: dict[str, Any] = {'render_modes': []}  # noqa: RUF012 - gymnasium.Env's own declaration

    def __init__(self, simulation: Simulation | None = None, *, duration: float = 3.0,
                 target: Callable[[float], float] | None = None,
                 error_scale: float = ERROR_SCALE, error_limit: float = ERROR_LIMIT,
                 effort_weight: float = EFFORT_WEIGHT,
                 randomize: Mapping[str, tuple[float, float]] | None = None,
                 parameters: Mapping[str, Any] | None = None,
                 render_mode: str | None = None) -> None:
        if render_mode is not None:
            raise EnvArgumentError(f'render_mode must be None: {ENV_ID} renders nothing, '
                                   f'not {render_mode!r:.60}')
        base = _simulation(simulation, parameters)
        self.base = base
        self.randomize = {name: (float(lo), float(hi))
                          for name, (lo, hi) in (randomize or {}).items()}
        for name, (lo, hi) in self.randomize.items():
            if not lo <= hi:
                raise ValueError(f'randomize {name}: low {lo:g} > high {hi:g}')
            base.with_values(**{name: lo})          # a name and a range the node takes
            base.with_values(**{name: hi})
        self.duration = _setting('duration', duration, 0.0, strict=True)
        self.target = DEFAULT_TARGET if target is None else target
        if not callable(self.target):
            raise EnvArgumentError(f'target must be a callable t (s) -> angle (rad), not '
                                   f'{self.target!r:.60}')
        check_tick = getattr(self.target, 'check_tick', None)
        if check_tick is not None:
            try:
                check_tick(base.tick_period)
            except ValueError as exc:
                raise EnvArgumentError(f'target: {exc}') from None
        self.error_scale = _setting('error_scale', error_scale, 0.0, strict=True)
        self.error_limit = _setting('error_limit', error_limit, self.error_scale, strict=True,
                                    bound='error_scale = ')
        self.effort_weight = _setting('effort_weight', effort_weight, 0.0, strict=False)
        self._limit = float(base.params.max_torque)
        self.action_space = spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float64)
        self._scales = Scales.of(base.params, self.error_scale, self.error_limit)
        low, high = self._scales.bounds()
        self.observation_space = spaces.Box(low, high, dtype=np.float64)
        self.render_mode = None
        self.simulation = base
        self._t0 = 0.0
        self._steps = 0
        self._max_steps = max(1, round(self.duration / base.tick_period))

    def _target(self, t: float) -> float:
        """The target at ``t`` s of the episode, a finite float; EnvArgumentError naming
        the target and the time otherwise (its own exception's type and text beside)."""
        try:
            value = self.target(t)
        except Exception as exc:  # noqa: BLE001 - the user's callable: anything, named
            raise EnvArgumentError(f'target failed at t = {t:g} s ({type(exc).__name__}: '
                                   f'{exc!s:.80}): a target is a callable t (s) -> a finite '
                                   'angle (rad)') from None
        number = math.nan
        if not isinstance(value, (bool, np.bool_)) and isinstance(
                value, (int, float, np.integer, np.floating)):
            try:
                number = float(value)
            except OverflowError:           # an int beyond float64
                number = math.inf
        if not math.isfinite(number):
            raise EnvArgumentError(f'target returned {value!r:.60} at t = {t:g} s: a target '
                                   'is a callable t (s) -> a finite angle (rad)')
        return number

    def _next_time(self) -> float:
        """Simulation time of the next tick's observation, s (the plant's own step·dt)."""
        session, settings = self.simulation.session, self.simulation.settings
        return (session.plant.step + settings.steps_per_publish) * settings.dt

    def reset(self, *, seed: int | None = None,
              options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        drawn = {name: float(self.np_random.uniform(lo, hi))
                 for name, (lo, hi) in self.randomize.items()}
        self.simulation = self.base.with_values(**drawn) if drawn else self.base
        limit = self.simulation.params.max_torque
        if limit != self._limit:
            raise ValueError('randomize must not change max_torque (it is the action space)')
        first = self.simulation.reset()
        self._t0 = first.time
        self._steps = 0
        target = self._target(0.0)
        return self._scales.observe(first, target), {
            'parameters': drawn, 'time': first.time, 'observation': first, 'target': target}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        a = min(1.0, max(-1.0, _action(action)))
        # the target first: one that fails refuses the step before anything is integrated
        when = self._next_time()
        target = self._target(when - self._t0)
        o = self.simulation.step(a * self._limit)
        if o.time != when:                  # a faulted plant stands still
            target = self._target(o.time - self._t0)
        self._steps += 1
        observation = self._scales.observe(o, target)
        reward = -abs(float(observation[-1])) - self.effort_weight * a * a
        terminated = o.fault is not None
        truncated = self._steps >= self._max_steps and not terminated
        return observation, reward, terminated, truncated, {
            'time': o.time, 'active_path': o.active_path, 'fault': o.fault, 'observation': o,
            'target': target}


gymnasium.register(id=ENV_ID, entry_point='screwgear_ros.envs.table_env:ScrewgearTableEnv')

__all__ = ['DEFAULT_TARGET', 'EFFORT_WEIGHT', 'ENV_ID', 'ERROR_LIMIT', 'ERROR_SCALE',
           'OBSERVATION', 'EnvArgumentError', 'InvalidAction', 'ScrewgearTableEnv']
