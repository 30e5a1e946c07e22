"""The rigid steady motion of the gear under a constant drive torque, direction and table
load: the table speed at which the torques of every term but the meshes'
(:func:`~screwgear_ros.physics.torques.torque_terms`, bearing friction included) balance
on the rigid motion, solved numerically on those terms, so a new term moves it without
an edit here. What the operating point of a linear model
(:mod:`screwgear_ros.design.operating_point`) and the terminal speed
(:func:`~screwgear_ros.physics.quantities.terminal_speed`) stand on.

In a rigid motion every mesh keeps its deflection (δ1 = r1·θ1 − r2·θ2 and δ3 alike), so
the pinions turn at ω1 = ω2·r2/r1, ω3 = ω2·r2/r3 (pinion 3 stands in `conventional`
mode) and the meshes' forces do no net work: the motion is steady where the generalized
torque g(ω2) = Σ_j (∂ω_j/∂ω2)·τ_j of the other terms is zero. The drives' current loops
sit at their targets, the periodic terms at their mean (t = 0 and θ = 0, where the
fluctuation and the cogging ripple are zero), and bearing friction slips in the sense of
the motion; at rest, it holds the gear while g stays within its static torques.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

from .drive import DrivePiece, active_speed, drive_piece, drive_targets
from .friction import FrictionPiece
from .mesh import ContactBranch
from .motion import Pieces, bearings
from .packed import MODE, MODE_CONVENTIONAL, R1, R2, R3, Drive, PackedModel
from .torques import Terms, off_mesh_torques, torque_terms

#: The fastest table speed (rad/s) a steady motion is looked for at: beyond it, nothing
#: holds the drive back.
FASTEST = 1e15


def rigid_state(model: PackedModel, table_speed: float, torque: float, direction: int
                ) -> tuple[tuple[float, ...], DrivePiece, np.ndarray]:
    """The state of the rigid motion at ``table_speed`` (rad/s; angles 0, the current
    loops at their targets), the piece of the drive line it puts the drive on, and
    ∂ω_j/∂ω2 of each body (pinion 1, table, pinion 3)."""
    p = model.p
    conventional = p[MODE] == MODE_CONVENTIONAL
    w1 = table_speed * p[R2] / p[R1]
    w3 = 0.0 if conventional else table_speed * p[R2] / p[R3]
    piece = DrivePiece(drive_piece(torque, active_speed(w1, w3, float(direction), p), p))
    lag1, lag3 = drive_targets(piece, w1, w3, torque, float(direction), p)
    lever = np.array([p[R2] / p[R1], 1.0, 0.0 if conventional else p[R2] / p[R3]])
    return (0.0, 0.0, 0.0, w1, table_speed, w3, lag1, lag3), piece, lever


def rigid_torques(model: PackedModel, table_speed: float, sense: float, torque: float,
                  direction: int, load: float) -> tuple[np.ndarray, Terms, DrivePiece,
                                                        np.ndarray]:
    """The torque of every term but the meshes' on each body in the rigid motion at
    ``table_speed``, bearing friction slipping in ``sense`` (±1; 0: none, at rest), with
    the terms themselves, the drive piece and ∂ω_j/∂ω2 (:func:`rigid_state`)."""
    y, piece, lever = rigid_state(model, table_speed, torque, direction)
    terms = torque_terms(0.0, y, model, Drive(torque, float(direction), load),
                         ContactBranch.FROM_STATE, ContactBranch.FROM_STATE, piece)[0]
    tau = off_mesh_torques(terms)
    if sense != 0.0:
        slip = FrictionPiece.SLIP_FORWARD if sense > 0.0 else FrictionPiece.SLIP_BACKWARD
        standing = FrictionPiece.FROM_STATE if lever[2] == 0.0 else slip
        friction = bearings(y, tau[0], tau[1], tau[2], model.p,
                            Pieces(ContactBranch.FROM_STATE, ContactBranch.FROM_STATE,
                                   piece, slip, slip, standing))[3:6]
        tau = tuple(t + f for t, f in zip(tau, friction, strict=True))
    return np.array(tau), terms, piece, lever


def steady_table_speed(model: PackedModel, torque: float, load: float,
                       direction: int) -> float:
    """The table speed (rad/s) of the rigid steady motion (module docstring) under drive
    ``torque`` ≥ 0 (N·m) in ``direction`` (±1) against table ``load`` (N·m): 0 when the
    gear rests, ±inf when nothing holds it back."""

    def g(speed: float, sense: float) -> float:
        tau, _, _, lever = rigid_torques(model, speed, sense, torque, direction, load)
        return float(lever @ tau)

    _, terms, _, lever = rigid_torques(model, 0.0, 0.0, torque, direction, load)
    scale = float(np.abs(lever) @ np.sum(np.abs(np.array(terms)), axis=0))
    tolerance = 1e-12 * scale
    forward, backward = g(0.0, 1.0), g(0.0, -1.0)
    if forward <= tolerance and backward >= -tolerance:
        return 0.0                          # held at rest (by friction, or exactly)
    sense = 1.0 if forward > tolerance else -1.0
    far = 1.0
    while sense * g(sense * far, sense) > 0.0:
        far *= 2.0
        if far > FASTEST:
            return sense * math.inf
    near = 0.0 if far == 1.0 else far / 2.0
    ends = sorted((sense * near, sense * far))
    return float(brentq(g, ends[0], ends[1], args=(sense,), xtol=1e-300,
                        rtol=4.0 * np.finfo(float).eps))


__all__ = [
    'FASTEST',
    'rigid_state',
    'rigid_torques',
    'steady_table_speed',
]
