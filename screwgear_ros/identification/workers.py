"""Where the trial points of a finite-difference Jacobian are simulated: this process
(one worker), a pool of worker processes (``concurrent.futures``, the problem sent to
each once), or a Dask cluster at a scheduler address (the problem scattered to every
worker once), as ``sweep`` runs its runs. Every residual is a pure function of the
trial point, so where it is computed changes no bit of it.
"""

from __future__ import annotations

import multiprocessing
import signal
from collections.abc import Sequence
from concurrent.futures import Executor, ProcessPoolExecutor
from typing import Any, Self

import numpy as np

from .problem import Problem, timed_residual

_problem: tuple[Problem, np.ndarray] | None = None


def _install(problem: Problem, weights: np.ndarray) -> None:
    global _problem
    # a terminal's Ctrl-C reaches the whole process group: the parent stops the fit and
    # shuts the pool down, so a worker ignores it rather than print a traceback
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _problem = (problem, weights)


def _evaluate(x: np.ndarray) -> tuple[np.ndarray, float]:
    assert _problem is not None, 'worker process without its problem'
    return timed_residual(_problem[0], x, _problem[1])


class Evaluator:
    """Residuals of trial points, and how many simulations they took and how long.

    Use as a context manager: the worker processes or the cluster's client are closed
    on the way out (also on Ctrl-C)."""

    def __init__(self, problem: Problem, weights: np.ndarray, workers: int = 1,
                 scheduler: str | None = None) -> None:
        self.problem, self.weights = problem, weights
        self.workers, self.scheduler = max(1, int(workers)), scheduler
        self.evaluations = 0
        self.sim_seconds = 0.0
        self._pool: Executor | None = None
        self._client: Any = None
        self._scattered: Any = None

    @property
    def simulations(self) -> int:
        """Simulations run: one per recording per trial point."""
        return self.evaluations * len(self.problem.recordings)

    def describe(self) -> str:
        if self.scheduler:
            return f'the Dask cluster at {self.scheduler}'
        return 'this process' if self.workers == 1 else f'{self.workers} worker processes'

    def __enter__(self) -> Self:
        if self.scheduler:
            from dask.distributed import Client
            self._client = Client(self.scheduler)
            self._scattered = self._client.scatter(self.problem, broadcast=True)
        elif self.workers > 1:
            # fork: the workers start with the compiled kernels this process loaded
            self._pool = ProcessPoolExecutor(
                self.workers, mp_context=multiprocessing.get_context('fork'),
                initializer=_install, initargs=(self.problem, self.weights))
        return self

    def __exit__(self, *exc: object) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None
        if self._client is not None:
            self._client.close()
            self._client = None

    def one(self, x: np.ndarray) -> np.ndarray:
        """The residual at ``x``, here."""
        r, seconds = timed_residual(self.problem, x, self.weights)
        self.evaluations += 1
        self.sim_seconds += seconds
        return r

    def many(self, xs: Sequence[np.ndarray]) -> list[np.ndarray]:
        """The residuals at ``xs``, in parallel where there are workers."""
        if self._client is not None:
            futures = self._client.map(timed_residual, [self._scattered] * len(xs), list(xs),
                                       [self.weights] * len(xs), pure=False)
            results = self._client.gather(futures)
        elif self._pool is not None:
            results = list(self._pool.map(_evaluate, xs))
        else:
            results = [timed_residual(self.problem, x, self.weights) for x in xs]
        self.evaluations += len(xs)
        self.sim_seconds += sum(seconds for _, seconds in results)
        return [r for r, _ in results]


__all__ = ['Evaluator']
