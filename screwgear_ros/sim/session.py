"""One simulation run: the plant, an ordered queue of typed events, ticks, the outputs.

:class:`Session` is the only simulation loop in the project, and
:meth:`Session.advance` its one door: N ticks or up to a step (:meth:`Session.advance_to`:
a time), submitting the events of a schedule as their step comes, asking an optional
controller before each tick and telling an optional monitor after it (Drake's
``Simulator.AdvanceTo`` with a monitor is the model). In-process runs, replays, the
energy audit and the paper's studies go through it; the node's pacing thread, which
makes one tick at a time against the wall clock or a lockstep answer, calls
:meth:`Session.tick`, the single tick that ``advance`` is made of.

A tick is what the node does between two publications:

1. every event submitted since the last tick (:mod:`screwgear_ros.sim.events`: a
   command, a parameter change, a reset, a setpoint to record) takes effect, in
   submission order, at the tick's first step; each comes back with that step set;
2. the plant integrates ``settings.steps_per_publish`` RK4 steps in one compiled
   call (none once the model has diverged: the plant then stands still, state and
   time, until a reset);
3. the outputs of the tick's last step are computed, and what the joint sensors
   measure of them (:mod:`screwgear_ros.physics.sensors`: the outputs themselves when every
   sensor is ideal). A reset restarts the sensors' chain; a parameter change hands them
   its settings.

A closed loop's tick, whose one event is its controller's answer, runs a fast path
when nobody needs its :class:`Tick` (:meth:`Session.advance` with a controller and not
``every_tick``): the same tick, without the objects a tick makes for callers that log
or record it. Ticks that take no event, when only their outputs are wanted (``rows``),
run many to a compiled call. Both leave every bit as :meth:`Session.tick` would.

Commands are validated when they take effect, against the parameters in force at
that step (:func:`screwgear_ros.sim.commands.apply_command`); a refused command changes
nothing and is counted. A parameter change that lowers a limit below the input in
force cuts that input to the new limit and says so in the tick's notices.

``command_timeout`` (settings, s of simulation time, 0 = off): when no command has
been accepted for that long, at the first step of a tick, the drive torque and the
load go to zero (the direction stays); the tick's notices say so once, and
:attr:`Session.timed_out` stays true until the next accepted command. Counting in
simulation time makes it the same in a replay, in lockstep and at any real-time
factor.

Threads: :meth:`Session.submit` may be called from any thread (it takes the lock
that guards the queue, and nothing else). Everything else (``tick``, ``plant``,
``settings``, ``rejected``) belongs to the one thread that drives the session.
"""

from __future__ import annotations

import math
import threading
import warnings
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from ..interface import INFO_TOPICS, Input
from ..params.table import SimSettings, TableParams
from ..physics.sensors import SensorChain
from . import fast_ticks
from .commands import INPUT_TOPICS, InputRejected, apply_command, limit_input
from .events import Command, Event, ParameterChange, Reset, Setpoint, Timeline
from .plant import Outputs, Plant
from .tick import ROW, ROW_JOINTS, ROW_STEP, ROW_TE, Tick, row_of


class Session:
    """Plant, event queue and outputs of one run; see the module docstring."""

    def __init__(self, params: TableParams, settings: SimSettings,
                 initial_state: np.ndarray | None = None, start_step: int = 0) -> None:
        self.plant = Plant(params, settings.dt, initial_state, settings.contact_location)
        self.plant.step = int(start_step)
        self._use(settings)
        self.start_step = int(start_step)
        self.initial_state = tuple(float(v) for v in self.plant.state)
        self.rejected = {topic: 0 for topic in (*INPUT_TOPICS, *INFO_TOPICS)}
        self.timed_out = False                 # command_timeout zeroed the input
        self._last_command = self.start_step   # step of the last accepted command
        self._lock = threading.Lock()          # guards _pending only
        self._pending: list[Event] = []
        self._observed: np.ndarray | None = None   # the compiled ticks' rows, made on first use
        self._outputs: Outputs | None = self.plant.compute_outputs()
        self.sensors = SensorChain(settings.sensors, settings.dt)
        self._measure()

    def _use(self, settings: SimSettings) -> None:
        """Settings in force from now on, and what ``tick`` derives from them (once per
        change, not per tick): steps per tick, command_timeout in steps (None = off)."""
        self.settings = settings
        self._steps = settings.steps_per_publish
        self._timeout_steps = (round(settings.command_timeout / settings.dt)
                               if settings.command_timeout > 0.0 else None)

    @property
    def step(self) -> int:
        """Integration steps since the start of simulation time."""
        return self.plant.step

    @property
    def last_outputs(self) -> Outputs:
        """The outputs of the last tick (before the first: of the start)."""
        outputs = self._outputs
        if outputs is None:      # a fast closed-loop tick left them in the plant: made when read
            self._outputs = outputs = self.plant.last_outputs()
        return outputs

    @property
    def measured(self) -> Outputs:
        """What joint_states publishes of :attr:`last_outputs` (the same object when every
        sensor is ideal). :meth:`advance` with ``rows`` leaves the sensors' chain alone (sensors
        that are not ideal: this stays what they measured last)."""
        measured = self._measured
        return self.last_outputs if measured is None else measured

    def _measure(self) -> None:
        """The sensors' sample of the tick just done (:attr:`measured`; None: ideal
        sensors, the outputs themselves, left to be made when read)."""
        sensors = self.sensors
        if sensors.ideal:
            self._measured = None
        else:
            outputs = self.last_outputs
            measured = sensors.measure(outputs)
            self._measured = None if measured is outputs else measured

    def submit(self, event: Event) -> None:
        """Queue ``event``; it takes effect at the first step of the next tick. Any thread."""
        with self._lock:
            self._pending.append(event)

    def advance(self, ticks: int | None = None, *, until: int | None = None,
                events: Sequence[Event] | Timeline = (),
                controller: Callable[[], Any] | None = None,
                monitor: Callable[[Tick | None], bool | None] | None = None,
                every_tick: bool = False,
                changes: Callable[[ParameterChange], None] | None = None,
                rows: np.ndarray | None = None) -> int:
        """Advance ``ticks`` ticks, or until the step ``until``, submitting the events due
        on the way: the session's one loop.

        Before each tick: the events of ``events`` whose step the session has reached are
        submitted (:class:`~screwgear_ros.sim.events.Timeline`: they take effect at the
        tick's first step), then ``controller()`` is asked for its answer. After each
        tick: ``monitor(tick)``.

        Parameters
        ----------
        ticks : int, optional
            How many ticks to do.
        until : int, optional
            Tick while the session's step is below this one; stops early once the plant
            has faulted (its time then stands still). At least one of ``ticks`` and
            ``until`` is given; with both, whichever comes first.
        events : sequence of Event or Timeline
            Events with their step set, in step order (a Timeline continues where an
            earlier advance left it).
        controller : callable, optional
            ``controller() -> effort``: cmd_effort's signed drive torque (N·m) for the
            coming tick, or None for no command.
        monitor : callable, optional
            ``monitor(tick)`` after every tick; it gets None when the tick took nothing
            but the controller's answer and ran the fast path (no :class:`Tick` made:
            :attr:`last_outputs`, :attr:`measured` and the plant say what it did). A true
            return stops the advance after that tick.
        every_tick : bool
            Make every tick a full :meth:`tick`, so the monitor always gets its Tick (a
            recording writes it).
        changes : callable, optional
            Who submits a parameter change of ``events`` (a recording renders its texts
            first); default: :meth:`submit`.
        rows : ndarray, optional
            Row i (``ROW`` columns, :func:`row_of`) gets tick i's exact outputs. With no
            controller and not ``every_tick``, the ticks that take no event then run as
            :meth:`advance` with ``rows`` does, many in one compiled call, and the monitor sees
            only the full ticks (those that applied an event or timed a command out).

        Returns
        -------
        int
            The ticks done.

        Raises
        ------
        ValueError
            Neither ``ticks`` nor ``until`` given, or an event without its step.

        Examples
        --------
        >>> from screwgear_ros.params.table import SimSettings, TableParams
        >>> session = Session(TableParams(), SimSettings())
        >>> per_tick = session.settings.steps_per_publish
        >>> session.advance(until=10 * per_tick)
        10
        >>> session.step == 10 * per_tick
        True
        """
        if ticks is None and until is None:
            raise ValueError('advance needs ticks, until or both')
        timeline = events if isinstance(events, Timeline) else Timeline(events)
        limit = math.inf if ticks is None else ticks
        submit = self.submit
        plant = self.plant
        quiet = rows is not None and controller is None and not every_tick
        done = 0
        while done < limit and (until is None or (plant.step < until
                                                   and (done == 0 or plant.fault is None))):
            due = timeline.next_step
            if due is not None and due <= plant.step:
                for event in timeline.due(plant.step):
                    if changes is not None and isinstance(event, ParameterChange):
                        changes(event)
                    else:
                        submit(event)
            elif quiet:
                n = limit - done
                if until is not None:         # ticks that start below ``until``
                    n = min(n, -(-(until - plant.step) // self._steps))
                if due is not None:           # ticks that start before the next event
                    n = min(n, -(-(due - plant.step) // self._steps))
                k = fast_ticks.tick_quietly(self, int(n), rows[done:])   # type: ignore[index]
                if k:
                    done += k
                    continue
            effort = None if controller is None else controller()
            if effort is None:
                tick: Tick | None = self.tick()
            elif every_tick:
                tick = self.tick(Command.of(Input.CMD_EFFORT, [effort]))
            else:
                tick = fast_ticks.tick_effort(self, effort)
            if rows is not None:
                rows[done] = row_of(self.last_outputs)
            done += 1
            if monitor is not None and monitor(tick):
                break
        return done

    def advance_to(self, time: float, **kwargs: Any) -> int:
        """:meth:`advance` until simulation time ``time`` (s): ticks while the step's
        time is below it, so a time on the tick grid is where it stops exactly.

        Parameters
        ----------
        time : float
            Simulation time to reach, s.
        **kwargs
            As :meth:`advance` takes them (``events``, ``controller``, ``monitor`` ...).

        Returns
        -------
        int
            The ticks done.

        Examples
        --------
        >>> from screwgear_ros.params.table import SimSettings, TableParams
        >>> session = Session(TableParams(), SimSettings(dt=1e-4, publish_rate=100.0))
        >>> session.advance_to(0.05)
        5
        """
        return self.advance(until=math.ceil(round(time / self.settings.dt, 6)), **kwargs)

    def tick(self, command: Command | None = None) -> Tick:
        """Apply the queued events, integrate one tick, compute its outputs.

        ``command``: what ``submit(command)`` just before would do, without the queue
        when nothing else waits in it (a closed loop's tick: its controller's answer)."""
        plant = self.plant
        start = plant.step
        previous = self.last_outputs
        previous_direction = plant.input.direction
        applied: tuple[Event, ...] = ()
        rejected: tuple[InputRejected, ...] = ()
        notices: tuple[str, ...] = ()
        commanded = False
        # Read without the lock first: only this thread empties the queue, and an event
        # submitted just after the read is as late as one submitted after the swap.
        if self._pending:
            if command is not None:
                self.submit(command)
            with self._lock:
                events, self._pending = self._pending, []
            applied, rejected, notices, commanded = self._apply(events, start)
        elif command is not None:
            error = self._command(command)
            if error is None:
                applied, commanded = (command.at(start),), True
            else:
                rejected = (error,)
        if commanded:                        # an accepted command restarts the timeout
            self._last_command, self.timed_out = start, False
        elif self._timeout_steps is not None:
            notice = self._time_out(start)
            if notice is not None:
                notices = (*notices, notice)
        fault = plant.fault
        self._outputs = outputs = plant.advance_outputs(self._steps)
        self._measure()
        return Tick(start, applied, rejected, notices, plant.input, plant.params, outputs,
                    previous, previous_direction, plant.fault,
                    fault is None and plant.fault is not None, self._measured)

    def _apply(self, events: list[Event], start: int) -> tuple[
            tuple[Event, ...], tuple[InputRejected, ...], tuple[str, ...], bool]:
        """Apply ``events`` in order at step ``start``: those applied (``step`` set), the
        commands refused, the notices of inputs a parameter change cut, and whether a
        command was accepted."""
        plant = self.plant
        applied: list[Event] = []
        rejected: list[InputRejected] = []
        notices: list[str] = []
        commanded = False
        if len(events) == 1 and isinstance(events[0], Command):
            # A closed loop's tick (one command): the same as the loop below, without
            # building its lists.
            error = self._command(events[0])
            if error is not None:
                return (), (error,), (), False
            return (events[0].at(start),), (), (), True
        for event in events:
            if isinstance(event, Command):
                error = self._command(event)
                if error is not None:
                    rejected.append(error)
                    continue
                commanded = True
            elif isinstance(event, ParameterChange):
                plant.set_params(event.params)
                self._use(event.settings)
                self.sensors.configure(event.settings.sensors)
                drive, notice = limit_input(plant.input, event.params)
                if notice is not None:
                    plant.set_input(drive)
                    notices.append(notice)
            elif isinstance(event, Reset):
                plant.reset()
                self.sensors.restart()
            elif isinstance(event, Setpoint):
                error = self._setpoint(event)
                if error is not None:
                    rejected.append(error)
                    continue
            else:
                raise TypeError(f'not a session event: {event!r}')
            applied.append(event.at(start))
        return tuple(applied), tuple(rejected), tuple(notices), commanded

    def _command(self, command: Command) -> InputRejected | None:
        """Fold ``command`` into the input in force, validated against the parameters in
        force; the refusal (counted) if it is refused."""
        plant = self.plant
        try:
            plant.set_input(apply_command(plant.input, command.topic, command.value,
                                          plant.params, self.settings.joint_names))
        except InputRejected as error:
            self.rejected[command.topic] += 1
            return error
        return None

    def _setpoint(self, setpoint: Setpoint) -> InputRejected | None:
        """The refusal (counted) of a setpoint that is no finite angle; it is only
        recorded, so nothing else is checked."""
        value = setpoint.value
        if isinstance(value, bool) or not isinstance(value, (int, float)) \
                or not math.isfinite(value):
            self.rejected[Input.SETPOINT] += 1
            return InputRejected(Input.SETPOINT, value, 'a setpoint must be a finite angle, rad')
        return None

    def _time_out(self, start: int) -> str | None:
        """command_timeout (module docstring), at the first step of a tick that accepted
        no command; the notice when it zeroes the input."""
        if (self.timed_out or self._timeout_steps is None
                or start - self._last_command < self._timeout_steps):
            return None
        self.timed_out = True
        drive = self.plant.input
        if not (drive.torque or drive.load):
            return None
        self.plant.set_input(replace(drive, torque=0.0, load=0.0))
        return (f'no command for {self.settings.command_timeout:g} s of simulation time '
                f'(command_timeout): drive torque ({drive.torque:g} N·m) and load '
                f'({drive.load:g} N·m) set to zero until the next command')

def _deprecated_tick(path: Any) -> Any:
    """``Session.<name>``, the old public name of a path :meth:`Session.advance` takes,
    for one release."""
    def tick(self: Session, *args: Any) -> Any:
        warnings.warn(f'Session.{path.__name__} is deprecated: Session.advance runs it',
                      DeprecationWarning, stacklevel=2)
        return path(self, *args)
    tick.__name__ = path.__name__
    return tick


Session.tick_effort = _deprecated_tick(fast_ticks.tick_effort)    # type: ignore[attr-defined]
Session.tick_quietly = _deprecated_tick(fast_ticks.tick_quietly)  # type: ignore[attr-defined]

__all__ = [
    'ROW',
    'ROW_JOINTS',
    'ROW_STEP',
    'ROW_TE',
    'Session',
    'Tick',
    'row_of',
]
