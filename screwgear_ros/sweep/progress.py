"""A sweep's pending runs, run with a progress bar: each finished run is written at once.

The runs go to the engine :func:`~screwgear_ros.sweep.engine.outcomes` picks; every
outcome is added to the :class:`~screwgear_ros.sweep.store.Store` the moment it is back,
so Ctrl-C (or a lost engine) keeps every run that finished.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

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
                workers: int, scheduler: str | None) -> Pass:
    """Run ``todo``, adding each finished run to ``store`` and ``done`` as it comes back.

    Parameters
    ----------
    sweep, store
        The sweep and its results directory.
    done
        The rows of the finished runs by index; updated in place.
    todo
        The runs to run now.
    workers, scheduler
        Where they run (:func:`~screwgear_ros.sweep.engine.outcomes`).

    Returns
    -------
    Pass
        Whether Ctrl-C stopped it, and the runs' wall times.

    Raises
    ------
    Exception
        Whatever the engine fails with; ``done`` and ``store`` keep the runs that finished.
    """
    from tqdm import tqdm

    failed = failures(done.values())
    ran: list[float] = []
    stream = outcomes(sweep.bundle, todo, workers, scheduler)
    bar = tqdm(total=len(sweep.runs), initial=len(done), unit='run', dynamic_ncols=True,
               desc='sweep', file=sys.stderr)
    bar.set_postfix(failures=failed)
    try:
        for outcome in stream:
            done[outcome.index] = store.add(outcome)
            if outcome.wall_time == outcome.wall_time:      # NaN: a worker lost under it
                ran.append(outcome.wall_time)
            failed += outcome.status is not Status.OK
            bar.set_postfix(failures=failed, refresh=False)
            bar.update(1)
    except KeyboardInterrupt:
        return Pass(True, tuple(ran))
    finally:
        bar.close()
        close = getattr(stream, 'close', None)
        if close is not None:
            close()
    return Pass(False, tuple(ran))


__all__ = ['Pass', 'run_pending']
