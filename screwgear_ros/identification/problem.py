"""The output-error problem: the residual of a trial point, and the fit of a prediction.

The residual stacks, for every recording and every joint, the simulated minus the
measured angle change since the first sample, at each sample's own time, less its mean
over the recording (each
encoder's zero is estimated, not taken from one noisy first sample: a real table's
encoders read from wherever they were switched on), divided by the spread of
that joint's measured angles over all fit recordings, so that the pinions and the table
weigh alike; with ``speeds``, the speeds likewise. With ``settle`` the samples of each
recording's first ``settle`` seconds count zero (the model's state settles there). A trial point the model cannot run
or that diverges gives :data:`DIVERGED` everywhere: a large residual, not an error.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .adapter import Diverged, simulate
from .parameters import FitParameter, values_of
from .samples import Recording

#: Residual of every element at a trial point the model cannot run or diverges at.
DIVERGED = 1.0e3


@dataclass(frozen=True, eq=False)
class Problem:
    """Everything a residual needs, picklable (it travels to worker processes once)."""

    base: Mapping[str, Any]
    fitted: tuple[FitParameter, ...]
    recordings: tuple[Recording, ...]
    speeds: bool = False
    settle: float = 0.0

    @property
    def columns(self) -> list[int]:
        return [0, 1, 2, 3, 4, 5] if self.speeds else [0, 1, 2]

    def measured(self, recording: Recording) -> np.ndarray:
        """(n, columns): the angle changes since the first sample (and the speeds)."""
        data = np.column_stack([recording.position - recording.position[0],
                                recording.velocity])
        return data[:, self.columns]

    @property
    def weights(self) -> np.ndarray:
        stacked = np.vstack([self.measured(r) for r in self.recordings])
        spread = np.nanstd(stacked, axis=0)
        return 1.0 / np.where(spread > 0.0, spread, 1.0)

    @property
    def size(self) -> int:
        return sum(r.samples for r in self.recordings) * len(self.columns)

    def compared(self, recording: Recording) -> np.ndarray:
        """(n,) True where a sample enters the residual: from ``settle`` s after the
        simulation's start on (the first part lets a recording that did not start at rest
        settle the model's state)."""
        since = (np.asarray(recording.times) - recording.origin) * 1e-9
        return since >= self.settle

    def values(self, x: np.ndarray) -> dict[str, Any]:
        return {**self.base, **values_of(self.fitted, x)}

    def predict(self, values: Mapping[str, Any], recording: Recording) -> np.ndarray:
        """The prediction in :meth:`measured`'s columns, each angle's zero the one that
        fits the recording best (raises Diverged)."""
        out = simulate(values, recording, self.speeds)[:, self.columns]
        use = self.compared(recording)
        out[:, :3] += np.nanmean(self.measured(recording)[use, :3] - out[use, :3], axis=0)
        return out

    def lag_correlation(self, residual: np.ndarray) -> float:
        """The lag-one autocorrelation of ``residual`` (each joint's series apart, pooled),
        ≥ 0: how far the residuals are from white noise."""
        c = len(self.columns)
        num = den = 0.0
        at = 0
        for recording in self.recordings:
            part = residual[at:at + recording.samples * c].reshape(-1, c)
            at += recording.samples * c
            num += float(np.sum(part[1:] * part[:-1]))
            den += float(np.sum(part * part))
        return max(0.0, min(0.99, num / den)) if den > 0 else 0.0

    def residual(self, x: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
        """The weighted residual vector at ``x`` (scaled coordinates)."""
        weights = self.weights if weights is None else weights
        values = self.values(x)
        parts = []
        try:
            for recording in self.recordings:
                error = (self.predict(values, recording) - self.measured(recording)) * weights
                error[~self.compared(recording)] = 0.0
                parts.append(np.nan_to_num(error, nan=0.0).ravel())
        except Diverged:
            return np.full(self.size, DIVERGED)
        return np.concatenate(parts)


def timed_residual(problem: Problem, x: np.ndarray, weights: np.ndarray
                   ) -> tuple[np.ndarray, float]:
    """(residual, seconds spent simulating) of one trial point."""
    start = time.perf_counter()
    r = problem.residual(x, weights)
    return r, time.perf_counter() - start


def fit_percent(measured: np.ndarray, predicted: np.ndarray) -> np.ndarray:
    """Per column: 100·(1 − ‖y − ŷ‖ / ‖y − ȳ‖), the normalized fit of a prediction."""
    ok = np.isfinite(measured) & np.isfinite(predicted)
    out = []
    for j in range(measured.shape[1]):
        y, yhat = measured[ok[:, j], j], predicted[ok[:, j], j]
        spread = np.linalg.norm(y - y.mean()) if len(y) else 0.0
        out.append(100.0 * (1.0 - np.linalg.norm(y - yhat) / spread) if spread > 0 else
                   np.nan)
    return np.array(out)


@dataclass(frozen=True, eq=False)
class Comparison:
    """One recording, measured against the model before and after the fit."""

    recording: Recording
    measured: np.ndarray
    before: np.ndarray | None     # None: the model diverged there
    after: np.ndarray | None
    role: str                     # 'fit' or 'validate'

    def fit(self, which: str) -> np.ndarray:
        predicted = self.before if which == 'before' else self.after
        if predicted is None:
            return np.full(self.measured.shape[1], -np.inf)
        return fit_percent(self.measured, predicted)


def compare(problem: Problem, recordings: Sequence[Recording], before: Mapping[str, Any],
            after: Mapping[str, Any], role: str) -> list[Comparison]:
    out = []
    for recording in recordings:
        predictions: list[np.ndarray | None] = []
        for values in (before, after):
            try:
                predictions.append(problem.predict(values, recording))
            except Diverged:
                predictions.append(None)
        out.append(Comparison(recording, problem.measured(recording), predictions[0],
                              predictions[1], role))
    return out


__all__ = ['DIVERGED', 'Comparison', 'Problem', 'compare', 'fit_percent', 'timed_residual']
