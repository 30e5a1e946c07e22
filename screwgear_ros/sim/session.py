"""One simulation run: the plant, an ordered queue of typed events, ticks, the outputs.

:class:`Session` is the only simulation loop in the project, and
:meth:`Session.advance` its one door: N ticks or up to a step (:meth:`Session.advance_to`:
a time), submitting the events of a timeline as their step comes, asking an optional
controller before each tick and telling an optional monitor after it (Drake's
``Simulator.AdvanceTo`` with a monitor is the model). In-process runs, replays, the
energy audit and the paper's studies go through it. The node's pacing thread calls
:meth:`Session.tick`, the single tick that ``advance`` is made of: it waits for the wall
clock or a lockstep answer between two ticks, and its answer arrives through
:meth:`Session.submit` from another thread, so no loop of ``advance`` can hold it.

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

What a tick makes for its caller is :meth:`Session.advance`'s ``mode``
(:class:`~screwgear_ros.sim.tick.AdvanceMode`: a full :class:`Tick`, none for a tick that
takes only the controller's answer, or only a row of outputs for ticks that take no
event, many to a compiled call); every mode leaves every bit as :meth:`Session.tick` does.

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

import threading
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ..interface import INFO_TOPICS, Input
from ..params.table import SimSettings, TableParams
from ..physics.sensors import SensorChain
from .commands import (
    INPUT_TOPICS,
    InputRejected,
    apply_command,
    effort_drive,
    finite_number,
    limit_input,
    timed_out_input,
)
from .events import AdvanceError, Command, Event, ParameterChange, Reset, Setpoint, Timeline
from .plant import Outputs, Plant
from .row_ticks import RowTicks
from .tick import (
    ROW,
    ROW_JOINTS,
    ROW_STEP,
    ROW_TE,
    AdvanceMode,
    Tick,
    advance_limits,
    row_of,
    step_of_time,
)


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
        self._row_ticks = RowTicks()           # AdvanceMode.ROWS's compiled ticks
        self._outputs: Outputs | None = self.plant.compute_outputs()
        self.sensors = SensorChain(settings.sensors, settings.dt)
        self._measure()

    def _use(self, settings: SimSettings) -> None:
        """Settings in force from now on, and what ``tick`` derives from them once per
        change: steps per tick, command_timeout in steps (None = off)."""
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
        sensor is ideal); :attr:`AdvanceMode.ROWS`'s compiled ticks leave it as it was."""
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
                mode: AdvanceMode = AdvanceMode.TICKS,
                rows: np.ndarray | None = None,
                changes: Callable[[ParameterChange], None] | None = None) -> int:
        """Advance ``ticks`` ticks, or until the step ``until``, submitting the events due
        on the way: the session's one loop (Drake's ``Simulator.AdvanceTo`` with a
        monitor; its boundary is a step here, :meth:`advance_to` takes a time).

        Before each tick: the events of ``events`` whose step the session has reached are
        submitted (:class:`~screwgear_ros.sim.events.Timeline`: they take effect at the
        tick's first step), then ``controller()`` is asked for its answer. After each
        tick: ``monitor(tick)``.

        Parameters
        ----------
        ticks : int, optional
            How many ticks to do, an integer >= 0.
        until : int, optional
            Tick while the session's step is below this one (an integer, not below the
            session's step), or until the plant faults (its time then stands still).
            ``ticks``, ``until`` or both (whichever comes first).
        events : sequence of Event or Timeline
            Events with their step set, in step order (a Timeline continues where an
            earlier advance left it). An event out of step order, or, in a new sequence,
            one before the session's step, is refused: none is applied after its step.
        controller : callable, optional
            ``controller() -> effort``: cmd_effort's signed drive torque (N·m) for the
            coming tick, or None for no command.
        monitor : callable, optional
            ``monitor(tick)`` after a tick (``mode`` says which it sees, and when it gets
            None); a true return stops the advance after that tick.
        mode : AdvanceMode
            What a tick makes (:class:`AdvanceMode`: ``ROWS`` needs ``rows``); every mode
            leaves the same bits.
        rows : ndarray, optional
            Row i (``ROW`` columns, :func:`row_of`) gets tick i's exact outputs; at
            least as many rows as ticks are done.
        changes : callable, optional
            Who submits a parameter change of ``events`` (a recording renders its texts
            first); default: :meth:`submit`.

        Returns
        -------
        int
            The ticks done.

        Raises
        ------
        AdvanceError
            An argument that breaks its rule (the message names it and the rule).

        Examples
        --------
        >>> from screwgear_ros.params.table import SimSettings, TableParams
        >>> session = Session(TableParams(), SimSettings())
        >>> per_tick = session.settings.steps_per_publish
        >>> session.advance(until=10 * per_tick), session.step == 10 * per_tick
        (10, True)
        >>> session.advance(2.5)
        Traceback (most recent call last):
        ...
        screwgear_ros.sim.events.AdvanceError: ticks must be an integer >= 0, got 2.5
        """
        limit, timeline = advance_limits(self.plant.step, self._steps, ticks, until,
                                          events, mode, rows)
        submit = self.submit
        plant = self.plant
        quiet = mode is AdvanceMode.ROWS and controller is None
        fast = mode is AdvanceMode.ANSWERS
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
                k = self._tick_rows(int(n), rows[done:])   # type: ignore[index]
                if k:
                    done += k
                    continue
            effort = None if controller is None else controller()
            if effort is None:
                tick: Tick | None = self.tick()
            elif fast:
                tick = self._tick_answer(effort)
            else:
                tick = self.tick(Command.of(Input.CMD_EFFORT, [effort]))
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
            Simulation time to reach, s: a finite number, not before the session's time.
        **kwargs
            As :meth:`advance` takes them (``events``, ``controller``, ``monitor`` ...).

        Returns
        -------
        int
            The ticks done.

        Raises
        ------
        AdvanceError
            ``time`` or another argument that breaks its rule.

        Examples
        --------
        >>> from screwgear_ros.params.table import SimSettings, TableParams
        >>> session = Session(TableParams(), SimSettings(dt=1e-4, publish_rate=100.0))
        >>> session.advance_to(0.05)
        5
        """
        return self.advance(until=step_of_time(time, self.plant.step, self.settings.dt),
                            **kwargs)

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

    def _tick_answer(self, effort: Any) -> Tick | None:
        """``tick(Command.of(Input.CMD_EFFORT, [effort]))`` (:attr:`AdvanceMode.ANSWERS`): when
        the tick only takes the answer (nothing else queued, the answer valid, the plant
        running) it does to the session, plant and sensors exactly what :meth:`tick`
        does, without the objects tick makes (its Tick, the stamped command;
        :attr:`last_outputs` is made when read), and returns None. Otherwise it is
        :meth:`tick` itself, and returns its Tick."""
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

    def _tick_rows(self, n: int, rows: np.ndarray) -> int:
        """Up to ``n`` ticks that take no event (``ROWS``: :class:`RowTicks`), their outputs
        in ``rows``, the plant left as ``n`` :meth:`tick` calls leave it. Stops before a
        tick that does more than integrate (events queued, ``command_timeout`` due) and
        after one in which the plant faulted. Returns the ticks done."""
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
            rows[:n, :ROW] = row_of(self._outputs)
            return n
        done = self._row_ticks.run(plant, n, self._steps, rows, self.last_outputs.active_path)
        self._outputs = plant.last_outputs()
        return done

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
            elif isinstance(event, Setpoint):    # only recorded: a finite angle, nothing else
                if not finite_number(event.value):
                    self.rejected[Input.SETPOINT] += 1
                    rejected.append(InputRejected(Input.SETPOINT, event.value,
                                                  'a setpoint must be a finite angle, rad'))
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
        except (TypeError, ValueError, OverflowError):   # an int beyond float64, an array
            self.rejected[command.topic] += 1
            return InputRejected(command.topic, command.value,
                                 'a message of this topic cannot carry it')
        return None

    def _time_out(self, start: int) -> str | None:
        """command_timeout (module docstring), at the first step of a tick that accepted
        no command; the notice when it zeroes the input."""
        if (self.timed_out or self._timeout_steps is None
                or start - self._last_command < self._timeout_steps):
            return None
        self.timed_out = True
        zeroed = timed_out_input(self.plant.input, self.settings.command_timeout)
        if zeroed is None:
            return None
        self.plant.set_input(zeroed[0])
        return zeroed[1]


__all__ = ['ROW', 'ROW_JOINTS', 'ROW_STEP', 'ROW_TE', 'AdvanceError', 'AdvanceMode', 'Session',
           'Tick', 'row_of']
