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
        self.best_x: np.ndarray | None = None
        self.best_cost = np.inf
        self.best_r: np.ndarray | None = None
        self.iterations = 0
        self._last: tuple[np.ndarray, np.ndarray] | None = None

    def _seen(self, x: np.ndarray, r: np.ndarray) -> None:
        cost = 0.5 * float(r @ r)
        if cost < self.best_cost:
            self.best_x, self.best_cost, self.best_r = x.copy(), cost, r
        self.bar.set_postfix(cost=f'{self.best_cost:.4g}', iteration=self.iterations,
                             refresh=False)

    def fun(self, x: np.ndarray) -> np.ndarray:
        r = self.evaluator.one(x)
        self._last = (x.copy(), r)
        self._seen(x, r)
        self.bar.update(1)
        return r

    def jac(self, x: np.ndarray) -> np.ndarray:
        if self._last is not None and np.array_equal(self._last[0], x):
            r0 = self._last[1]
        else:
            r0 = self.fun(x)
        steps = np.where(x + STEP <= self.hi, STEP, -STEP)
        trial = [x + np.eye(len(x))[j] * steps[j] for j in range(len(x))]
        results = self.evaluator.many(trial)
        for xt, r in zip(trial, results, strict=True):
            self._seen(xt, r)
        self.iterations += 1
        self.bar.update(len(trial))
        return np.column_stack([(r - r0) / h for r, h in zip(results, steps, strict=True)])


def minimize(evaluator: Evaluator, fitted: Sequence[FitParameter],
             starts: Sequence[np.ndarray], max_evaluations: int = 40,
             progress: bool = False) -> FitOutcome:
    """Fit from each of ``starts`` in turn; the best outcome (lowest cost).

    ``max_evaluations``: residual evaluations per start (not counting the Jacobian's).
    """
    from tqdm import tqdm
    p = len(fitted)
    planned = len(starts) * min(max_evaluations, PLANNED_ITERATIONS) * (p + 1)
    with tqdm(total=planned, unit='sim', desc='identify (≈ total)',
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
                result = least_squares(search.fun, x0, jac=search.jac,
                                       bounds=(search.lo, search.hi), method='trf',
                                       x_scale=1.0, max_nfev=max_evaluations,
                                       ftol=1e-10, xtol=1e-10, gtol=1e-10)
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


__all__ = ['STEP', 'FitOutcome', 'minimize']
