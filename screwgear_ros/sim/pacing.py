"""Pacing a fixed-step simulation against the wall clock, with honest bookkeeping.

:class:`Pacer` sleeps to absolute deadlines ``t0 + k·period / real_time_factor``
(never ``sleep(period)``, so sleep errors do not accumulate and simulation time
does not drift from wall time). A tick whose work ends after its deadline is an
*overrun*; the pacer then runs the next ticks without sleeping until it has
caught up. If it falls further behind than ``max_lag`` seconds of wall time it
stops trying to catch up and re-anchors its schedule at the present (a
*resync*), so a machine that cannot keep up runs slower instead of bursting, and
says so in its statistics. ``real_time_factor`` 0 never sleeps.

The pacer sleeps in slices of at most :data:`MAX_SLEEP` and wakes at once when its
``wake`` event is set (the node sets it when a parameter change arrives), so a change
takes effect within one tick or MAX_SLEEP of wall time, whichever comes first, however
slow the pace in force: a change never waits for a far deadline of the old pace.

No ROS here: the node's pacing thread uses it, tests drive it with a fake clock.
"""

from __future__ import annotations

import contextlib
import math
import os
import select
import sys
import threading
import time
import weakref
from collections.abc import Callable
from dataclasses import dataclass

#: Longest single sleep of the pacer, s of wall time: the most a stop waits to be seen.
MAX_SLEEP = 0.05


def wall_period(period: float, real_time_factor: float) -> float:
    """Wall time per tick, s, of a tick of ``period`` s at ``real_time_factor`` (0: as
    fast as possible, 0 s); ValueError when it is not a finite, non-negative time."""
    if not period > 0.0 or not math.isfinite(period):
        raise ValueError(f'period must be > 0 s, got {period!r}')
    if not real_time_factor >= 0.0 or not math.isfinite(real_time_factor):
        raise ValueError(f'real_time_factor must be >= 0, got {real_time_factor!r}')
    if real_time_factor == 0.0:
        return 0.0
    wall = period / real_time_factor
    if not math.isfinite(wall):
        raise ValueError(f'a tick of {period:g} s at real-time factor {real_time_factor:g} '
                         'lasts no finite wall time')
    return wall


@dataclass
class PacerStats:
    """What the pacer saw since it started (wall-clock seconds)."""

    ticks: int = 0
    overruns: int = 0          # ticks that ended after their deadline
    resyncs: int = 0           # times the schedule was re-anchored (fell > max_lag behind)
    lost_time: float = 0.0     # wall time given up by resyncs, s
    max_lag: float = 0.0       # largest lateness of a tick, s
    last_lag: float = 0.0      # lateness of the last tick (0 if on time), s


class Pacer:
    """Sleeps to absolute deadlines t0 + k·period/factor; counts overruns.

    ``period`` is the simulation time per tick, s; ``real_time_factor`` the wanted
    ratio of simulation to wall time (0 = as fast as possible).
    """

    def __init__(self, period: float, real_time_factor: float, max_lag: float = 0.1,
                 clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep) -> None:
        wall_period(period, real_time_factor)
        self._clock = clock
        self._sleep = sleep
        self.max_lag = max_lag
        self.stats = PacerStats()
        self.restart(period, real_time_factor)

    def restart(self, period: float, real_time_factor: float) -> None:
        """Re-anchor the schedule at now with a new period (s) and factor."""
        self._wall_period = wall_period(period, real_time_factor)
        self.period = period
        self.real_time_factor = real_time_factor
        self._t0 = self._clock()
        self._k = 0

    @property
    def wall_period(self) -> float:
        """Wall time per tick, s (0 when running as fast as possible)."""
        return self._wall_period

    def next_deadline(self) -> float:
        """Wall-clock time (of ``clock``) at which the next tick is due."""
        return self._t0 + (self._k + 1) * self.wall_period

    def wait(self, stop: threading.Event | None = None,
             wake: threading.Event | None = None) -> bool:
        """Sleep until the next tick's deadline; False if ``stop`` was set meanwhile.

        Call once per tick after its work is done; the deadline of tick k is
        t0 + k·wall_period. Without events it sleeps with ``sleep``. With them it
        sleeps in slices of at most MAX_SLEEP on ``wake`` (else ``stop``), and returns
        early, True, once ``wake`` is set (it clears it): the caller then runs its next
        tick at once, which applies what woke it.
        """
        self.stats.ticks += 1
        if self.real_time_factor == 0.0:
            self._k += 1
            return not (stop is not None and stop.is_set())
        deadline = self.next_deadline()
        self._k += 1
        now = self._clock()
        lag = now - deadline
        if lag > 0.0:
            self.stats.overruns += 1
            self.stats.last_lag = lag
            self.stats.max_lag = max(self.stats.max_lag, lag)
            if lag > max(self.max_lag, 2.0 * self.wall_period):
                self.stats.resyncs += 1
                self.stats.lost_time += lag
                self._t0, self._k = now, 0
            return not (stop is not None and stop.is_set())
        self.stats.last_lag = 0.0
        if stop is None and wake is None:
            self._sleep(-lag)
            return True
        return self._sleep_until(deadline, stop, wake)

    def _sleep_until(self, deadline: float, stop: threading.Event | None,
                     wake: threading.Event | None) -> bool:
        event = wake if wake is not None else stop
        assert event is not None             # the caller sleeps plainly without either
        while True:
            if stop is not None and stop.is_set():
                return False
            if wake is not None and wake.is_set():
                wake.clear()
                return True
            left = deadline - self._clock()
            if left <= 0.0:
                return True
            event.wait(min(left, MAX_SLEEP))


class FactorMeter:
    """Achieved real-time factor over a window: simulated time / wall time."""

    def __init__(self, clock: Callable[[], float] = time.monotonic) -> None:
        self._clock = clock
        self._wall0 = clock()
        self._sim0 = 0.0
        self.value = math.nan   # last measured factor (NaN before the first window)

    def update(self, sim_time: float) -> float:
        """Close the window at simulation time ``sim_time`` (s); return the factor."""
        now = self._clock()
        wall = now - self._wall0
        if wall > 0.0:
            self.value = (sim_time - self._sim0) / wall
        self._wall0, self._sim0 = now, sim_time
        return self.value

    def elapsed(self) -> float:
        """Wall time since the window opened, s."""
        return self._clock() - self._wall0


#: What a ring writes: an eventfd adds the 8-byte count written to its own.
_ONE = (1).to_bytes(8, sys.byteorder)


def _close(fds: set[int]) -> None:
    for fd in fds:
        os.close(fd)


class Doorbell:
    """A wake-up from one thread to another that rings without the interpreter lock.

    :meth:`ring` writes to an eventfd (a pipe where there is none) and :meth:`wait`
    polls it; both system calls release the interpreter lock. A threading primitive
    instead wakes the waiter while the ringing thread still holds the lock: the waiter
    wakes, finds the lock taken, sleeps again until the ringing thread lets it go, two
    wake-ups per hand-off (benchmarks/bench_loop.py's hand-off floor measures what the
    hand-off costs). Rings coalesce: one :meth:`wait` consumes all rung before it.
    """

    def __init__(self) -> None:
        if hasattr(os, 'eventfd'):
            self._read = self._write = os.eventfd(0, os.EFD_NONBLOCK | os.EFD_CLOEXEC)
        else:                                   # no eventfd: a pipe
            self._read, self._write = os.pipe()
            os.set_blocking(self._read, False)
            os.set_blocking(self._write, False)
        self._poll = select.poll()
        self._poll.register(self._read, select.POLLIN)
        self._closer = weakref.finalize(self, _close, {self._read, self._write})

    def ring(self) -> None:
        """Wake the thread in :meth:`wait` (or the next one to wait)."""
        with contextlib.suppress(BlockingIOError):   # full: rings enough are pending
            os.write(self._write, _ONE)

    def wait(self, timeout: float) -> bool:
        """Wait up to ``timeout`` s for a ring; whether one came (and consume it)."""
        if not self._poll.poll(max(0, math.ceil(timeout * 1000.0))):
            return False
        try:
            os.read(self._read, 4096)
        except BlockingIOError:                 # another waiter consumed it
            return False
        return True


class AnswerGate:
    """Lockstep: tick k+1 starts only once the controller answered tick k's outputs.

    The pacing thread calls :meth:`expect` just before it publishes a tick's
    outputs, then :meth:`wait`; a subscription callback calls :meth:`answer` for
    every answer message. An answer counts only while one is expected (after the
    outputs it answers were published and before the next tick starts), so a
    duplicate answer to an earlier tick never releases a later one. Thread-safe;
    :meth:`release` wakes a waiting thread for shutdown. The answer wakes the waiting
    thread with a :class:`Doorbell`, outside the gate's lock.
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._bell = Doorbell()
        self._expecting = False     # guarded by _lock
        self._answered = False      # guarded by _lock
        self._released = False      # guarded by _lock
        self.ignored = 0            # answers that came when none was expected (pacing thread reads)

    def expect(self) -> None:
        """Open the window for the answer to the outputs about to be published."""
        with self._lock:
            self._expecting, self._answered = True, False

    def answer(self) -> bool:
        """One answer arrived; True if it releases the next tick."""
        with self._lock:
            if not self._expecting or self._answered:
                self.ignored += 1
                return False
            self._answered = True
        self._bell.ring()
        return True

    def wait(self, timeout: float) -> bool:
        """Wait up to ``timeout`` s for the answer; True (and the window closed) once
        it came, False on timeout or after :meth:`release`."""
        deadline = time.monotonic() + timeout
        while True:
            with self._lock:
                if self._answered:
                    self._expecting = self._answered = False
                    return True
                if self._released:
                    return False
            left = deadline - time.monotonic()
            if left <= 0.0:
                return False
            self._bell.wait(left)     # a ring of an answer already taken wakes it early

    def release(self) -> None:
        """Wake any waiting thread for good (shutdown)."""
        with self._lock:
            self._released = True
        self._bell.ring()


__all__ = [
    'MAX_SLEEP',
    'AnswerGate',
    'Doorbell',
    'FactorMeter',
    'Pacer',
    'PacerStats',
    'wall_period',
]
