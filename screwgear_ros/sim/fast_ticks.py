"""The session's two fast paths, which :meth:`Session.advance
<screwgear_ros.sim.session.Session.advance>` takes when nobody needs a tick's
:class:`~screwgear_ros.sim.tick.Tick`: a closed loop's tick that takes only its
controller's answer, and runs of ticks that take no event, many to a compiled call.
Each leaves the session, its plant and sensors exactly as :meth:`Session.tick` would;
they are functions of the session (its private state included) kept apart from the
general tick so that each module does one job.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from ..interface import Input
from ..numerics.integrator import OBSERVED
from .commands import InputRejected, effort_drive
from .events import Command
from .plant import OBSERVED_DELTA, OBSERVED_JOINTS
from .tick import ROW, ROW_JOINTS, ROW_STEP, ROW_TE, Tick, row_of

if TYPE_CHECKING:
    from .session import Session

#: Ticks per compiled call of :func:`tick_quietly` (its scratch rows: 0.5 MB).
QUIET_TICKS_PER_CALL = 4096


def tick_effort(self: Session, effort: Any) -> Tick | None:
    """``tick(Command.of(Input.CMD_EFFORT, [effort]))``: a closed loop's tick, answered
    by its controller's signed drive torque ``effort``.

    When that tick only takes the answer (nothing else is queued, the answer is
    valid, the plant is running) it does to the session, its plant and sensors
    exactly what :meth:`Session.tick` does, without making the objects tick makes for it
    (its Tick, the stamped command; :attr:`Session.last_outputs` is made when read), and returns
    None: :attr:`Session.last_outputs`, :attr:`Session.measured`, :attr:`Plant.observed` and
    :attr:`Plant.fault` (the plant may have faulted in it) say what it made.
    Otherwise it is :meth:`Session.tick` itself, and returns its Tick."""
    plant = self.plant
    if self._pending or plant.fault is not None:
        return self.tick(Command.of(Input.CMD_EFFORT, [effort]))
    params = plant.params
    try:
        torque, direction = effort_drive(effort, params.max_torque, params.effort_deadband,
                                         plant.direction, params.direction_hysteresis)
    except InputRejected:                # tick refuses it, counts it and says why
        return self.tick(Command.of(Input.CMD_EFFORT, [effort]))
    plant.set_drive(torque, direction)
    self._last_command, self.timed_out = plant.step, False
    plant.advance(self._steps)
    self._outputs = None
    if not self.sensors.ideal:
        self._measure()
    return None


def tick_quietly(self: Session, n: int, values: np.ndarray) -> int:
    """Up to ``n`` ticks that take no event, for replays that sample every tick: the
    plant does exactly what ``n`` calls of :meth:`Session.tick` would make it do (the same
    calls, bit for bit), without a :class:`Tick` each, up to ``QUIET_TICKS_PER_CALL``
    ticks per compiled call (:meth:`Plant.advance_ticks`). Row i of ``values``
    (float64, at least n × ROW) gets tick i's outputs: θ(3) rad, ω(3) rad/s,
    effort(3) N·m, transmission error m, and the step they are at (exact in float64;
    a faulted plant's time stands still); :attr:`Session.last_outputs` is the last one's.

    The exact outputs only: the sensors (:attr:`Session.measured`) do not follow these
    ticks (replays compare the exact state; ``check_run`` measures it afresh).

    Stops before a tick that would do more than integrate: events are queued, or
    ``command_timeout`` comes due at its first step (:meth:`Session.tick` does that one); and
    after a tick in which the plant faulted (:attr:`Plant.fault` says why). Returns
    the number of ticks done.
    """
    with self._lock:
        if self._pending:
            return 0
    plant = self.plant
    if self._timeout_steps is not None and not self.timed_out:
        left = self._last_command + self._timeout_steps - plant.step
        n = min(n, max(0, -(-left // self._steps)))   # ticks starting before it is due
    if n <= 0:
        return 0
    if plant.fault is not None:          # standing still: every tick the same row
        self._outputs = plant.advance_outputs(self._steps)
        values[:n, :ROW] = row_of(self._outputs)
        return n
    if self._observed is None:
        self._observed = np.empty((QUIET_TICKS_PER_CALL, OBSERVED))
    delta = OBSERVED_DELTA[self.last_outputs.active_path]     # no event: the path stays
    done = 0
    while done < n and plant.fault is None:
        step0 = plant.step
        k = plant.advance_ticks(min(n - done, QUIET_TICKS_PER_CALL), self._steps,
                                self._observed)                  # one compiled call
        rows, observed = values[done:done + k], self._observed[:k]
        rows[:, ROW_JOINTS] = observed[:, OBSERVED_JOINTS]
        rows[:, ROW_TE] = observed[:, delta]
        rows[:, ROW_STEP] = step0 + self._steps * np.arange(1, k + 1)
        if plant.fault is not None:      # the last tick faulted: its time stood still
            rows[k - 1, ROW_STEP] = plant.step
        done += k
    self._outputs = plant.last_outputs()
    return done


__all__ = ['QUIET_TICKS_PER_CALL', 'tick_effort', 'tick_quietly']
