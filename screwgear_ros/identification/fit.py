"""The minimization: ``scipy.optimize.least_squares`` (trust region reflective, within
the bounds) on the scaled parameters, from a few seeded starting points, with a
forward-difference Jacobian whose trial points are simulated in parallel by an
:class:`~screwgear_ros.identification.workers.Evaluator`.

Ctrl-C stops the search; the best point evaluated so far is kept and the outcome says
it is unfinished.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from .parameters import FitParameter
from .workers import Evaluator

#: Forward-difference step in scaled coordinates (ln value, or a fraction of the bounds).
STEP = 1.0e-4
#: Iterations the progress bar plans a start to take until one has ended (the fits of
#: docs/identification.md took 6 to 8); then it plans by the starts that ended.
PLANNED_ITERATIONS = 8
#: Parameters that act at the mesh's frequencies: searched in the second stage only.
FAST = ('mesh_stiffness_mean', 'mesh_damping', 'inertia_pinion_1', 'inertia_pinion_3',
        'drive_time_constant')


def first_stage(fitted: Sequence[FitParameter], started: Sequence[str]) -> list[bool]:
    """The coordinates :func:`minimize`'s first stage searches: the rigid body's, not
    the :data:`FAST` ones nor those ``started`` from the data."""
    return [p.name not in FAST and p.name not in started for p in fitted]


@dataclass
class FitOutcome:
    """The best point found (scaled coordinates), its cost ½‖r‖², residual and
    Jacobian there (None when interrupted before one was computed)."""

    x: np.ndarray
    cost: float
    residual: np.ndarray
    jacobian: np.ndarray | None
    iterations: int
    finished: bool
    message: str
    start_costs: list[float] = field(default_factory=list)
    start_points: list[np.ndarray] = field(default_factory=list)


class _Search:
    """fun and jac for least_squares, keeping the best point and driving the bar."""

    def __init__(self, evaluator: Evaluator, fitted: Sequence[FitParameter],
                 bar: Any) -> None:
        self.evaluator, self.bar = evaluator, bar
        self.lo = np.array([p.x_bounds[0] for p in fitted])
        self.hi = np.array([p.x_bounds[1] for p in fitted])
        self.free = np.ones(len(fitted), dtype=bool)     # the coordinates searched
        self.held = np.zeros(len(fitted))                # the others' values
        self.best_x: np.ndarray | None = None
        self.best_cost = np.inf
        self.best_r: np.ndarray | None = None
        self.iterations = 0
        self._last: tuple[np.ndarray, np.ndarray] | None = None

    def _seen(self, x: np.ndarray, r: np.ndarray) -> None:
        if len(x) != len(self.free):
            x = self.full(x)
        cost = 0.5 * float(r @ r)
        if cost < self.best_cost:
            self.best_x, self.best_cost, self.best_r = x.copy(), cost, r
        self.bar.set_postfix(cost=f'{self.best_cost:.4g}', iteration=self.iterations,
                             refresh=False)

    def full(self, x: np.ndarray) -> np.ndarray:
        """The whole point of the searched coordinates ``x``."""
        out = self.held.copy()
        out[self.free] = x
        return out

    def fun(self, x: np.ndarray) -> np.ndarray:
        r = self.evaluator.one(self.full(x))
        self._last = (x.copy(), r)
        self._seen(x, r)
        self.bar.update(1)
        return r

    def jac(self, x: np.ndarray) -> np.ndarray:
        if self._last is not None and np.array_equal(self._last[0], x):
            r0 = self._last[1]
        else:
            r0 = self.fun(x)
        steps = np.where(x + STEP <= self.hi[self.free], STEP, -STEP)
        trial = [x + np.eye(len(x))[j] * steps[j] for j in range(len(x))]
        results = self.evaluator.many([self.full(xt) for xt in trial])
        for xt, r in zip(trial, results, strict=True):
            self._seen(self.full(xt), r)
        self.iterations += 1
        self.bar.update(len(trial))
        return np.column_stack([(r - r0) / h for r, h in zip(results, steps, strict=True)])


def _least_squares(search: _Search, x0: np.ndarray, free: np.ndarray,
                   max_evaluations: int) -> Any:
    """One trust-region search over the coordinates ``free`` (the others held at x0's)."""
    search.free, search.held = free, np.array(x0, dtype=np.float64)
    result = least_squares(search.fun, x0[free], jac=search.jac,
                           bounds=(search.lo[free], search.hi[free]), method='trf',
                           x_scale=1.0, max_nfev=max_evaluations,
                           ftol=1e-10, xtol=1e-10, gtol=1e-10)
    result.x = search.full(result.x)
    return result


def minimize(evaluator: Evaluator, fitted: Sequence[FitParameter],
             starts: Sequence[np.ndarray], max_evaluations: int = 40,
             progress: bool = False, first: Sequence[bool] | None = None) -> FitOutcome:
    """Fit from each of ``starts`` in turn; the best outcome (lowest cost).

    ``max_evaluations``: residual evaluations per start and stage (not counting the
    Jacobian's). ``first``: the coordinates a first stage searches alone, the others
    held at the start's values (the rigid body's parameters before the mesh's, and
    before those started from the data: a mesh whose stiffness is off pulls its damping
    into a wrong valley while the rigid body's are off too, and would pull a measured
    preload along its valley with the stiffness); the second stage then searches all
    from there.
    """
    from tqdm import tqdm
    p = len(fitted)
    staged = None if first is None else np.asarray(first, dtype=bool)
    if staged is not None and (staged.all() or not staged.any()):
        staged = None
    # a start costs up to two searches: the first stage's over its coordinates, then all
    per_start = min(max_evaluations, PLANNED_ITERATIONS) * (p + 1)
    if staged is not None:
        per_start += min(max_evaluations, PLANNED_ITERATIONS) * (int(staged.sum()) + 1)
    with tqdm(total=len(starts) * per_start, unit='sim', desc='identify (≈ total)',
              disable=not progress, leave=False) as bar:
        search = _Search(evaluator, fitted, bar)
        best: Any = None
        costs: list[float] = []
        points: list[np.ndarray] = []
        message, finished = '', True
        for done, x0 in enumerate(starts):
            if done:     # plan the starts left by those that ended
                bar.total = bar.n + round(bar.n / done * (len(starts) - done))
                bar.refresh()
            try:
                if staged is not None:
                    x0 = _least_squares(search, np.asarray(x0), staged, max_evaluations).x
                result = _least_squares(search, np.asarray(x0), np.ones(p, dtype=bool),
                                        max_evaluations)
            except KeyboardInterrupt:
                finished, message = False, 'interrupted (SIGINT): the best point so far'
                break
            costs.append(float(result.cost))
            points.append(np.array(result.x))
            if best is None or result.cost < best.cost:
                best = result
    if best is not None and finished:
        return FitOutcome(best.x, float(best.cost), best.fun, np.asarray(best.jac),
                          search.iterations, True, str(best.message), costs, points)
    if search.best_x is None or search.best_r is None:
        raise KeyboardInterrupt
    return FitOutcome(search.best_x, search.best_cost, search.best_r, None,
                      search.iterations, finished, message, costs, points)


__all__ = ['FAST', 'STEP', 'FitOutcome', 'first_stage', 'minimize']
