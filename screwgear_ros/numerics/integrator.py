"""RK4 over the 3-DOF model: the node's hot loop, with contact changes located.

:func:`advance` integrates ``n`` steps of ``dt`` seconds in one compiled call on six
scalars, with no allocation per step; every step is :func:`screwgear_ros.numerics.rk.step`.
Time is never accumulated: step k starts at t = (step0 + k)·dt, so long runs do not
drift and a run is reproducible from the integer step at which each input took effect.
The kernels take the model, the input and the held pieces as the named tuples of
:mod:`screwgear_ros.physics` (:class:`~screwgear_ros.physics.packed.PackedModel`,
:class:`~screwgear_ros.physics.packed.Drive`, :class:`~screwgear_ros.physics.motion.Pieces`), whole. The input
is constant over a call; it changes only at step boundaries.

Contact location (``locate``, the default): the mesh force jumps (a flank is hit with
δ̇ ≠ 0) or kinks (it lifts off) where a mesh changes its branch of the contact law
(:class:`~screwgear_ros.physics.mesh.ContactBranch`), the drive torque kinks where the command
meets the drive's torque–speed line (:class:`~screwgear_ros.physics.drive.DrivePiece`), a
bearing's friction jumps where its body sticks or breaks away
(:class:`~screwgear_ros.physics.friction.FrictionPiece`), and an RK4 step across such a point
is only first- or second-order accurate. So each step is integrated with the meshes,
the drive and the bearings held on the pieces they are on at its start (the smooth
continuation of each piece; a stuck body stands exactly still). If the law is on
another piece at the step's end, the change is located on the step's cubic Hermite
interpolant (:func:`screwgear_ros.numerics.rk.hermite`, from the ends and their slopes: O(dt⁴))
by bisection on the pieces the law gives there (bisection, because a mesh can leave a branch
tangentially, as a flank touched at rest does, where secant methods stall); the step is
redone up to that instant, switched to the new pieces (a body that sticks there gets
its speed set to exactly 0), and the rest of the step
integrated from there, which may locate another change. A slipping body's speed may
also cross zero and come back inside one step (a sticking episode shorter than the
step), leaving the pieces at the step's end those of its start: an extremum of a speed's
interpolant past zero (:func:`~screwgear_ros.physics.friction.speed_dip`) is located the same way,
by bisection between the step's start and it. The step grid is unchanged: a
step ends where it always ends. A step without a change does exactly what the
fixed-step RK4 does (its slopes agree bit for bit while no stage leaves the pieces) at
the same four evaluations of the model per step, because the slope the law gives at a
step's end, which detects changes, is the next step's first slope. ``locate=False`` is
plain fixed-step RK4 on the law (the integrator of earlier releases, bit for bit).
"""

from __future__ import annotations

import math

import numpy as np

from ..physics.friction import FrictionPiece, speed_dip
from ..physics.jit import inline_kernel, kernel
from ..physics.motion import BY_LAW, Pieces, effort_and_meshes, pieces, state_rate
from ..physics.packed import N_STATE, TAU, Drive, PackedModel
from . import rk

#: Changes located within one step before the step is finished by the plain law (a mesh
#: chattering on its boundary; never reached by a sane run).
MAX_CHANGES = 16
#: Bisection on the interpolant stops when the bracket (a fraction of the step) is this
#: narrow: 50 bisections, the change's instant to within 1e-15·dt.
THETA_TOLERANCE = 1e-15
MAX_BISECTIONS = 60


@inline_kernel
def _slope(t: float, y: tuple[float, ...], args: tuple[PackedModel, Drive, Pieces]) -> tuple[float, ...]:
    """dy/dt with the meshes, the drive and the bearings held on the pieces args =
    (model, drive, held) give (a stuck body's slope is exactly 0)."""
    return state_rate(t, y, args[0], args[1], args[2])[0]


@inline_kernel
def _law(t: float, y: tuple[float, ...], model: PackedModel, drive: Drive) -> tuple[tuple[float, ...], Pieces]:
    """dy/dt by the contact law and drive line themselves, and the pieces they are on."""
    return state_rate(t, y, model, drive, BY_LAW)


@kernel
def _locate(t: float, h: float, y0: tuple[float, ...], f0: tuple[float, ...], y1: tuple[float, ...], f1: tuple[float, ...], model: PackedModel,
            drive: Drive, held: Pieces, top: float, after: Pieces) -> tuple[float, Pieces]:
    """First instant t + θ·h at which the law leaves the ``held`` pieces, on the Hermite
    interpolant of the step (y0, f0) → (y1, f1), by bisection: (θ just past the change,
    the pieces the law gives there, coming from ``held``). The law has left them at
    θ = ``top`` (≤ 1), for ``after``."""
    lo, hi = 0.0, top
    for _ in range(MAX_BISECTIONS):
        if hi - lo <= THETA_TOLERANCE:
            break
        theta = 0.5 * (lo + hi)
        now = pieces(t + theta * h, rk.hermite(y0, f0, y1, f1, h, theta), model, drive, held)
        if now == held:
            lo = theta
        else:
            hi, after = theta, now
    return hi, after


@inline_kernel
def _stick(y: tuple[float, ...], held: Pieces, after: Pieces) -> tuple[float, ...]:
    """``y`` with the speed of each body that sticks (from a slip piece in ``held`` to
    STUCK in ``after``) set to exactly 0; the drives' lagged torques as they are."""
    stuck = FrictionPiece.STUCK
    w1 = 0.0 if after.friction_1 == stuck and held.friction_1 != stuck else y[3]
    w2 = 0.0 if after.friction_2 == stuck and held.friction_2 != stuck else y[4]
    w3 = 0.0 if after.friction_3 == stuck and held.friction_3 != stuck else y[5]
    return (y[0], y[1], y[2], w1, w2, w3, y[6], y[7])


@inline_kernel
def _located_step(t0: float, t_end: float, dt: float, y: tuple[float, ...], slope: tuple[float, ...], held: Pieces,
                  model: PackedModel, drive: Drive) -> tuple[tuple[float, ...], tuple[float, ...], Pieces, int]:
    """One step from t0 to t_end = t0 + dt with changes located (module docstring).
    ``slope`` and ``held`` are the law's at (t0, y); returns the new state, the law's
    slope and pieces there, and how many changes were located."""
    t, h = t0, dt
    for changes in range(MAX_CHANGES + 1):
        args = (model, drive, held)
        y_end = rk.step_from(_slope, t, y, h, slope, args)
        slope_end, end = _law(t_end, y_end, model, drive)
        if end == held:
            # the pieces are those of the start, but a speed may have crossed zero and
            # come back inside the step: locate up to the interpolant's dip past zero
            # (slope_end is the held pieces' slope there: the law is on them)
            top = _dip(y, slope, y_end, slope_end, h, held)
            if top < 1.0 and changes < MAX_CHANGES:
                dip = pieces(t + top * h, rk.hermite(y, slope, y_end, slope_end, h, top),
                             model, drive, held)
                if dip != held:
                    theta, after = _locate(t, h, y, slope, y_end, slope_end, model, drive,
                                           held, top, dip)
                    y, t, h, held, slope = _switch(t, h, t_end, y, slope, theta, held,
                                                   after, model, drive)
                    continue
            return y_end, slope_end, end, changes
        if changes == MAX_CHANGES:              # chatter: finish by the law
            y_end = rk.step(_slope, t, y, h, (model, drive, BY_LAW))
            slope_end, end = _law(t_end, y_end, model, drive)
            return y_end, slope_end, end, changes
        theta, after = _locate(t, h, y, slope, y_end, _slope(t + h, y_end, args), model,
                               drive, held, 1.0, pieces(t_end, y_end, model, drive, held))
        y, t, h, held, slope = _switch(t, h, t_end, y, slope, theta, held, after, model,
                                       drive)
    return y, slope, held, MAX_CHANGES    # not reached


@inline_kernel
def _switch(t: float, h: float, t_end: float, y: tuple[float, ...], slope: tuple[float, ...], theta: float, held: Pieces,
            after: Pieces, model: PackedModel, drive: Drive
            ) -> tuple[tuple[float, ...], float, float, Pieces, tuple[float, ...]]:
    """The step from (t, y) redone up to the change at t + θ·h, switched there from the
    ``held`` pieces to ``after`` (a body that sticks stopped exactly): (y, t, the rest
    of the step, the new pieces, their slope)."""
    tau = theta * h
    y = _stick(rk.step_from(_slope, t, y, tau, slope, (model, drive, held)), held, after)
    t = t + tau
    return y, t, t_end - t, after, _slope(t, y, (model, drive, after))


@inline_kernel
def _dip(y0: tuple[float, ...], f0: tuple[float, ...], y1: tuple[float, ...], f1: tuple[float, ...], h: float, held: Pieces) -> float:
    """The first θ of the step (y0, f0) → (y1, f1) over h at which a slipping body's
    speed has, on the Hermite interpolant, an extremum past zero
    (:func:`~screwgear_ros.physics.friction.speed_dip`); 1.0 if none."""
    return min(speed_dip(held.friction_1, y0[3], f0[3], y1[3], f1[3], h),
               speed_dip(held.friction_2, y0[4], f0[4], y1[4], f1[4], h),
               speed_dip(held.friction_3, y0[5], f0[5], y1[5], f1[5], h))


@kernel
def advance(state: np.ndarray, step0: int, n: int, dt: float, model: PackedModel,
            drive: Drive, locate: bool = True) -> int:
    """Advance ``state`` (θ1, θ2, θ3 in rad, ω1, ω2, ω3 in rad/s, the lagged drive torques
    L1, L3 in N·m: :data:`~screwgear_ros.physics.packed.N_STATE` long) in place by n RK4 steps.

    Step k runs from t = (step0 + k)·dt to (step0 + k + 1)·dt, s. ``locate``: changes of
    contact (and of the drive line's piece) located inside the steps (module docstring),
    else plain fixed-step RK4. Returns how many changes were located. A state of the six
    mechanical entries alone is advanced as one whose drive torques are 0 (τ_d = 0 only).
    """
    lagged = state.shape[0] >= N_STATE
    if not lagged and model.p[TAU] != 0.0:
        raise ValueError('a drive time constant needs the lagged drive torques: the state '
                         'must be N_STATE long')
    # A mechanical state alone (6 long) runs without a lag: its drive torques stay 0.
    y = (state[0], state[1], state[2], state[3], state[4], state[5],
         state[6] if lagged else 0.0, state[7] if lagged else 0.0)
    located = 0
    if locate:
        slope, held = _law(step0 * dt, y, model, drive)
        for k in range(n):
            y, slope, held, changes = _located_step(
                (step0 + k) * dt, (step0 + k + 1) * dt, dt, y, slope, held, model, drive)
            located += changes
    else:
        law = (model, drive, BY_LAW)
        for k in range(n):
            y = rk.step(_slope, (step0 + k) * dt, y, dt, law)
    state[0], state[1], state[2], state[3], state[4], state[5] = y[:6]
    if lagged:
        state[6], state[7] = y[6], y[7]
    return located


#: Length of :func:`advance_observed`'s ``out``: the mechanical state (6), then
#: :func:`screwgear_ros.physics.motion.effort_and_meshes` of it (9), in their orders.
OBSERVED = 15


@kernel
def observe(state: np.ndarray, out: np.ndarray, t: float, model: PackedModel,
            drive: Drive) -> None:
    """``out`` (float64[OBSERVED]) = the state, then
    :func:`~screwgear_ros.physics.motion.effort_and_meshes` of it at time t (s)."""
    th1, th2, th3, w1, w2, w3 = state[0], state[1], state[2], state[3], state[4], state[5]
    lagged = state.shape[0] >= N_STATE
    o = effort_and_meshes(t, (th1, th2, th3, w1, w2, w3, state[6] if lagged else 0.0,
                              state[7] if lagged else 0.0), model, drive)
    out[0], out[1], out[2], out[3], out[4], out[5] = th1, th2, th3, w1, w2, w3
    for k in range(9):
        out[6 + k] = o[k]


@kernel
def advance_observed(state: np.ndarray, backup: np.ndarray, out: np.ndarray, step0: int,
                     n: int, dt: float, model: PackedModel, drive: Drive,
                     locate: bool = True) -> int:
    """One tick in one call: :func:`advance` n steps, keep the state finite, observe it.

    If any state value is non-finite after the n steps, ``state`` is put back to what
    it was before the call (kept in ``backup``) and -1 is returned; else the number of
    changes located. ``out`` is then :func:`observe` of ``state`` at its step (step0 + n,
    or step0 after a fault).
    """
    for i in range(state.shape[0]):
        backup[i] = state[i]
    located = advance(state, step0, n, dt, model, drive, locate)
    end = step0 + n
    for i in range(state.shape[0]):
        if not math.isfinite(state[i]):
            for j in range(state.shape[0]):
                state[j] = backup[j]
            located, end = -1, step0
            break
    observe(state, out, end * dt, model, drive)
    return located


@kernel
def advance_ticks(state: np.ndarray, backup: np.ndarray, rows: np.ndarray, step0: int,
                  ticks: int, n: int, dt: float, model: PackedModel, drive: Drive,
                  locate: bool = True) -> tuple[int, int, bool]:
    """``ticks`` ticks of n steps in one call: what as many calls of
    :func:`advance_observed` do (the same calls, bit for bit), ``rows[i]`` (float64,
    OBSERVED wide) getting tick i's ``out``. Stops after a tick that faults (its row
    observes the state put back, at its first step). Returns (ticks done, changes
    located by the ticks that did not fault, whether the last one faulted)."""
    located = 0
    step = step0
    for i in range(ticks):
        changes = advance_observed(state, backup, rows[i], step, n, dt, model, drive, locate)
        if changes < 0:
            return i + 1, located, True
        located += changes
        step += n
    return ticks, located, False


@kernel
def trajectory(state: np.ndarray, step0: int, dt: float, stride: int, out: np.ndarray,
               model: PackedModel, drive: Drive, locate: bool = True) -> int:
    """Advance ``state`` by ``out.shape[0]·stride`` steps, storing it every ``stride`` steps.

    ``out[j]`` is the state after (j + 1)·stride steps; ``state`` ends at the last row.
    Returns how many changes were located.
    """
    located = 0
    for j in range(out.shape[0]):
        located += advance(state, step0 + j * stride, stride, dt, model, drive, locate)
        for i in range(out.shape[1]):
            out[j, i] = state[i]
    return located


__all__ = ['MAX_CHANGES', 'OBSERVED', 'advance', 'advance_observed', 'advance_ticks', 'observe',
           'trajectory']
