"""Where a sweep's runs execute: this process (one worker, no Dask imported at all), an
embedded Dask ``LocalCluster`` (one single-threaded worker process per core), or an
existing Dask cluster at a scheduler address (short runs go several to a task). Each
yields the runs' outcomes as they finish; the runs and their shared inputs travel as
values, so remote workers need the package installed but no shared filesystem.

Worker processes, not threads: ``benchmarks/bench_sweep.py`` runs the same short runs in N
threads of one process and in N processes; the compiled kernels hold the GIL and every tick
passes through Python (the controller, the deadline check), so threads share one core.
``--workers auto`` (:func:`free_workers`) counts the cores free now (the run queue), so that a busy
machine gets one worker here rather than a cluster that competes with the load.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..sim.machine import cores
from .cluster import Cluster
from .model import Bundle, RunSpec
from .worker import Outcome, Status, execute, execute_batch, hard_limit, warm_up


@dataclass(frozen=True)
class Workers:
    """How many worker processes a sweep uses, and why that many."""

    count: int
    why: str


#: /proc/loadavg's fourth field: the tasks running or waiting for a core right now.
_RUN_QUEUE = Path('/proc/loadavg')


def load_now(samples: int = 10, interval: float = 0.02) -> float:
    """The load on the cores now: the tasks running or waiting for one (the kernel's run
    queue, this process left out), the mean of ``samples`` readings ``interval`` s apart.
    The 1-minute load average where the kernel shows no run queue (not Linux): that
    average also remembers the last minute, so that a machine that has just finished a
    sweep would look busy for a minute after it.

    Examples
    --------
    >>> load_now() >= 0.0
    True
    """
    try:
        seen = []
        for k in range(samples):
            if k:
                time.sleep(interval)
            running = int(_RUN_QUEUE.read_text().split()[3].split('/')[0])
            seen.append(max(running - 1, 0))           # this process reads it, running
        return sum(seen) / len(seen)
    except (OSError, IndexError, ValueError):
        return os.getloadavg()[0]


def free_workers(runs: int, load: float | None = None, allowed: int | None = None) -> Workers:
    """The workers for ``runs`` runs on the cores that are free now: the cores this
    process may run on (its affinity) less the load on them now (:func:`load_now`),
    rounded; at least 1, and never more than the runs. One worker runs here, with no
    cluster to start.

    Parameters
    ----------
    runs
        The runs to place.
    load, allowed
        The load and the cores this process may use (default: measured now).

    Returns
    -------
    Workers
        The count and a sentence saying why.

    Examples
    --------
    >>> free_workers(300, load=7.0, allowed=2).count
    1
    >>> free_workers(300, load=0.2, allowed=2).count
    2
    """
    allowed = cores() if allowed is None else allowed
    load = load_now() if load is None else load
    free = max(1, min(allowed, math.floor(allowed - load + 0.5)))
    why = f'{allowed} cores, {load:.1f} busy now'
    if runs <= 1:
        return Workers(1, f'{runs} run to do')
    if free == 1 and allowed > 1:
        return Workers(1, f'the machine is busy ({why}): one worker here is faster than '
                       'several sharing the cores with the load')
    return Workers(min(free, runs), f'{why}: {free} free')


def in_process(bundle: Bundle, specs: Sequence[RunSpec]) -> Iterator[Outcome]:
    """The runs one after the other, here."""
    warm_up()
    for spec in specs:
        yield execute(bundle, spec)


#: A cluster task runs a batch of runs expected to take about this long in all: each
#: task costs the scheduler, the client and the worker some CPU, and its worker waits a
#: round trip through the client for the next one, which a lone short run would feel; a
#: longer batch would lose more runs to Ctrl-C and spread the last runs worse.
BATCH_SECONDS = 1.0
MAX_BATCH = 64


class Batches:
    """Cuts the runs left into batches of about :data:`BATCH_SECONDS` of run time, from
    the mean time of the runs back so far (one run a batch until the first is back),
    and never so large that the last runs leave a worker thread idle."""

    def __init__(self, specs: Sequence[RunSpec]) -> None:
        self.left = list(reversed(specs))
        self.times: list[float] = []

    def record(self, outcome: Outcome) -> None:
        if outcome.wall_time == outcome.wall_time:      # NaN: a worker lost under it
            self.times.append(outcome.wall_time)

    def size(self, slots: int) -> int:
        if not self.times:
            return 1
        mean = sum(self.times) / len(self.times)
        size = min(MAX_BATCH, max(1, int(BATCH_SECONDS / max(mean, 1e-6))))
        return max(1, min(size, len(self.left) // max(slots, 1)))

    def take(self, slots: int) -> list[RunSpec]:
        return [self.left.pop() for _ in range(min(self.size(slots), len(self.left)))]


def _lost(bundle: Bundle, spec: RunSpec, exc: BaseException) -> Outcome:
    return Outcome(spec.index, spec.key, Status.ERROR, f'its worker process ended (a '
                   f'crash, or blocked past the hard limit of '
                   f'{hard_limit(bundle.time_limit):g} s): {type(exc).__name__}',
                   tuple(math.nan for _ in bundle.metrics), math.nan)


def on_dask(bundle: Bundle, specs: Sequence[RunSpec], workers: int,
            scheduler: str | None = None, cluster: Cluster | None = None) -> Iterator[Outcome]:
    """The runs on Dask: a LocalCluster of ``workers`` processes, or the cluster of
    ``scheduler``, or ``cluster`` started before (this closes it); in batches
    (:class:`Batches`), one task per live worker thread at a time, so that the scheduler
    places each on an idle worker and a worker holds no task but the one it runs. The
    runs of a batch whose worker process ended are run again one run a task; a run whose
    own task ended its worker is an error row. The bundle travels with each task (a few
    kB), so that no worker's end loses it. Closing the iterator (Ctrl-C included)
    cancels what is left."""
    if cluster is None:
        cluster = Cluster(workers, scheduler)
    try:
        client = cluster.client()
    except BaseException:
        cluster.close()
        raise
    from dask.distributed import as_completed

    running = as_completed(loop=client.loop)
    batch_of: dict[Any, list[RunSpec]] = {}
    try:
        batches = Batches(specs)
        alone: list[RunSpec] = []       # the runs of a batch whose worker ended

        def submit_while_idle() -> None:
            slots = max(1, sum(client.nthreads().values()))
            while len(batch_of) < slots and (alone or batches.left):
                batch = [alone.pop()] if alone else batches.take(slots)
                future = client.submit(execute_batch, bundle, batch, pure=False)
                batch_of[future] = batch
                running.add(future)

        submit_while_idle()
        for future in running:
            batch = batch_of.pop(future)
            lost: list[Outcome] = []
            try:
                results = future.result()
            except Exception as exc:  # noqa: BLE001 - its worker died under it: see above
                if len(batch) == 1:
                    lost.append(_lost(bundle, batch[0], exc))
                else:
                    alone.extend(reversed(batch))
                results = []
            for outcome in results:
                batches.record(outcome)
            # the idle worker's next batch before this one's rows are handled (each is
            # a file the caller writes): the worker waits for nothing but the submit
            submit_while_idle()
            yield from lost
            yield from results
    finally:
        if batch_of:
            client.cancel(list(batch_of))
        cluster.close()


def outcomes(bundle: Bundle, specs: Sequence[RunSpec], workers: int,
             scheduler: str | None, cluster: Cluster | None = None) -> Iterator[Outcome]:
    """The runs' outcomes as they finish: here for one worker and no scheduler, else on
    Dask (``cluster``: the one started for them, which the runs then close)."""
    if scheduler is None and workers == 1 and cluster is None:
        return in_process(bundle, specs)
    return on_dask(bundle, specs, workers, scheduler, cluster)


def describe(workers: int, scheduler: str | None) -> str:
    if scheduler:
        return f'the Dask cluster at {scheduler}'
    if workers == 1:
        return 'this process'
    return f'a Dask LocalCluster of {workers} worker processes'


__all__ = ['Workers', 'cores', 'describe', 'free_workers', 'in_process', 'load_now', 'on_dask',
           'outcomes']
