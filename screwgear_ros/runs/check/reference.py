"""The reference solution of a recorded run's own inputs, at its joint_states samples.

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
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ...bag.reader import RecordedRun
from ...numerics.integrator import OBSERVED
from ...numerics.reference import ATOL, RTOL, ReferenceFailure, Segment, solve
from ...params.table import TableParams
from ...physics.equilibrium import equilibrium_state
from ...physics.packed import N_STATE
from ...sim.events import ParameterChange, Reset
from ...sim.plant import OBSERVED_DELTA, OBSERVED_JOINTS, OBSERVED_MESH, DriveInput, Plant
from ...sim.tick import ROW, ROW_JOINTS, ROW_STEP, ROW_TE
from ..replay_in_process import ReplayedOutputs
from .tolerance import BLOCK_SECONDS


@dataclass
class _Piece:
    """A stretch of run with no reset: start state, segments, sample steps."""

    start_step: int
    initial_state: np.ndarray
    segments: list[Segment]
    samples: np.ndarray = field(default_factory=lambda: np.empty(0, np.int64))  # sorted steps


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
    pieces, steps = c.pieces, run.true_joint_states.steps
    # The reference solution at every sample step, piece by piece, in blocks.
    total = sum(len(p.segments) for p in pieces)
    offsets = np.cumsum([0] + [len(p.segments) for p in pieces])
    solved = [_solve_piece(p, run.dt, progress, int(first), total, rtol)
              for p, first in zip(pieces, offsets, strict=False)]
    piece_of = np.array([x[0] for x in c.contexts], dtype=np.int64)[c.in_force]
    states = np.empty((len(steps), N_STATE))
    for k, piece in enumerate(pieces):
        mine = piece_of == k
        states[mine] = solved[k][np.searchsorted(piece.samples, steps[mine])]
    rows, mesh = _observe(run, c, states)
    return rows[:, ROW_JOINTS], rows[:len(run.transmission_error), ROW_TE], mesh


def mesh_of(run: RecordedRun, replayed: ReplayedOutputs, joints: np.ndarray) -> np.ndarray:
    """mesh_state rows (n, 6) of joint_states rows ``joints`` (n, 9: their θ and ω are
    the state) at the samples of ``run``, under what ``replayed`` says was in force:
    what the node publishes beside such joint states."""
    return _observe(run, _contexts(run, replayed), joints[:, :6])[1]


def _observe(run: RecordedRun, c: _Contexts, states: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray]:
    """Output rows (n, ROW) and mesh_state rows (n, 6) of ``states`` (n, 6) at the
    joint_states samples, through the plant's own output code (:meth:`Plant.observe_state`)."""
    steps = run.true_joint_states.steps
    states = np.ascontiguousarray(states, dtype=np.float64)
    observed = np.empty((len(steps), OBSERVED))
    paths = np.empty(len(steps), dtype=np.int64)
    plants: dict[int, Plant] = {}
    # Runs of samples under one context: the plant set up once per run, then one
    # compiled observation per sample (its active path is the input's, the same for all).
    edges = np.flatnonzero(np.diff(c.in_force)) + 1
    for a, b in zip([0, *edges.tolist()], [*edges.tolist(), len(steps)], strict=True):
        if a == b:
            continue
        _, drive, params = c.contexts[int(c.in_force[a])]
        plant = plants.get(id(params))
        if plant is None:
            plant = plants[id(params)] = Plant(params, run.dt)
        if plant.input is not drive:
            plant.set_input(drive)
        observe = plant.observe_state
        for state, step, out in zip(states[a:b], steps[a:b].tolist(), observed[a:b],
                                    strict=True):
            path = observe(state, step, out)
        paths[a:b] = path
    rows = np.empty((len(steps), ROW))
    rows[:, ROW_JOINTS] = observed[:, OBSERVED_JOINTS]
    rows[:, ROW_TE] = np.where(paths == 1, observed[:, OBSERVED_DELTA[1]],
                               observed[:, OBSERVED_DELTA[3]])
    rows[:, ROW_STEP] = steps
    return rows, observed[:, OBSERVED_MESH]


def _contexts(run: RecordedRun, replayed: ReplayedOutputs) -> _Contexts:
    """The pieces, segments and context of every sample of ``run`` (see
    :func:`reference_outputs`)."""
    start = run.parameters
    params: TableParams = start.params
    drive = DriveInput()
    steps = run.true_joint_states.steps
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
        piece.samples = np.unique(steps[piece_of == k])
    return _Contexts(pieces, contexts, in_force)


def _solve_piece(piece: _Piece, dt: float, progress: Callable[[float], None] | None,
                 first: int, total: int, rtol: float = RTOL) -> np.ndarray:
    """Reference states (rows, N_STATE wide) at the piece's sample steps, restarting at
    every segment and at least every BLOCK_SECONDS. A :class:`ReferenceFailure` names
    the segment as number ``first + k`` of ``total`` in the run."""
    samples = piece.samples
    result = np.empty((len(samples), N_STATE))
    if not len(samples):
        return result
    last = int(samples[-1])
    block = max(1, round(BLOCK_SECONDS / dt))
    y = np.zeros(N_STATE)       # the whole state: the drives' lagged torques from 0
    y[:len(piece.initial_state)] = piece.initial_state
    filled = 0
    if samples[0] == piece.start_step:
        result[0] = y
        filled = 1
    for k, seg in enumerate(piece.segments):
        seg_end = piece.segments[k + 1].start_step if k + 1 < len(piece.segments) else last
        a = seg.start_step
        while a < min(seg_end, last):
            b = min(a + block, seg_end, last)
            lo, hi = np.searchsorted(samples, [a, b], side='right').tolist()
            inside = samples[lo:hi]
            steps = inside if len(inside) and inside[-1] == b else np.append(inside, b)
            try:
                out = solve(y, [Segment(a, seg.drive, seg.params)], dt, steps, rtol=rtol,
                            atol=ATOL * rtol / RTOL)
            except ReferenceFailure as exc:
                raise exc.located(first + k, total,
                                  seg.start_step * dt, seg_end * dt) from None
            result[lo:hi] = out[:hi - lo]
            filled += hi - lo
            y = out[-1].copy()
            if progress is not None:
                progress((b - a) * dt)
            a = b
    if filled != len(samples):      # every sample lies in one block (a, b] or at the start
        raise RuntimeError(f'{len(samples) - filled} sample steps of a piece were not solved')
    return result
