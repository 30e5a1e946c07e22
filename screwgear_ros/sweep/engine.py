"""Where a sweep's runs execute: this process (one worker, no Dask imported at all), an
embedded Dask ``LocalCluster`` (one single-threaded worker process per core), or an
existing Dask cluster at a scheduler address. Each yields the runs' outcomes as they
finish; the runs and their shared inputs travel as values, so remote workers need the
package installed but no shared filesystem.
"""

from __future__ import annotations

import logging
import math
import os
from typing import Iterator, Sequence

from .spec import Bundle, RunSpec
from .worker import Outcome, Status, execute, hard_limit, warm_up


def cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


def in_process(bundle: Bundle, specs: Sequence[RunSpec]) -> Iterator[Outcome]:
    """The runs one after the other, here."""
    warm_up()
    for spec in specs:
        yield execute(bundle, spec)


def on_dask(bundle: Bundle, specs: Sequence[RunSpec], workers: int,
            scheduler: str | None = None) -> Iterator[Outcome]:
    """The runs on Dask: a LocalCluster of ``workers`` processes, or the cluster of
    ``scheduler``. Closing the iterator (Ctrl-C included) cancels what is left."""
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError as exc:
        raise RuntimeError(f'more than one worker needs Dask ({exc}): pip install '
                           "'screwgear_ros[sweep]', or run with --workers 1") from None

    import dask

    cluster = None
    if scheduler:
        client = Client(scheduler, timeout='30s')
    else:
        # a run whose worker process ends (a crash, or the hard time limit) is a row at
        # once: no retry of the run on another worker
        with dask.config.set({'distributed.scheduler.allowed-failures': 0}):
            cluster = LocalCluster(n_workers=workers, processes=True, threads_per_worker=1,
                                   dashboard_address=None, silence_logs=logging.CRITICAL)
        client = Client(cluster)
    futures = []
    try:
        client.run(warm_up)
        shared = client.scatter(bundle, broadcast=True)
        futures = [client.submit(execute, shared, spec, pure=False)
                   for spec in specs]
        of = dict(zip(futures, specs))
        for future in as_completed(futures):
            try:
                yield future.result()
            except Exception as exc:  # noqa: BLE001 - a worker died under it (twice): a row
                spec = of[future]
                yield Outcome(spec.index, spec.key, Status.ERROR, f'its worker process '
                              f'ended (a crash, or blocked past the hard limit of '
                              f'{hard_limit(bundle.time_limit):g} s): {type(exc).__name__}',
                              tuple(
                                  math.nan for _ in bundle.metrics), math.nan)
    finally:
        if futures:
            client.cancel(futures)
        client.close()
        if cluster is not None:
            cluster.close()


def outcomes(bundle: Bundle, specs: Sequence[RunSpec], workers: int,
             scheduler: str | None) -> Iterator[Outcome]:
    if scheduler is None and workers == 1:
        return in_process(bundle, specs)
    return on_dask(bundle, specs, workers, scheduler)


def describe(workers: int, scheduler: str | None) -> str:
    if scheduler:
        return f'the Dask cluster at {scheduler}'
    if workers == 1:
        return 'this process'
    return f'a Dask LocalCluster of {workers} worker processes'


__all__ = ['cores', 'in_process', 'on_dask', 'outcomes', 'describe']
