"""A sweep's cluster started early: as soon as the sweep file has said how many runs it
has, while the command validates the runs, with ``--workers auto`` choosing once."""

from __future__ import annotations

from collections.abc import Callable

from .cluster import Cluster
from .engine import Workers, free_workers, load_now


class EarlyCluster:
    """Starts a sweep's :class:`Cluster` as soon as the sweep file has said how many runs
    it has (``load_sweep``'s announce, before the runs are validated), when the runs left
    need one, so that it comes up while the command validates them. Holds the load that
    ``--workers auto`` measured then, so that the choice made then is the one made after.

    ``workers``: the number given, or None for auto's choice; ``scheduler``: an existing
    cluster's address; ``max_runs``: the most runs this call runs; ``announce``: what the
    command says of the sweep's size, called first.
    """

    def __init__(self, workers: int | None, scheduler: str | None, max_runs: int | None,
                 announce: Callable[[int, float], None]) -> None:
        self._given, self._scheduler, self._max_runs = workers, scheduler, max_runs
        self._announce = announce
        self.finished = 0                     # finished runs' keys in the results directory
        self.cluster: Cluster | None = None
        self.load: float | None = None

    def __call__(self, total: int, simulated: float) -> None:
        self._announce(total, simulated)
        left = total - self.finished          # or more: a finished key may be another's
        if self._max_runs is not None:
            left = min(left, self._max_runs)
        if left > 0:
            workers = self.workers(left).count
            if self._scheduler or workers > 1:
                self.cluster = Cluster(workers, self._scheduler)

    def workers(self, runs: int) -> Workers:
        """The workers for ``runs`` runs: those given, or auto's choice."""
        if self._scheduler or self._given is not None:
            return Workers(1 if self._scheduler else int(self._given or 1), 'given')
        if runs > 1 and self.load is None:
            self.load = load_now()
        return free_workers(runs, load=self.load or 0.0)

    def take(self, workers: int, runs: int) -> Cluster | None:
        """The cluster started, if it is the one ``runs`` runs on ``workers`` workers
        need (the runs close it when they end; :meth:`close` again at the latest);
        else None, and it is closed."""
        if self.cluster is not None and (not runs or self.cluster.workers != workers):
            self.close()
        return self.cluster

    def close(self) -> None:
        """Close the cluster started, if any (idempotent)."""
        if self.cluster is not None:
            self.cluster.close()
            self.cluster = None


__all__ = ['EarlyCluster']
