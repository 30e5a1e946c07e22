"""The Dask cluster of a sweep, started in a thread of its own: the embedded
``LocalCluster`` (its worker processes start, import the package and load the compiled
model, seconds of work on the other cores) or a client of an existing cluster. The
command starts it as soon as the sweep file says how many runs it has, so that the
cluster comes up while this process validates the runs (:mod:`.resolve`), and
:meth:`Cluster.client` waits for it when the first run is due. Nothing here runs a run.
"""

from __future__ import annotations

import logging
import signal
import threading
from typing import Any

from .worker import warm_up

#: Dask settings for the embedded LocalCluster (a remote cluster keeps its own).
LOCAL_CONFIG = {
    # a run whose worker process ends (a crash, or the hard time limit) is a row at
    # once: no retry of the run on another worker
    'distributed.scheduler.allowed-failures': 0,
    # what every Dask process does on its own while the runs take the cores: the
    # statistical profiler sampling the worker's stacks (under the GIL the run needs),
    # the event loop's health check, the memory and system monitors; a sweep reads none
    # of them, and at their default rates they take a share of the cores from the runs
    'distributed.worker.profile.enabled': False,
    'distributed.admin.tick.interval': '1s',
    'distributed.admin.system-monitor.interval': '2s',
    'distributed.worker.memory.monitor-interval': '1s',
}

#: Environment of the LocalCluster's worker processes: one thread of compiled code or
#: BLAS each, as each process has one core (Dask sets the BLAS ones itself; numba's
#: threading layer is not covered by them).
WORKER_ENV = {'OMP_NUM_THREADS': '1', 'OPENBLAS_NUM_THREADS': '1', 'MKL_NUM_THREADS': '1',
              'NUMBA_NUM_THREADS': '1'}


class Cluster:
    """A Dask client, and the LocalCluster of ``workers`` processes it drives unless a
    ``scheduler`` address is given, started in a thread on creation.

    The LocalCluster's workers load the compiled model before :meth:`client` returns
    (a worker that a crash restarted loads it before its first run). Whatever the start
    fails with is raised by :meth:`client`; :meth:`close` ends it all, started or not.
    """

    def __init__(self, workers: int, scheduler: str | None = None) -> None:
        self.workers, self.scheduler = workers, scheduler
        self._client: Any = None
        self._cluster: Any = None
        self._failure: BaseException | None = None
        self._unwanted = threading.Event()     # closed before its start was over
        self._thread = threading.Thread(target=self._start, name='sweep-cluster-start',
                                        daemon=True)
        self._thread.start()

    def _start(self) -> None:
        if hasattr(signal, 'pthread_sigmask'):
            # Ctrl-C at a terminal goes to the whole process group: the threads this one
            # starts and the worker processes they spawn inherit its mask (a blocked
            # signal stays blocked across exec), so that this process alone answers it,
            # ending the cluster, rather than each worker with its own traceback
            signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        try:
            try:
                from dask.distributed import Client, LocalCluster
            except ImportError as exc:
                raise RuntimeError(f'more than one worker needs Dask ({exc}): pip install '
                                   "'screwgear_ros[sweep]', or run with --workers 1") from None
            if self.scheduler:
                self._client = Client(self.scheduler, timeout='30s')
                return
            import dask

            with dask.config.set(LOCAL_CONFIG):
                self._cluster = LocalCluster(
                    n_workers=self.workers, processes=True, threads_per_worker=1,
                    dashboard_address=None, silence_logs=logging.CRITICAL, env=WORKER_ENV)
            if not self._unwanted.is_set():      # a sweep refused meanwhile: no more
                self._client = Client(self._cluster)
                self._client.run(warm_up)
        except BaseException as exc:  # noqa: BLE001 - raised where the client is asked for
            self._failure = exc

    def client(self) -> Any:
        """The connected client, once the cluster is up (raises what its start raised)."""
        self._thread.join()
        if self._failure is not None:
            raise self._failure
        return self._client

    def close(self) -> None:
        """End the client and the embedded cluster (after the step of its start under
        way, which cannot be cut short)."""
        self._unwanted.set()
        self._thread.join()
        try:
            if self._client is not None:
                self._client.close()
        finally:
            if self._cluster is not None:
                self._cluster.close()
            self._client = self._cluster = None


__all__ = ['LOCAL_CONFIG', 'WORKER_ENV', 'Cluster']
