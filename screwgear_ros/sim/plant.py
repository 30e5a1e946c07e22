"""The simulated table as one object: state, step counter, current input, outputs.

:class:`Plant` is what the node (and in-process replays and tests) drive: set the
input, ``advance(n)``, read :meth:`Plant.compute_outputs`. It holds no ROS. Simulation time
is ``step·dt`` exactly; the plant, which owns the step and dt, stamps every
:class:`Outputs` with it once, in seconds and in the integer nanoseconds of the
messages' stamps (:func:`~screwgear_ros.sim.simtime.sim_time_ns`): nothing downstream
recomputes it. ``contact_location`` (settings) selects RK4 with contact
changes located inside the steps, or plain fixed-step RK4
(:func:`screwgear_ros.numerics.integrator.advance`). If a step ever produces a non-finite state
(parameters whose physics diverges: RK4 itself is kept stable by ``check_step``) the
plant restores the last finite state, stops, and reports why through
:attr:`Plant.fault`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..numerics.integrator import OBSERVED, advance_observed, advance_ticks, observe
from ..numerics.stability import check_step
from ..params.table import TableParams
from ..physics.drive import DriveInput, active_path
from ..physics.equilibrium import equilibrium_state
from ..physics.packed import N_MECHANICAL, N_STATE, Drive, PackedModel, pack
from .simtime import sim_time_ns


@dataclass(slots=True)
class Outputs:
    """Everything the node publishes about one instant, SI units.

    Read-only by convention: nothing changes one after the plant made it. Not
    ``frozen``: a frozen dataclass sets each field through ``object.__setattr__``, which
    costs several times a plain slot store, and the node makes one a tick.
    """

    time: float                              # simulation time, s
    time_ns: int                             # the same, integer ns (sim_time_ns: stamps)
    step: int                                # integration steps since start
    position: tuple[float, float, float]     # θ1, θ2, θ3, rad
    velocity: tuple[float, float, float]     # ω1, ω2, ω3, rad/s
    effort: tuple[float, float, float]       # torque applied to pinion 1, table, pinion 3, N·m
    delta: tuple[float, float]               # δ1, δ3, m
    delta_rate: tuple[float, float]          # δ̇1, δ̇3, m/s
    mesh_force: tuple[float, float]          # F1, F3, N
    active_path: int                         # 1 or 3

    @property
    def transmission_error(self) -> float:
        """Total transmission error δ of the active path, m."""
        return self.delta[0] if self.active_path == 1 else self.delta[1]


#: Columns of the observed vector (:data:`~screwgear_ros.numerics.integrator.OBSERVED` wide, as
#: :meth:`Plant.last_outputs` reads it): θ, ω and effort of the three joints, in the order
#: of a joint_states row; and δ1 and δ3, by active path (the transmission error of path 1
#: and of path 3).
OBSERVED_JOINTS = slice(0, 9)
OBSERVED_DELTA = {1: 9, 3: 12}
#: Columns of a mesh_state row (δ1, δ3, δ̇1, δ̇3, F1, F3) in the observed vector.
OBSERVED_MESH = [9, 12, 10, 13, 11, 14]


class Plant:
    """State, time and input of one simulated table; advances with compiled RK4."""

    def __init__(self, params: TableParams, dt: float,
                 initial_state: np.ndarray | None = None, contact_location: bool = True) -> None:
        check_step(params, dt)
        self._params = params
        self._model: PackedModel = pack(params)
        self.dt = float(dt)
        self.contact_location = bool(contact_location)
        self.contact_changes = 0        # located inside steps so far (contact_location)
        self.step = 0
        self._input: DriveInput | None = DriveInput()     # None: made from _drive when read
        self._direction = self._input.direction
        self._path = active_path(params.mode, self._direction)   # of both
        self._drive = self._input.kernel
        self.state = (equilibrium_state(params) if initial_state is None
                      else np.array(initial_state, dtype=np.float64))
        self.fault: str | None = None
        # Scratch of the compiled calls: the state before a tick, the outputs after it.
        self._backup = np.empty(N_STATE)
        self._observed = np.empty(OBSERVED)
        self._observe: Callable[..., None] | None = None     # observe_state's entry

    @property
    def state(self) -> np.ndarray:
        """θ1, θ2, θ3, ω1, ω2, ω3 (rad, rad/s): a view of the mechanical part of
        :attr:`full_state`, changed in place by every advance."""
        return self._state[:N_MECHANICAL]

    @state.setter
    def state(self, value: np.ndarray) -> None:
        """A mechanical state (6 long: the drives' lagged torques start at 0) or a full
        one (N_STATE long)."""
        value = np.asarray(value, dtype=np.float64)
        full = np.zeros(N_STATE)
        full[:len(value)] = value
        self._state = full
        # The compiled entry is chosen by the types of the arrays it takes: a new array
        # (of another type, maybe) goes through numba's dispatcher again once.
        self._advance: Callable[..., int] | None = None

    @property
    def full_state(self) -> np.ndarray:
        """The whole integrated state (N_STATE long): :attr:`state`, then the torques L1,
        L3 (N·m) the drives of pinion 1 and 3 apply through their current loops besides the
        preload (0 while ``drive_time_constant`` is 0); changed in place by every advance."""
        return self._state

    def __getstate__(self) -> dict[str, Any]:
        """The plant as a value: its compiled entry (:func:`compiled_entry`) belongs to
        this process, and a copy finds its own at its first advance."""
        return {**self.__dict__, '_advance': None, '_observe': None}

    @property
    def params(self) -> TableParams:
        return self._params

    @property
    def input(self) -> DriveInput:
        """The input in force (:meth:`set_input`, :meth:`set_drive` change it)."""
        drive = self._input
        if drive is None:
            kernel = self._drive
            self._input = drive = DriveInput.of(kernel.torque, self._direction, kernel.load)
        return drive

    @property
    def direction(self) -> int:
        """The commanded direction in force, +1 or −1 (``input.direction``)."""
        return self._direction

    @property
    def active_path(self) -> int:
        """The path the input in force drives (1 or 3): what :class:`Outputs` say."""
        return self._path

    @property
    def time(self) -> float:
        """Simulation time, s."""
        return self.step * self.dt

    def set_params(self, params: TableParams) -> None:
        """Use new (validated) physical parameters from the next step on.

        The mode is fixed for a run; a dt that is unstable at the new stiffness is
        refused (ParameterError) and the old parameters stay.
        """
        if params.mode != self._params.mode:
            raise ValueError('mode cannot change while the table runs')
        check_step(params, self.dt)
        self._params = params
        self._model = pack(params)
        self._advance = self._observe = None      # the model's types may change
        self._path = active_path(params.mode, self._direction)

    def set_input(self, drive: DriveInput) -> None:
        """Apply a validated input from the next step on."""
        # The path depends on the mode (fixed between set_params) and the direction
        # only: most commands (one a tick, in a closed loop) keep the direction.
        if drive.direction != self._direction:
            self._path = active_path(self._params.mode, drive.direction)
            self._direction = drive.direction
        self._input = drive
        self._drive = drive.kernel      # made once per input rather than at each call

    def set_drive(self, torque: float, direction: int) -> None:
        """``set_input(DriveInput(torque, direction, input.load))`` for a validated
        drive torque (a float) and direction (0: the one in force), as a closed loop's
        answer sets it every tick: the :class:`DriveInput` is made only when
        :attr:`input` is read."""
        if direction and direction != self._direction:
            self._path = active_path(self._params.mode, direction)
            self._direction = direction
        kernel = self._drive
        self._drive = _DRIVE(Drive, (torque, float(self._direction), kernel.load))
        self._input = None

    def reset(self) -> None:
        """Back to the preload equilibrium at rest, keeping the simulation time; the
        drives' current loops start again from no torque."""
        self._state[:N_MECHANICAL] = equilibrium_state(self._params)
        self._state[N_MECHANICAL:] = 0.0
        self.fault = None

    def advance(self, n: int) -> bool:
        """Integrate n steps; False (state kept at the last finite one) on a fault."""
        if self.fault is not None:
            return False
        args = (self._state, self._backup, self._observed, self.step, n, self.dt, self._model,
                self._drive, self.contact_location)
        changes = (self._advance or advance_observed)(*args)
        if self._advance is None:       # after the dispatcher's call: it has the code now
            self._advance = compiled_entry(advance_observed, args)
        if changes < 0:
            self.fault = self._fault(n)
            return False
        self.step += n
        self.contact_changes += changes
        return True

    def _fault(self, n: int) -> str:
        return (f'state became non-finite between t = {self.time:.6f} s and '
                f'{(self.step + n) * self.dt:.6f} s; integration stopped at the last finite '
                'state (the parameters make the model itself unstable, e.g. a parametric '
                'resonance of the mesh stiffness)')

    def advance_ticks(self, ticks: int, n: int, rows: np.ndarray) -> int:
        """``ticks`` calls of :meth:`advance_outputs` (n steps each) in one compiled call
        (:func:`screwgear_ros.numerics.integrator.advance_ticks`, the same calls bit for bit), for
        replays: row i of ``rows`` (float64, at least ticks × OBSERVED) gets tick i's
        observed vector (the state, then :func:`~screwgear_ros.physics.motion.effort_and_meshes` of it;
        :data:`OBSERVED_DELTA` has where δ1 and δ3 are). Stops after a tick that faults
        (:attr:`fault` then says why). Returns the ticks done, 0 if the plant already
        stands still."""
        if self.fault is not None or ticks <= 0:
            return 0
        done, changes, faulted = advance_ticks(
            self._state, self._backup, rows, self.step, ticks, n, self.dt, self._model,
            self._drive, self.contact_location)
        self.step += (done - faulted) * n       # a faulted tick's time stands still
        if faulted:
            self.fault = self._fault(n)
        self.contact_changes += changes
        self._observed[:] = rows[done - 1]
        return done

    def advance_outputs(self, n: int) -> Outputs:
        """:meth:`advance` n steps, then :meth:`compute_outputs`, in one compiled call
        (:func:`screwgear_ros.numerics.integrator.advance_observed` computes the outputs of the
        state it leaves): what a tick does."""
        if self.advance(n):
            return self.last_outputs()
        return self.compute_outputs()

    def compute_outputs(self) -> Outputs:
        """Joint and mesh quantities of the current state (and input)."""
        self.observe_state(self._state, self.step, self._observed)
        return self.last_outputs()

    def observe_state(self, state: np.ndarray, step: int, out: np.ndarray) -> int:
        """:meth:`compute_outputs` of another state (float64, C order: 6 long, or
        N_STATE) at another step, written to ``out`` (float64[OBSERVED], C order) rather
        than made an :class:`Outputs`; the plant's own state and step stay. For a caller
        that observes many states (the checker's reference): the same compiled call,
        without the dispatcher after the first. Returns the active path, whose δ is the
        transmission error (:data:`OBSERVED_DELTA`)."""
        args = (state, out, step * self.dt, self._model, self._drive)
        if self._observe is None:
            observe(*args)
            self._observe = compiled_entry(observe, args)
        else:
            self._observe(*args)
        return self._path

    @property
    def observed(self) -> np.ndarray:
        """The observed vector the last advance (or :meth:`compute_outputs`) left
        (OBSERVED wide: the state, then its outputs), read-only; valid until the next
        advance. For a caller that keeps every tick's outputs: one array copy instead of
        an object."""
        view = self._observed.view()
        view.flags.writeable = False
        return view

    def last_outputs(self) -> Outputs:
        """The outputs the last advance (or :meth:`compute_outputs`) observed, without computing
        them again."""
        th1, th2, th3, w1, w2, w3, t1, table, t3, d1, dd1, f1, d3, dd3, f3 = \
            self._observed.tolist()
        step = self.step
        return Outputs(step * self.dt, sim_time_ns(step, self.dt), step, (th1, th2, th3),
                       (w1, w2, w3), (t1, table, t3), (d1, d3), (dd1, dd3), (f1, f3),
                       self._path)


#: Drive(...) without the named tuple's Python-level ``__new__`` (the same tuple).
_DRIVE = tuple.__new__


def compiled_entry(dispatcher: Any, args: tuple[Any, ...]) -> Callable[..., Any]:
    """The compiled code ``dispatcher`` runs for arguments of exactly the types of
    ``args`` (which it has run once, so it has the code: loaded from numba's cache or
    compiled), called without the dispatcher; the dispatcher itself if it has none.

    The dispatcher types every argument again at each call to choose that code; calling
    the code directly skips that, and gives the same bits (the same machine code). It
    is valid only for arguments of those types: a caller uses it only while they stay
    the same (the plant's own arrays, its floats and ints).
    """
    overloads = getattr(dispatcher, 'overloads', None)
    if overloads is None:          # NUMBA_DISABLE_JIT: the plain Python function itself
        return dispatcher
    compiled = overloads.get(tuple(dispatcher.typeof_pyval(a) for a in args))
    return dispatcher if compiled is None else compiled.entry_point


__all__ = ['OBSERVED_DELTA', 'OBSERVED_JOINTS', 'OBSERVED_MESH', 'DriveInput', 'Outputs',
           'Plant']
