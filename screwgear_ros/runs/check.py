"""Check a recorded run against the reference solution of its own inputs.

The model is rebuilt from the bag's run_parameters; the recorded inputs, parameter
changes and resets are re-integrated with the DOP853 reference solver
(:mod:`screwgear_ros.numerics.reference`: compiled Dormand–Prince 8(5,3), adaptive, rtol 1e-11),
restarted at every change, and the recorded joint states (θ, ω, effort of every joint),
transmission error and mesh_state (δ, δ̇, F of both meshes, the plant's outputs of the
reference state) are compared with it at every recorded sample; the recorded
active_path must change where the in-process replay changes it. A run whose joint
sensors are not all ideal records the exact state on ``~/true_joint_states``: the
physics is judged on it, and the recorded joint_states must then follow from it by the
recorded sensor model (:mod:`screwgear_ros.physics.sensors`, its noise included) bit for bit.
A run the reference cannot follow raises :class:`~screwgear_ros.numerics.reference.ReferenceFailure`
(why, at what simulation time, in which segment of the run); one with nothing to
compare raises :class:`NothingToCompare`.

The reference is solved at rtol 1e-12 and again at 1e-11, and its own error is taken
from their difference (÷ 9: a global error proportional to the tolerance, which the
solver's error control aims at). It matters because the reference does not locate
the points where the right-hand side is not smooth (the drive line's corner, contact
changes): a run crossing them over and over (pinion speeds oscillating about the
corner) can leave the solution at 1e-11 off by a good part of RK4's tolerance, by
chance of where its steps fell, while the one at 1e-12 agrees with RK4's converged
limit. A signal is ok when its error plus the reference's stays within
tolerance, out of tolerance when its error minus the reference's exceeds it, and
undecided in between (no verdict: check_run exits 2).

Tolerance, per signal: the node integrates with classical RK4 at dt. Its global
error e(dt) is estimated by Richardson's comparison with RK4 at dt/2 over the same
recorded inputs: for a method of order p, |RK4(dt) − RK4(dt/2)| = (1 − 2^−p)·|e(dt)|,
i.e. the error is 16/15 of the estimate at order 4. With contact changes located
inside the steps (setting ``contact_location``, on since it exists: docs/model_notes.md
§12) RK4 keeps order 4 through backlash impacts too: on the test scenarios re-recorded
with it (conventional reversals with impacts among them) and on a 60 s run with
reversals and load steps, the error was 1.07 times the estimate on every signal. The
tolerance is then ``SAFETY`` (1.5: order ≥ 1.6 everywhere would still pass) × the
largest estimate over the run. A recording made with the fixed step (``contact_location``
off, or recorded before it existed) drops to order 0.3–1 at every impact, where the
error reached 2.0 times the estimate on the checked-in conventional bag: such runs keep
``SAFETY_FIXED_STEP`` (4). Never less than ``FLOOR_REL`` × the signal's largest
magnitude (10× the looser of the reference's two rtols, so float round-off never
fails a run).

The RK4 replay at dt/2 runs in a second process (forked) while this one replays at dt
and solves the reference; with one core, or ``parallel=False``, it runs after them.

Why one module of this length: the comparisons, their tolerances and the verdict are
one judgement of when a run passes; the bag reading, replay and reference it uses live
in their own modules.
"""

from __future__ import annotations

import math
import multiprocessing as mp
import os
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..bag.reader import BagError, RecordedRun
from ..numerics.reference import ATOL, RTOL, ReferenceFailure, Segment, solve
from ..params.table import TableParams
from ..physics.model import N_STATE, active_path, equilibrium_state
from ..physics.sensors import SensorChain
from ..sim.events import ParameterChange, Reset
from ..sim.plant import DriveInput, Plant
from ..sim.session import ROW, ROW_JOINTS, ROW_TE, row_of
from .replay_in_process import ReplayedOutputs, replay_in_process

#: Tolerance = SAFETY × Richardson estimate of RK4's error (contact changes located).
SAFETY = 1.5
#: The same for a run recorded with plain fixed-step RK4 (impacts lower its order).
SAFETY_FIXED_STEP = 4.0
#: Smallest tolerance relative to the signal's largest magnitude.
FLOOR_REL = 10.0 * RTOL
#: Smallest absolute tolerance per unit (round-off of a value near zero).
FLOOR_ABS = {'rad': 1e-12, 'rad/s': 1e-12, 'N·m': 1e-9, 'm': 1e-15, 'm/s': 1e-15, 'N': 1e-9}
#: Longest reference solve between restarts, s of simulation (progress granularity).
BLOCK_SECONDS = 0.25
#: The reference is solved at RTOL / REFERENCE_REFINE (atol alike) and at RTOL: the run
#: is judged against the tighter solution, whose own error is taken to be their
#: difference / (REFERENCE_REFINE − 1) (a global error proportional to the tolerance).
REFERENCE_REFINE = 10.0
#: Bits of the table encoder the table angle's error is stated against: a 26-bit encoder,
#: what a precision rotary table carries (the realistic preset's). The simulation's own
#: error should stay below one of its counts, or a controller would see the integrator.
TABLE_ENCODER_BITS = 26
#: One count of that encoder, rad.
TABLE_ENCODER_COUNT = 2.0 * math.pi / 2**TABLE_ENCODER_BITS


@dataclass(frozen=True)
class SignalError:
    """How far one recorded signal is from what it is judged against, in ``unit``."""

    name: str
    unit: str
    max_error: float
    rms_error: float
    at_time: float          # simulation time of the largest error, s
    tolerance: float
    estimate: float = math.nan   # check_run: Richardson estimate of RK4's error, max over the run
    times: np.ndarray | None = field(default=None, compare=False, repr=False)  # samples, s
    errors: np.ndarray | None = field(default=None, compare=False, repr=False)  # |error| there
    #: check_run: what the reference's own error is taken to be (how far its solutions at
    #: two tolerances differ, max over the run); 0 where it is judged exact
    reference_error: float = 0.0

    @property
    def ok(self) -> bool:
        """Within tolerance whatever the reference's own error."""
        return self.max_error + self.reference_error <= self.tolerance

    @property
    def undecided(self) -> bool:
        """Neither ok nor out of tolerance: within the reference's own error of it."""
        return not self.ok and self.max_error - self.reference_error <= self.tolerance


def signal_error(name: str, unit: str, error: np.ndarray, times: np.ndarray, tolerance: float,
                 estimate: float = math.nan, reference_error: float = 0.0) -> SignalError:
    """Max (a non-finite error counts as infinite) and RMS of ``error`` sampled at ``times`` (s);
    the record keeps both arrays (``check_run --plot`` draws them)."""
    error = np.where(np.isfinite(error), error, np.inf)
    worst = int(np.argmax(error))
    return SignalError(name, unit, float(error[worst]), float(np.sqrt(np.mean(np.square(error)))),
                       float(times[worst]), tolerance, estimate, times, error, reference_error)


@dataclass
class CheckReport:
    """Everything check_run prints."""

    path: str
    dt: float
    duration: float                  # simulated time covered, s
    events: int
    resets: int
    signals: list[SignalError] = field(default_factory=list)
    safety: float = SAFETY           # tolerance = safety × Richardson estimate
    replay_identical: bool = False   # in-process RK4 replay equals the recording bit for bit
    replay_max_diff: float = 0.0
    truncated: str | None = None
    summary: str | None = None       # what is wrong with the bag's summary section
    stamp_mismatches: list[tuple[int, int]] = field(default_factory=list)  # (log time, stamp)
    samples: int = 0                 # values compared, over every signal
    path_changes: int = 0            # active_path messages expected (with the start's)
    path_mismatch: str | None = None  # how the recorded active_path differs, if it does
    #: joint_states measured by non-ideal sensors: the samples checked against the sensor
    #: model of the exact state (0: the sensors are ideal and joint_states is exact)
    sensor_samples: int = 0
    sensor_mismatch: str | None = None   # where the measured joint_states first differ

    @property
    def ok(self) -> bool:
        return (self.samples > 0 and all(s.ok for s in self.signals)
                and not self.stamp_mismatches and self.path_mismatch is None
                and self.sensor_mismatch is None)

    @property
    def table_angle(self) -> SignalError | None:
        """The table position's error (the second joint of :func:`signal_names`)."""
        return self.signals[1] if len(self.signals) > 1 else None

    @property
    def undecided(self) -> list[SignalError]:
        """The signals the reference cannot judge, if nothing else fails: then no verdict."""
        if (any(not s.ok and not s.undecided for s in self.signals) or self.stamp_mismatches
                or self.path_mismatch is not None or self.sensor_mismatch is not None):
            return []
        return [s for s in self.signals if s.undecided]


@dataclass
class _Piece:
    """A stretch of run with no reset: start state, segments, sample steps."""

    start_step: int
    initial_state: np.ndarray
    segments: list[Segment]
    samples: set[int] = field(default_factory=set)


def signal_names(run: RecordedRun) -> list[tuple[str, str]]:
    joints = run.parameters.settings.joint_names
    return ([(f'{j} position', 'rad') for j in joints]
            + [(f'{j} velocity', 'rad/s') for j in joints]
            + [(f'{j} effort', 'N·m') for j in joints]
            + [('transmission_error', 'm')])


@dataclass
class _Contexts:
    """What was in force at each joint_states sample of a run: the pieces (stretches
    without a reset) and, per sample, the index of its (piece, input, parameters)."""

    pieces: list[_Piece]
    contexts: list[tuple[int, DriveInput, TableParams]]
    in_force: np.ndarray


def reference_outputs(run: RecordedRun, replayed: ReplayedOutputs,
                      progress: Callable[[float], None] | None = None,
                      rtol: float = RTOL) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Reference joint_states rows (n, 9), transmission errors (m,) and mesh_state rows
    (n, 6: δ1, δ3, δ̇1, δ̇3, F1, F3) at the joint_states samples.

    ``replayed`` is the in-process RK4 replay of ``run`` (:func:`replay_in_process`):
    its ticks say which input and parameters were in force from which step, and
    where resets restarted the state, as the node's session applied them (a sample
    between them ran under what the tick before it ran under).
    ``progress(seconds)`` is told the simulated time solved after each block. ``rtol``:
    the reference solver's relative tolerance (its absolute one scales with it).
    """
    c = _contexts(run, replayed)
    pieces, steps = c.pieces, run.joint_states.steps
    # The reference solution at every sample step, piece by piece, in blocks.
    total = sum(len(p.segments) for p in pieces)
    offsets = np.cumsum([0] + [len(p.segments) for p in pieces])
    states: list[dict[int, np.ndarray]] = [
        _solve_piece(p, run.dt, progress, int(first), total, rtol)
        for p, first in zip(pieces, offsets)]
    piece_of = np.array([x[0] for x in c.contexts], dtype=np.int64)[c.in_force]
    rows, mesh = _observe(run, c, np.array([states[k][s] for k, s in
                                            zip(piece_of.tolist(), steps.tolist())]
                                           ).reshape(-1, N_STATE))
    return rows[:, ROW_JOINTS], rows[:len(run.transmission_error), ROW_TE], mesh


def mesh_of(run: RecordedRun, replayed: ReplayedOutputs, joints: np.ndarray) -> np.ndarray:
    """mesh_state rows (n, 6) of joint_states rows ``joints`` (n, 9: their θ and ω are
    the state) at the samples of ``run``, under what ``replayed`` says was in force:
    what the node publishes beside such joint states."""
    return _observe(run, _contexts(run, replayed), joints[:, :6])[1]


def _observe(run: RecordedRun, c: _Contexts, states: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray]:
    """Output rows (n, ROW) and mesh_state rows (n, 6) of ``states`` (n, 6) at the
    joint_states samples, through the plant's own output code."""
    steps = run.joint_states.steps
    rows = np.empty((len(steps), ROW))
    mesh = np.empty((len(steps), 6))
    plants: dict[int, Plant] = {}
    for i, (step, k) in enumerate(zip(steps.tolist(), c.in_force.tolist())):
        _, drive, params = c.contexts[k]
        plant = plants.get(id(params))
        if plant is None:
            plant = plants[id(params)] = Plant(params, run.dt)
        plant.full_state[:len(states[i])] = states[i]
        plant.step = step
        plant.set_input(drive)
        out = plant.compute_outputs()
        rows[i] = row_of(out)
        mesh[i] = (*out.delta, *out.delta_rate, *out.mesh_force)
    return rows, mesh


def _contexts(run: RecordedRun, replayed: ReplayedOutputs) -> _Contexts:
    """The pieces, segments and context of every sample of ``run`` (see
    :func:`reference_outputs`)."""
    start = run.parameters
    params: TableParams = start.params
    drive = DriveInput()
    steps = run.joint_states.steps
    pieces = [_Piece(start.start_step, np.array(start.initial_state, dtype=np.float64),
                     [Segment(start.start_step, drive, params)])]
    # Pass 1: pieces, segments, and the context (piece, input, parameters) of each tick.
    contexts = [(0, drive, params)]
    for tick in replayed.ticks:
        for event in tick.applied:      # the state a reset restarts from, with the
            if isinstance(event, ParameterChange):   # parameters in force at the reset
                params = event.params
            elif isinstance(event, Reset):
                pieces.append(_Piece(tick.start, equilibrium_state(params),
                                     [Segment(tick.start, tick.drive, tick.params)]))
        params, drive = tick.params, tick.drive
        segments = pieces[-1].segments
        if (segments[-1].drive, segments[-1].params) != (drive, params):
            if segments[-1].start_step == tick.start:
                segments[-1] = Segment(tick.start, drive, params)
            else:
                segments.append(Segment(tick.start, drive, params))
        contexts.append((len(pieces) - 1, drive, params))
    # Each sample's context: that of the last tick through Session.tick at or before it.
    in_force = np.searchsorted(replayed.tick_samples, np.arange(len(steps)), side='right')
    piece_of = np.array([c[0] for c in contexts], dtype=np.int64)[in_force]
    for k, piece in enumerate(pieces):
        piece.samples = set(steps[piece_of == k].tolist())
    return _Contexts(pieces, contexts, in_force)


def _solve_piece(piece: _Piece, dt: float, progress: Callable[[float], None] | None,
                 first: int, total: int, rtol: float = RTOL) -> dict[int, np.ndarray]:
    """Reference states at the piece's sample steps, restarting at every segment and
    at least every BLOCK_SECONDS. A :class:`ReferenceFailure` names the segment as
    number ``first + k`` of ``total`` in the run."""
    result: dict[int, np.ndarray] = {}
    if not piece.samples:
        return result
    samples = np.array(sorted(piece.samples), dtype=np.int64)
    last = int(samples[-1])
    block = max(1, int(round(BLOCK_SECONDS / dt)))
    y = np.zeros(N_STATE)       # the whole state: the drives' lagged torques from 0
    y[:len(piece.initial_state)] = piece.initial_state
    if samples[0] == piece.start_step:
        result[piece.start_step] = y.copy()
    for k, seg in enumerate(piece.segments):
        seg_end = piece.segments[k + 1].start_step if k + 1 < len(piece.segments) else last
        a = seg.start_step
        while a < min(seg_end, last):
            b = min(a + block, seg_end, last)
            inside = samples[(samples > a) & (samples <= b)]
            steps = inside if len(inside) and inside[-1] == b else np.append(inside, b)
            try:
                out = solve(y, [Segment(a, seg.drive, seg.params)], dt, steps, rtol=rtol,
                            atol=ATOL * rtol / RTOL)
            except ReferenceFailure as exc:
                raise exc.located(first + k, total,
                                  seg.start_step * dt, seg_end * dt) from None
            for s, state in zip(steps, out):
                result[int(s)] = state
            y = out[-1].copy()
            if progress is not None:
                progress((b - a) * dt)
            a = b
    return result


class _FineReplay:
    """The RK4 replay at dt/2, in a forked process while this one replays at dt and
    solves the reference (they are independent; a second core halves the wall time).
    Without ``fork`` (or with one core, or ``parallel`` off) it runs here when asked for.
    The result is the same either way: the same code on the same recording."""

    def __init__(self, run: RecordedRun, parallel: bool) -> None:
        self.run = run
        self.proc = self.conn = None
        cores = len(os.sched_getaffinity(0)) if hasattr(os, 'sched_getaffinity') else 1
        if parallel and cores > 1 and 'fork' in mp.get_all_start_methods():
            ctx = mp.get_context('fork')
            self.conn, child = ctx.Pipe(duplex=False)
            self.proc = ctx.Process(target=self._work, args=(run, child), daemon=True,
                                    name='check_run RK4 dt/2')
            self.proc.start()
            child.close()

    @staticmethod
    def _work(run: RecordedRun, conn) -> None:   # in the forked process
        try:
            fine = replay_in_process(run, 2)
            conn.send(('ok', np.ascontiguousarray(fine.joint_states),
                       np.ascontiguousarray(fine.transmission_error)))
        except BagError as exc:
            conn.send(('bag', exc.kind, str(exc)))
        except BaseException as exc:  # noqa: BLE001 - handed back, redone in the parent
            conn.send(('error', f'{type(exc).__name__}: {exc}'))
        finally:
            conn.close()

    def result(self) -> tuple[np.ndarray, np.ndarray]:
        """(joint_states rows, transmission errors) of the replay at dt/2."""
        answer = None
        if self.proc is not None:
            try:
                answer = self.conn.recv()
            except (EOFError, OSError):
                answer = None                  # the worker died: redo it here
            self.close()
        if answer is not None and answer[0] == 'ok':
            return answer[1], answer[2]
        if answer is not None and answer[0] == 'bag':
            raise BagError(answer[1], answer[2])
        fine = replay_in_process(self.run, 2)
        return fine.joint_states, fine.transmission_error

    def close(self) -> None:
        if self.proc is not None:
            if self.proc.is_alive():
                self.proc.terminate()
            self.proc.join()
            self.conn.close()
            self.proc = None


class NothingToCompare(BagError):
    """A comparison with no sample to compare: never a PASS. A :class:`BagError` (kind
    'nothing_to_compare'), so every tool that reports an unusable bag reports it (exit 2
    with this reason)."""

    def __init__(self, message: str) -> None:
        super().__init__('nothing_to_compare', message)


#: The signals of mesh_state, in its columns' order (δ, δ̇ and F of meshes 1 and 3).
MESH_SIGNALS = [('mesh_state δ1', 'm'), ('mesh_state δ3', 'm'), ('mesh_state dδ1/dt', 'm/s'),
                ('mesh_state dδ3/dt', 'm/s'), ('mesh_state F1', 'N'), ('mesh_state F3', 'N')]


def require_samples(run: RecordedRun) -> None:
    """Raise :class:`NothingToCompare` unless ``run`` has every output table_sim records
    (joint_states, transmission_error, mesh_state after the start of the run, and the
    active_path of the start): a check that compared fewer would judge nothing."""
    start = run.parameters.start_step
    missing = [name for name, signal in (('joint_states', run.joint_states),
                                         ('transmission_error', run.transmission_error),
                                         ('mesh_state', run.mesh_state))
               if not np.any(signal.steps > start)]
    if not len(run.active_path):
        missing.append('active_path')
    if missing:
        why = f' (the readable part ends there: {run.truncated})' if run.truncated else ''
        raise NothingToCompare(
            f'{run.path} holds no {", ".join(missing)} sample after the start of the run '
            f'(step {start}), so there is nothing to compare{why}; table_sim records '
            'joint_states, transmission_error and mesh_state every tick and active_path '
            'at the start and at every change')
    if run.measured is None and not all(
            s.sensors.ideal for s in [run.parameters.settings] + [
                e.settings for _, e in run.events if isinstance(e, ParameterChange)]):
        raise BagError('invalid', f'{run.path}: its joint sensors are not ideal '
                       '(run_parameters), but it holds no true_joint_states: the exact state '
                       'was not recorded, so the physics cannot be judged')
    if not np.array_equal(run.mesh_state.steps, run.joint_states.steps[:len(run.mesh_state)]):
        raise BagError('invalid', f'{run.path}: mesh_state and joint_states samples are not '
                       'published at the same steps')


def path_changes(run: RecordedRun, replayed: ReplayedOutputs) -> list[tuple[int, int]]:
    """(step, path) of the start and of every change of the active path, as the
    in-process replay applied the recorded events (the node publishes active_path then)."""
    path = active_path(run.parameters.params.mode, DriveInput().direction)
    changes = [(run.parameters.start_step, path)]
    for tick in replayed.ticks:
        if tick.outputs.active_path != changes[-1][1]:
            changes.append((tick.start, tick.outputs.active_path))
    return changes


def _path_mismatch(run: RecordedRun, replayed: ReplayedOutputs) -> str | None:
    """What differs between the recorded active_path and the replay's, or None."""
    end = run.end_step      # a change at or after the last output is not checked (cut bag)
    expected = [c for c in path_changes(run, replayed) if c[0] < end]
    recorded = [(int(s), int(v)) for s, v in zip(run.active_path.steps.tolist(),
                                                 run.active_path.values[:, 0].tolist())
                if s < end]
    if recorded == expected:
        return None
    for k, (a, b) in enumerate(zip(recorded, expected)):
        if a != b:
            return (f'change {k + 1}: recorded path {a[1]} at t = {a[0] * run.dt:.6f} s, '
                    f'the replay gives path {b[1]} at t = {b[0] * run.dt:.6f} s')
    return (f'{len(recorded)} recorded changes (with the start), the replay gives '
            f'{len(expected)}')


def sensor_rows(run: RecordedRun) -> np.ndarray:
    """What the run's sensors measure of its exact joint states: joint_states rows (n, 9),
    sample by sample through :class:`~screwgear_ros.physics.sensors.SensorChain`, restarted by
    each recorded reset and reconfigured by each recorded parameter change at the sample
    of the tick that applied it (the first sample recorded after it), as the node's
    session does."""
    exact = run.joint_states
    chain = SensorChain(run.parameters.settings.sensors, run.dt)
    events = [(order, e) for order, e in run.events if isinstance(e, (Reset, ParameterChange))]
    takes = np.searchsorted(exact.order, [order for order, _ in events], side='right').tolist()
    rows = exact.values.copy()
    k = 0
    for i, (step, values) in enumerate(zip(exact.steps.tolist(), exact.values.tolist())):
        while k < len(events) and takes[k] <= i:
            event = events[k][1]
            if isinstance(event, Reset):
                chain.restart()
            else:
                chain.configure(event.settings.sensors)
            k += 1
        position, velocity = chain.measure_values(step, values[0:3], values[3:6])
        rows[i, 0:6] = (*position, *velocity)
    return rows


def sensor_mismatch(run: RecordedRun) -> tuple[int, str | None]:
    """(samples compared, where the recorded joint_states first differ from
    :func:`sensor_rows` bit for bit, or None); (0, None) for a bag whose joint_states
    are the exact state."""
    measured = run.measured
    if measured is None:
        return 0, None
    topic = run.names.get('joint_states', 'joint_states')
    exact = run.joint_states
    n = min(len(exact), len(measured))
    if len(exact) != len(measured) and not run.truncated:
        return n, (f'{topic} has {len(measured)} samples, true_joint_states '
                   f'{len(exact)}: the node publishes both every tick')
    steps = exact.steps[:n]
    off = np.flatnonzero(steps != measured.steps[:n])
    if len(off):
        i = int(off[0])
        return n, (f'{topic} sample {i} is at step {measured.steps[i]}, true_joint_states '
                   f'at step {steps[i]}')
    expected = sensor_rows(run)[:n]
    differs = np.flatnonzero(np.any(expected.view(np.int64)
                                    != measured.values[:n].view(np.int64), axis=1))
    if not len(differs):
        return n, None
    i = int(differs[0])
    c = int(np.flatnonzero(expected[i].view(np.int64) != measured.values[i].view(np.int64))[0])
    name, unit = signal_names(run)[c]
    return n, (f'{topic} differs from what the recorded sensor model measures of '
               f'true_joint_states from tick {i} on (step {int(steps[i])}, '
               f't = {steps[i] * run.dt:.6f} s): {name} recorded '
               f'{float(measured.values[i, c])!r} {unit}, the model gives '
               f'{float(expected[i, c])!r} ({len(differs)} of {n} samples differ)')


def check_run(run: RecordedRun, progress: Callable[[float], None] | None = None,
              parallel: bool = True) -> CheckReport:
    """Compare a recorded run with the reference solution; see the module docstring.
    ``parallel``: the replay at dt/2 runs in a second process meanwhile (same result).
    Raises :class:`NothingToCompare` for a run without outputs to compare."""
    require_samples(run)
    half = None if progress is None else (lambda seconds: progress(seconds / 2))
    fine_replay = _FineReplay(run, parallel)
    try:
        rk4 = replay_in_process(run, 1)
        loose = reference_outputs(run, rk4, half)
        ref_js, ref_te, ref_mesh = reference_outputs(run, rk4, half, RTOL / REFERENCE_REFINE)
        fine_js, fine_te = fine_replay.result()
    finally:
        fine_replay.close()
    recorded = run.joint_states.values
    times_js = run.joint_states.steps * run.dt
    times_te = run.transmission_error.steps * run.dt
    report = CheckReport(
        str(run.path), run.dt,
        (run.end_step - run.parameters.start_step) * run.dt,
        len(run.events), sum(isinstance(e, Reset) for _, e in run.events),
        safety=SAFETY if run.parameters.settings.contact_location else SAFETY_FIXED_STEP,
        truncated=run.truncated, summary=run.summary,
        stamp_mismatches=list(run.stamp_mismatches))
    rec_te = run.transmission_error.values[:, 0]
    diff_js = np.abs(rk4.joint_states - recorded)
    diff_te = np.abs(rk4.transmission_error - rec_te)
    report.replay_max_diff = float(max(np.max(diff_js, initial=0.0), np.max(diff_te, initial=0.0)))
    report.replay_identical = bool(np.array_equal(rk4.joint_states, recorded)
                                   and np.array_equal(rk4.transmission_error, rec_te))
    columns = [(recorded[:, c], ref_js[:, c], loose[0][:, c],
                rk4.joint_states[:, c] - fine_js[:, c], times_js) for c in range(9)]
    columns.append((rec_te, ref_te, loose[1], rk4.transmission_error - fine_te, times_te))
    m = len(run.mesh_state)
    richardson_mesh = mesh_of(run, rk4, rk4.joint_states) - mesh_of(run, rk4, fine_js)
    columns += [(run.mesh_state.values[:, c], ref_mesh[:m, c], loose[2][:m, c],
                 richardson_mesh[:m, c], times_js[:m]) for c in range(6)]
    for (name, unit), (rec, ref, ref_loose, richardson, times) in zip(
            signal_names(run) + MESH_SIGNALS, columns):
        estimate = float(np.max(np.abs(richardson)))
        scale = float(np.max(np.abs(ref)))
        tolerance = max(report.safety * estimate, FLOOR_REL * scale, FLOOR_ABS[unit])
        report.signals.append(signal_error(name, unit, np.abs(rec - ref), times, tolerance,
                                           estimate, float(np.max(np.abs(ref - ref_loose)))
                                           / (REFERENCE_REFINE - 1.0)))
        report.samples += len(rec)
    report.path_changes = len(path_changes(run, rk4))
    report.path_mismatch = _path_mismatch(run, rk4)
    report.sensor_samples, report.sensor_mismatch = sensor_mismatch(run)
    return report


def format_report(report: CheckReport) -> str:
    """The human-readable report check_run prints."""
    lines = [
        f'check_run {report.path}',
        f'  {report.duration:.3f} s simulated at dt = {report.dt * 1e6:g} µs, '
        f'{report.events} recorded events ({report.resets} resets)',
    ]
    if report.truncated:
        lines.append(f'  WARNING: {report.truncated}; checked what is readable')
    if report.summary:
        lines.append(f'  NOTE: {report.summary}; it is not used: the channels and messages '
                     'are read from the data section (the index rebuilt from the data)')
    lines += [
        f'  reference: DOP853 (compiled, adaptive), rtol {RTOL / REFERENCE_REFINE:g}, '
        'restarted at every input/parameter change and reset; its own error ("ref. err") is '
        f'taken as its difference from the solution at rtol {RTOL:g} ÷ '
        f'{REFERENCE_REFINE - 1:g}: a signal within that of its tolerance is undecided',
        f'  tolerance = max({report.safety:g} × |RK4(dt) − RK4(dt/2)|, {FLOOR_REL:g} × '
        'max|signal|): Richardson\'s estimate of RK4\'s global error',
        ('  (15/16 of it for a 4th-order method, kept through backlash impacts by locating '
         'contact changes),' if report.safety == SAFETY else
         '  (15/16 of it for a 4th-order method; recorded with the fixed step, whose order '
         'impacts lower),') + f' with a safety factor {report.safety:g}',
        f'  {"signal":<26}{"unit":<7}{"max error":>12}{"RMS error":>12}{"at t [s]":>11}'
        f'{"RK4 est.":>12}{"ref. err":>12}{"tolerance":>12}  verdict',
    ]
    for s in report.signals:
        lines.append(f'  {s.name:<26}{s.unit:<7}{s.max_error:>12.3e}{s.rms_error:>12.3e}'
                     f'{s.at_time:>11.4f}{s.estimate:>12.3e}{s.reference_error:>12.3e}'
                     f'{s.tolerance:>12.3e}  '
                     + ('ok' if s.ok else 'undecided' if s.undecided else 'FAIL'))
    table = report.table_angle
    if table is not None:
        lines.append(f'  table angle error {table.max_error:.2e} rad = '
                     f'{table.max_error / TABLE_ENCODER_COUNT:.3g} counts of a '
                     f'{TABLE_ENCODER_BITS}-bit table encoder ({TABLE_ENCODER_COUNT:.2e} rad '
                     'a count)')
    lines.append('  in-process RK4 replay of the recorded inputs: '
                 + ('identical to the recording, bit for bit' if report.replay_identical
                    else f'differs from the recording by up to {report.replay_max_diff:.3e}'))
    lines.append(f'  active_path: {report.path_changes} messages expected (the start and '
                 'every change, as the replay applied the recorded events): '
                 + ('every one recorded at its step' if report.path_mismatch is None
                    else f'FAIL: {report.path_mismatch}'))
    if report.sensor_mismatch is not None:
        lines.append(f'  measured joint_states: FAIL: {report.sensor_mismatch}')
    elif report.sensor_samples:
        lines.append(f'  measured joint_states: {report.sensor_samples} samples follow from '
                     'true_joint_states by the recorded sensor model, bit for bit (the '
                     'signals above are the exact state)')
    else:
        lines.append('  joint_states: the sensors are ideal, so they are the exact state')
    lines.append(f'  {report.samples} recorded values compared')
    if report.stamp_mismatches:
        log_time, stamp = report.stamp_mismatches[0]
        lines.append(f'  joint_states header stamps: {len(report.stamp_mismatches)} differ from '
                     f'their log time (first: log time {log_time} ns, stamp {stamp} ns)')
    else:
        lines.append('  joint_states header stamps: every one equals its log time')
    undecided = report.undecided
    if undecided:
        worst = max(undecided, key=lambda s: s.reference_error / s.tolerance)
        lines.append(f'  RESULT: UNDECIDED: {", ".join(s.name for s in undecided)} within the '
                     f'reference\'s own error of the tolerance (e.g. {worst.name}: error '
                     f'{worst.max_error:.3e}, reference error {worst.reference_error:.3e}, '
                     f'tolerance {worst.tolerance:.3e}): the reference cannot judge this run')
        return '\n'.join(lines)
    failed = [s.name for s in report.signals if not s.ok]
    problems = [f'{", ".join(failed)} outside tolerance'] if failed else []
    if report.stamp_mismatches:
        problems.append('joint_states header stamps differ from their log times')
    if report.path_mismatch is not None:
        problems.append('active_path differs from the replay')
    if report.sensor_mismatch is not None:
        problems.append('joint_states do not follow from true_joint_states by the sensor '
                        'model')
    if not report.samples:
        problems.append('nothing compared')
    lines.append('  RESULT: ' + ('PASS: every signal within its tolerance' if not problems
                                 else f'FAIL: {"; ".join(problems)}'))
    return '\n'.join(lines)


__all__ = [
    'FLOOR_ABS',
    'FLOOR_REL',
    'MESH_SIGNALS',
    'REFERENCE_REFINE',
    'SAFETY',
    'SAFETY_FIXED_STEP',
    'TABLE_ENCODER_BITS',
    'TABLE_ENCODER_COUNT',
    'CheckReport',
    'NothingToCompare',
    'SignalError',
    'check_run',
    'format_report',
    'mesh_of',
    'path_changes',
    'reference_outputs',
    'require_samples',
    'sensor_mismatch',
    'sensor_rows',
    'signal_error',
    'signal_names',
]
