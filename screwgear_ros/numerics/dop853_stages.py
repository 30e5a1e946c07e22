"""The stages of one DOP853 step and the pieces of the law a step holds: the reference
solver's building blocks (:mod:`screwgear_ros.numerics.dop853` runs the steps).

Each slope is the model's compiled right-hand side
(:func:`screwgear_ros.physics.motion.state_rate`) with each body's bearing friction held
on the piece a step holds; the contact law and the drive line pick theirs from the state.
"""

from __future__ import annotations

import math

import numpy as np

from ..physics.jit import inline_kernel, kernel
from ..physics.motion import BY_LAW, Pieces, pieces, rate_and_friction, state_rate
from ..physics.packed import N_STATE, Drive, PackedModel
from .dop853_tableau import Tableau

N = N_STATE


@inline_kernel
def _store(out: np.ndarray, k: int, d: tuple[float, ...]) -> None:
    """out[k, :] = d, the 8 rates of the state (unrolled: ``d`` is a tuple)."""
    out[k, 0] = d[0]
    out[k, 1] = d[1]
    out[k, 2] = d[2]
    out[k, 3] = d[3]
    out[k, 4] = d[4]
    out[k, 5] = d[5]
    out[k, 6] = d[6]
    out[k, 7] = d[7]


@kernel
def slope(t: float, y: np.ndarray, out: np.ndarray, k: int, model: PackedModel, drive: Drive,
          held: Pieces) -> None:
    """out[k, :] = f(t, y) through the model's compiled equations of motion and current
    loops, each body's bearing friction on the piece ``held`` names (the contact law and
    the drive line pick theirs from the state, as in the model's rhs)."""
    d = state_rate(t, (y[0], y[1], y[2], y[3], y[4], y[5], y[6], y[7]), model, drive,
                   held)[0]
    _store(out, k, d)


@kernel
def slope_and_law(t: float, y: np.ndarray, out: np.ndarray, k: int, model: PackedModel,
                  drive: Drive, held: Pieces) -> Pieces:
    """:func:`slope`, and what :func:`law` says at (t, y) coming from ``held``, from one
    evaluation of the torques (``held``'s contact branches and drive piece are those of
    :data:`BY_LAW`, as every piece a step holds here)."""
    d, (friction_1, friction_2, friction_3) = rate_and_friction(
        t, (y[0], y[1], y[2], y[3], y[4], y[5], y[6], y[7]), model, drive, held)
    _store(out, k, d)
    return Pieces(BY_LAW.branch_1, BY_LAW.branch_3, BY_LAW.drive, friction_1, friction_2,
                  friction_3)


@inline_kernel
def stage_state(y: np.ndarray, h: float, k: np.ndarray, a: np.ndarray, s: int, y_stage: np.ndarray) -> None:
    """y_stage = the state of stage s of a step of h from y (slopes k[0:s] given)."""
    for i in range(N):
        acc = 0.0
        for j in range(s):
            acc += a[s, j] * k[j, i]
        y_stage[i] = y[i] + h * acc


@kernel
def stages(t: float, y: np.ndarray, h: float, k: np.ndarray, tableau: Tableau, y_stage: np.ndarray, y_new: np.ndarray,
            model: PackedModel, drive: Drive, held: Pieces) -> bool:
    """Stages 2..12 of a step of h from (t, y), k[0] = f(t, y) given, into k; the new
    state into y_new. Returns whether it is finite."""
    a, b, c = tableau[0], tableau[1], tableau[2]
    n_stages = b.shape[0]
    for s in range(1, n_stages):
        stage_state(y, h, k, a, s, y_stage)
        slope(t + c[s] * h, y_stage, k, s, model, drive, held)
    finite = True
    for i in range(N):
        acc = 0.0
        for j in range(n_stages):
            acc += b[j] * k[j, i]
        y_new[i] = y[i] + h * acc
        if not math.isfinite(y_new[i]):
            finite = False
    return finite


@kernel
def law(t: float, y: np.ndarray, model: PackedModel, drive: Drive, held: Pieces) -> Pieces:
    """What a step holds at (t, y) coming from ``held``: each bearing's friction piece
    (:func:`~screwgear_ros.physics.motion.pieces`), the contact law and the drive line by the
    state (FROM_STATE)."""
    now = pieces(t, (y[0], y[1], y[2], y[3], y[4], y[5], y[6], y[7]), model, drive, held)
    return Pieces(BY_LAW.branch_1, BY_LAW.branch_3, BY_LAW.drive, now.friction_1,
                  now.friction_2, now.friction_3)


__all__ = ['law', 'slope', 'slope_and_law', 'stage_state', 'stages']
