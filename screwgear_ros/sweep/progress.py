"""A sweep's pending runs, run with a progress bar: each finished run is written at once.

The runs go to the engine :func:`~screwgear_ros.sweep.engine.outcomes` picks; every
outcome is added to the :class:`~screwgear_ros.sweep.store.Store` the moment it is back,
so Ctrl-C (or a lost engine) keeps every run that finished. On a terminal the progress
is tqdm's bar; in a log or a pipe, one line every :data:`STEP` percent.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol, TextIO

from .cluster import Cluster
from .engine import outcomes
from .model import RunSpec, Sweep
from .store import Store, failures
from .worker import Status


@dataclass(frozen=True)
class Pass:
    """What one call of :func:`run_pending` ran: whether Ctrl-C ended it, and the wall
    time of each run on its worker, s (runs lost with their worker left out)."""

    interrupted: bool
    wall_times: tuple[float, ...]


def run_pending(sweep: Sweep, store: Store, done: dict[int, Any], todo: Sequence[RunSpec],
                workers: int, scheduler: str | None, cluster: Cluster | None = None) -> Pass:
    """Run ``todo``, adding each finished run to ``store`` and ``done`` as it comes back.

    Parameters
    ----------
    sweep, store
        The sweep and its results directory.
    done
        The rows of the finished runs by index; updated in place.
    todo
        The runs to run now.
    workers, scheduler, cluster
        Where they run (:func:`~screwgear_ros.sweep.engine.outcomes`; ``cluster``: the
        Dask cluster started for them, closed when they end).

    Returns
    -------
    Pass
        Whether Ctrl-C stopped it, and the runs' wall times.

    Raises
    ------
    Exception
        Whatever the engine fails with; ``done`` and ``store`` keep the runs that finished.
    """
    failed = failures(done.values())
    ran: list[float] = []
    stream = outcomes(sweep.bundle, todo, workers, scheduler, cluster)
    bar = progress_bar(len(sweep.runs), len(done), failed, sys.stderr)
    try:
        for outcome in stream:
            done[outcome.index] = store.add(outcome)
            if outcome.wall_time == outcome.wall_time:      # NaN: a worker lost under it
                ran.append(outcome.wall_time)
            failed += outcome.status is not Status.OK
            bar.update(failed)
    except KeyboardInterrupt:
        return Pass(True, tuple(ran))
    finally:
        bar.close()
        close = getattr(stream, 'close', None)
        if close is not None:
            close()
    return Pass(False, tuple(ran))


class Bar(Protocol):
    def update(self, failed: int) -> None: ...

    def close(self) -> None: ...


class _Terminal:
    """tqdm's bar, redrawn in place: for a terminal."""

    def __init__(self, total: int, initial: int, failed: int, stream: TextIO) -> None:
        from tqdm import tqdm

        self.bar = tqdm(total=total, initial=initial, unit='run', dynamic_ncols=True,
                        desc='sweep', file=stream)
        self.bar.set_postfix(failures=failed)

    def update(self, failed: int) -> None:
        self.bar.set_postfix(failures=failed, refresh=False)
        self.bar.update(1)

    def close(self) -> None:
        self.bar.close()


class Lines:
    """One line each time another :data:`STEP` percent of the runs is done (and at the
    last run): for a log or a pipe, where a bar's carriage returns pile up."""

    def __init__(self, total: int, initial: int, failed: int, stream: TextIO) -> None:
        self.total, self.done, self.stream = total, initial, stream
        self.started = time.monotonic()
        self.shown = self._step()
        self.failed = failed

    def _step(self) -> int:
        return 100 * self.done // max(self.total, 1) // STEP

    def update(self, failed: int) -> None:
        self.done, self.failed = self.done + 1, failed
        step = self._step()
        if step > self.shown or self.done == self.total:
            self.shown = step
            elapsed = time.monotonic() - self.started
            print(f'sweep: {self.done}/{self.total} runs ({100 * self.done // self.total} %), '
                  f'{failed} failures, {elapsed:.1f} s', file=self.stream, flush=True)

    def close(self) -> None:
        pass


#: Percent of the runs between two progress lines when the output is no terminal.
STEP = 5


def progress_bar(total: int, initial: int, failed: int, stream: TextIO) -> Bar:
    """tqdm's bar on a terminal, else :class:`Lines`."""
    isatty = getattr(stream, 'isatty', None)
    if isatty is not None and isatty():
        return _Terminal(total, initial, failed, stream)
    return Lines(total, initial, failed, stream)


__all__ = ['STEP', 'Bar', 'Lines', 'Pass', 'progress_bar', 'run_pending']
