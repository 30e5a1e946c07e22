"""One run of a sweep, wherever it runs (this process, a LocalCluster worker, a remote
worker): :func:`execute` takes the shared :class:`~screwgear_ros.sweep.model.Bundle` (file
contents, not paths) and a :class:`~screwgear_ros.sweep.model.RunSpec` and returns the
run's row. A run depends on nothing else (no worker state, no order), so its row is the
same bits wherever it runs. A run that faults, fails or overruns its time limit is a row
with its status and reason; nothing escapes.
"""

from __future__ import annotations

import math
import os
import signal
import sys
import tempfile
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import Any

from ..errors import ScrewgearError
from .model import Bundle, RunSpec


class Status(StrEnum):
    OK = 'ok'                  # ran to its end
    FAULT = 'fault'            # the model diverged: the plant stood still (reason: why)
    ERROR = 'error'            # the run could not go on (controller failed or was refused)
    TIMEOUT = 'timeout'        # over the sweep's time limit (wall time), stopped


@dataclass(frozen=True)
class Outcome:
    """A finished run: its row (index, seed, key, status, reason, metrics in the sweep's
    order) and the wall and CPU time it took (measured, so not part of the row; the CPU
    time is its thread's, which a busy machine stretches less than the wall time)."""

    index: int
    key: str
    status: Status
    reason: str
    metrics: tuple[float, ...]
    wall_time: float
    cpu_time: float = math.nan

    def row(self) -> dict[str, Any]:
        return {'index': self.index, 'key': self.key, 'status': self.status.value,
                'reason': self.reason, 'metrics': list(self.metrics)}


class RunTimeout(ScrewgearError):
    """The run went past its deadline (raised between ticks)."""


class _Deadline:
    """The run's controller, checking the wall clock before every answer: a run over its
    time limit stops at the next tick (the loop over ticks is Python; one tick of the
    compiled model is short)."""

    def __init__(self, controller: Any, deadline: float) -> None:
        self.controller, self.deadline = controller, deadline
        self.time = 0.0

    def around(self, controller: Any) -> _Deadline:
        """This guard, in front of ``controller`` (Scenario.run's ``guard``)."""
        self.controller = controller
        return self

    def __call__(self, observation: Any) -> Any:
        self.time = observation.time
        if time.perf_counter() > self.deadline:
            raise RunTimeout
        return None if self.controller is None else self.controller(observation)


#: The longest in-process time limit the timer holds, s (a year).
ALARM_MOST = 365.0 * 86400.0


class _Alarm:
    """SIGALRM at the run's deadline, when the run is in the main thread (``--workers
    1``): the handler raises :class:`RunTimeout` wherever the run's Python code is (the
    controller's factory, a controller that sleeps, the metrics), so its limit holds
    during the whole run, not only between ticks. The timer fires once; :meth:`disarm`
    makes a late one harmless, :meth:`restore` puts the old handler back."""

    def __init__(self, seconds: float) -> None:
        self.armed = (threading.current_thread() is threading.main_thread()
                      and hasattr(signal, 'setitimer'))
        self.old: Any = None
        if self.armed:
            self.old = signal.signal(signal.SIGALRM, self._fire)
            # a limit past a year is no limit a timer needs to hold (nor can, on time_t)
            signal.setitimer(signal.ITIMER_REAL, min(max(seconds, 1e-6), ALARM_MOST))

    def _fire(self, signum: int, frame: Any) -> None:
        if self.armed:
            self.armed = False
            raise RunTimeout

    def disarm(self) -> None:
        self.armed = False

    def restore(self) -> None:
        if self.old is not None:
            signal.setitimer(signal.ITIMER_REAL, 0.0)
            signal.signal(signal.SIGALRM, self.old)
            self.old = None


#: Scenarios materialized in this process, by bundle digest.
_SCENARIOS: dict[str, Any] = {}


def _scenario(bundle: Bundle) -> Any:
    """The bundle's scenario, read from its text written to a private directory with its
    controller modules (workers need no shared filesystem)."""
    digest = bundle.digest
    if digest not in _SCENARIOS:
        from ..inprocess.scenario import load_scenario
        directory = Path(tempfile.mkdtemp(prefix=f'sweep_{digest}_'))
        for name, text in bundle.sources:
            (directory / name).write_text(text, encoding='utf-8')
        path = directory / bundle.scenario_name
        path.write_text(bundle.scenario_text, encoding='utf-8')
        # the base values in the place of the scenario's parameters_file (a path beside
        # the scenario on the client, not here): the runs start from them anyway
        _SCENARIOS[digest] = load_scenario(path, dict(bundle.base))
    return _SCENARIOS[digest]


def _in_dask_worker() -> bool:
    if 'distributed' not in sys.modules:
        return False
    try:
        sys.modules['distributed'].get_worker()
    except (ValueError, AttributeError):
        return False
    return True


def hard_limit(time_limit: float) -> float:
    """s of wall time after which a run that never came back to its deadline check (a
    controller or a compiled call that blocks) ends its worker process."""
    return 2.0 * time_limit + 10.0


def _end_process() -> None:
    os._exit(70)


class _Watchdog:
    """One thread per process that ends it when the run in progress passes its hard
    limit. A run sets its deadline and clears it (no thread started or woken per run,
    which would cost each run a thread switch); the thread sleeps until the deadline it
    read, at most :data:`WATCH_EVERY` s, and reads it again: a run that finished in time
    has replaced it (with the next run's, later, or with none)."""

    def __init__(self) -> None:
        self.deadline = math.inf
        self.thread: threading.Thread | None = None

    def arm(self, seconds: float) -> None:
        self.deadline = time.monotonic() + seconds
        if self.thread is None:
            self.thread = threading.Thread(target=self._watch, name='sweep-watchdog',
                                           daemon=True)
            self.thread.start()

    def disarm(self) -> None:
        self.deadline = math.inf

    def _watch(self) -> None:
        while True:
            left = self.deadline - time.monotonic()
            if left <= 0.0:
                _end_process()
            time.sleep(min(left, WATCH_EVERY))


#: s between two looks of the watchdog at the deadline of the run in progress.
WATCH_EVERY = 1.0
_WATCHDOG = _Watchdog()


def execute(bundle: Bundle, spec: RunSpec) -> Outcome:
    """Run ``spec`` (never raises: a failure is an outcome with its reason). In a Dask
    worker, a run blocked past :func:`hard_limit` ends the worker process, which its
    nanny restarts (the run becomes a lost-worker row on the client): no worker stays
    stuck. In the main thread (``--workers 1``) a timer stops the run at its limit wherever
    its Python code is (:class:`_Alarm`); elsewhere the check between ticks stops it."""
    watched = _in_dask_worker()
    if watched:
        _WATCHDOG.arm(hard_limit(bundle.time_limit))
    try:
        return _execute(bundle, spec)
    finally:
        if watched:
            _WATCHDOG.disarm()


def _execute(bundle: Bundle, spec: RunSpec) -> Outcome:
    from ..inprocess.simulation import Simulation
    from ..sim.commands import InputRejected

    started, cpu = time.perf_counter(), time.thread_time()
    nothing = tuple(math.nan for _ in bundle.metrics)
    guard = _Deadline(None, started + bundle.time_limit)
    alarm = _Alarm(bundle.time_limit)
    try:
        try:
            scenario = _scenario(bundle)
            simulation = Simulation.from_values(dict(bundle.base), **dict(spec.overrides))
            run = scenario.run(simulation=simulation, guard=guard.around)
            metrics = scenario.metrics(run).as_dict()
            values = tuple(float(metrics[name]) for name in bundle.metrics)
            status, reason = (Status.FAULT, run.fault) if run.fault else (Status.OK, '')
        finally:
            alarm.disarm()
    except RunTimeout:
        values, status = nothing, Status.TIMEOUT
        reason = (f'over the time limit of {bundle.time_limit:g} s of wall time; stopped at '
                  f'{guard.time:.4f} s of simulation')
    except InputRejected as exc:
        values, status = nothing, Status.ERROR
        reason = f'the controller answered with a command the node refuses: {exc}'
    except Exception as exc:  # noqa: BLE001 - any failure of one run is that run's row
        values, status = nothing, Status.ERROR
        reason = f'{type(exc).__name__}: {exc}'
    finally:
        alarm.restore()
    return Outcome(spec.index, spec.key, status, reason, values,
                   time.perf_counter() - started, time.thread_time() - cpu)


def execute_batch(bundle: Bundle, specs: Sequence[RunSpec]) -> list[Outcome]:
    """:func:`execute` for each of ``specs`` in turn (one cluster task for several short
    runs, so the task's own cost is shared), in a process that has loaded the model (a
    worker restarted after a blocked run has not)."""
    warm_up()
    return [execute(bundle, spec) for spec in specs]


_WARM: list[bool] = []


def warm_up() -> None:
    """Load the compiled model in this process, once (so the first run's time, and its
    time limit, are its own)."""
    if not _WARM:
        from ..inprocess.simulation import Simulation
        Simulation().reset()
        _WARM.append(True)


__all__ = ['Outcome', 'RunTimeout', 'Status', 'execute', 'execute_batch', 'warm_up']
