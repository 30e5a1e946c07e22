"""The equations of motion of the 3-DOF double screw gear (``shared/spec/model.md`` §3):
the torque on each body, the sum of the terms of :mod:`.torques` (the one place each
term is written), then bearing friction (:mod:`.friction`); the right-hand side the
integrators and the reference take, what the node publishes about a state, and the
stiffest linearization that bounds an explicit step.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..params.table import Mode, TableParams, effective_stiffness, ste_slope
from .drive import DrivePiece, drive_targets, lag_rates
from .friction import FrictionPiece, friction_on, friction_piece
from .jit import inline_kernel, kernel
from .mesh import ContactBranch, contact_branch, mesh_motion
from .packed import (
    I1,
    I2,
    I3,
    MODE,
    MODE_CONVENTIONAL,
    N_MECHANICAL,
    R1,
    R3,
    TC2,
    TCP,
    TS2,
    TSP,
    WS2,
    WSP,
    Z1,
    Z3,
    B,
    C,
    Drive,
    PackedModel,
    pack,
)
from .torques import net_torques, off_mesh_torques, torque_terms


class Pieces(NamedTuple):
    """The pieces of the law the equations of motion are on (:func:`motion`): what a step
    holds while it integrates one smooth piece (:mod:`screwgear_ros.numerics.integrator`)."""

    branch_1: ContactBranch     # of mesh 1
    branch_3: ContactBranch     # of mesh 3
    drive: DrivePiece           # of the drive's torque–speed line
    # of each body's bearing friction law (:mod:`screwgear_ros.physics.friction`)
    friction_1: FrictionPiece = FrictionPiece.FROM_STATE    # pinion 1
    friction_2: FrictionPiece = FrictionPiece.FROM_STATE    # the table
    friction_3: FrictionPiece = FrictionPiece.FROM_STATE    # pinion 3


#: Pieces meaning "the ones the law picks at the state".
BY_LAW = Pieces(ContactBranch.FROM_STATE, ContactBranch.FROM_STATE, DrivePiece.FROM_STATE,
                FrictionPiece.FROM_STATE, FrictionPiece.FROM_STATE, FrictionPiece.FROM_STATE)


@kernel
def body_torques(t: float, y: tuple, model: PackedModel, drive: Drive, held: Pieces
                 ) -> tuple[float, float, float, float, float, float, float, ContactBranch,
                            ContactBranch, DrivePiece]:
    """The torque on each body from everything but its bearing friction at state y: the
    sum of the terms of :func:`~screwgear_ros.physics.torques.torque_terms`, the meshes on
    the contact branches and the drive on the piece of its line ``held`` names
    (FROM_STATE: the ones the contact law and the drive line pick at this state).

    Returns (τ1, τ2, τ3, T1, T3 in N·m: the drives' torques on the pinions with their
    cogging, F1, F3 in N, branch of mesh 1, branch of mesh 3, drive piece).
    """
    terms, f1, f3, branch_1, branch_3, piece = torque_terms(
        t, y, model, drive, held.branch_1, held.branch_3, held.drive)
    tau1, tau2, tau3 = net_torques(terms)
    return (tau1, tau2, tau3, terms.drive[0] + terms.cogging[0],
            terms.drive[2] + terms.cogging[2], f1, f3, branch_1, branch_3, piece)


@kernel
def friction_pieces(y: tuple, tau1: float, tau2: float, tau3: float, p: np.ndarray,
                    held: Pieces) -> tuple[FrictionPiece, FrictionPiece, FrictionPiece]:
    """The pieces of the bearing friction law (:func:`~screwgear_ros.physics.friction.friction_piece`)
    of pinion 1, the table and pinion 3 at state y, coming from the ones ``held`` names
    (FROM_STATE: from the speeds and torques alone), under the torques τ of
    :func:`body_torques`."""
    return (friction_piece(held.friction_1, y[3], tau1, p[TSP]),
            friction_piece(held.friction_2, y[4], tau2, p[TS2]),
            friction_piece(held.friction_3, y[5], tau3, p[TSP]))


@kernel
def motion(t: float, y: tuple, model: PackedModel, drive: Drive, held: Pieces
           ) -> tuple[float, float, float, float, float, float, float, float, Pieces]:
    """The 3-DOF equations of motion (model.md §3) at state y, the meshes on the contact
    branches, the drive on the piece of its line and each body's bearing friction on the
    piece of its law ``held`` names (FROM_STATE: the ones the laws pick at this state;
    :data:`BY_LAW` all of them).

    I_j·θ̈_j = τ_j + T_f,j with the torques τ of :func:`body_torques` and the bearing
    friction T_f of :func:`~screwgear_ros.physics.friction.friction_on` (docs/model_notes.md §14:
    stuck, θ̈_j = 0; no friction, τ_j/I_j exactly as the model without it).

    Returns (θ̈1, θ̈2, θ̈3 in rad/s², T1, net table torque (its friction included), T3
    in N·m, F1, F3 in N, the pieces the law was on).
    """
    return _accelerations(y, body_torques(t, y, model, drive, held), model.p, held)


@inline_kernel
def bearings(y: tuple, tau1: float, tau2: float, tau3: float, p: np.ndarray, held: Pieces
             ) -> tuple[float, float, float, float, float, float, FrictionPiece,
                        FrictionPiece, FrictionPiece]:
    """Each body's bearing friction under the torques τ of :func:`body_torques` at state
    y, on the pieces of its law ``held`` names (FROM_STATE: from the speed and torque):
    (θ̈1, θ̈2, θ̈3 in rad/s², the friction torques T_f1, T_f2, T_f3 in N·m, the pieces).
    """
    friction_1, friction_2, friction_3 = held.friction_1, held.friction_2, held.friction_3
    if friction_1 == FrictionPiece.FROM_STATE:
        friction_1 = friction_piece(friction_1, y[3], tau1, p[TSP])
    if friction_2 == FrictionPiece.FROM_STATE:
        friction_2 = friction_piece(friction_2, y[4], tau2, p[TS2])
    if friction_3 == FrictionPiece.FROM_STATE:
        friction_3 = friction_piece(friction_3, y[5], tau3, p[TSP])
    a1, f1 = friction_on(friction_1, y[3], tau1, p[I1], p[TCP], p[TSP], p[WSP])
    a2, f2 = friction_on(friction_2, y[4], tau2, p[I2], p[TC2], p[TS2], p[WS2])
    a3, f3 = friction_on(friction_3, y[5], tau3, p[I3], p[TCP], p[TSP], p[WSP])
    return a1, a2, a3, f1, f2, f3, friction_1, friction_2, friction_3


@inline_kernel
def _accelerations(y: tuple, torques: tuple, p: np.ndarray, held: Pieces
                   ) -> tuple[float, float, float, float, float, float, float, float, Pieces]:
    """:func:`motion` from the torques of :func:`body_torques` at state y."""
    tau1, tau2, tau3, t1, t3, f1, f3, branch_1, branch_3, piece = torques
    a1, a2, a3, _, table_friction, _, friction_1, friction_2, friction_3 = bearings(
        y, tau1, tau2, tau3, p, held)
    table = tau2 if friction_2 == FrictionPiece.NONE else tau2 + table_friction
    return (a1, a2, a3, t1, table, t3, f1, f3,
            Pieces(branch_1, branch_3, piece, friction_1, friction_2, friction_3))


@kernel
def state_rate(t: float, y: tuple, model: PackedModel, drive: Drive, held: Pieces
               ) -> tuple[tuple, Pieces]:
    """dy/dt (rad/s, rad/s², N·m/s) with the law on the pieces ``held`` names
    (:func:`motion`), and the pieces it was on."""
    m = motion(t, y, model, drive, held)
    l1, l3 = lag_rates(y, drive.torque, drive.direction, m[8].drive, model.p)
    return (y[3], y[4], y[5], m[0], m[1], m[2], l1, l3), m[8]


@kernel
def rate_and_friction(t: float, y: tuple, model: PackedModel, drive: Drive, held: Pieces
                      ) -> tuple[tuple, tuple[FrictionPiece, FrictionPiece, FrictionPiece]]:
    """:func:`state_rate`'s dy/dt, and the bearings' friction pieces at y coming from those
    ``held`` names (:func:`friction_pieces`), from one evaluation of the torques: what
    :func:`pieces` says of them when ``held``'s contact branches and drive piece are
    FROM_STATE (the reference solver's), without evaluating the torques again."""
    torques = body_torques(t, y, model, drive, held)
    m = _accelerations(y, torques, model.p, held)
    l1, l3 = lag_rates(y, drive.torque, drive.direction, m[8].drive, model.p)
    return ((y[3], y[4], y[5], m[0], m[1], m[2], l1, l3),
            friction_pieces(y, torques[0], torques[1], torques[2], model.p, held))


@kernel
def rhs(t: float, y: tuple, model: PackedModel, drive: Drive) -> tuple:
    """dy/dt of the equations of motion (:func:`motion`) and of the current loops
    (:func:`lag_rates`)."""
    return state_rate(t, y, model, drive, BY_LAW)[0]


@kernel
def contact_branches(t: float, y: tuple, model: PackedModel
                     ) -> tuple[ContactBranch, ContactBranch]:
    """The branches of the contact law mesh 1 and mesh 3 are on at state y."""
    p = model.p
    th1, th2, th3, w1, w2, w3 = y[0], y[1], y[2], y[3], y[4], y[5]
    _, _, d1, dd1, k1 = mesh_motion(th1, w1, p[R1], p[Z1], th2, w2, t, model)
    if p[MODE] == MODE_CONVENTIONAL:
        return contact_branch(d1, dd1, k1, p[C], p[B]), ContactBranch.DISENGAGED
    _, _, d3, dd3, k3 = mesh_motion(th3, w3, p[R3], p[Z3], th2, w2, t, model)
    return contact_branch(d1, dd1, k1, p[C], p[B]), contact_branch(d3, dd3, k3, p[C], p[B])


@kernel
def pieces(t: float, y: tuple, model: PackedModel, drive: Drive, held: Pieces) -> Pieces:
    """The pieces the law is on at state y, without the slope: the contact branches and
    the drive piece the state picks, each bearing's friction piece coming from the one
    ``held`` names (:func:`friction_pieces`: a slipping body whose speed has reached zero
    is judged at rest; FROM_STATE, as in :data:`BY_LAW`: what :func:`motion` picks)."""
    tau1, tau2, tau3, _, _, _, _, branch_1, branch_3, piece = body_torques(
        t, y, model, drive, BY_LAW)
    friction_1, friction_2, friction_3 = friction_pieces(y, tau1, tau2, tau3, model.p, held)
    return Pieces(branch_1, branch_3, piece, friction_1, friction_2, friction_3)


@kernel
def effort_and_meshes(t: float, y: tuple, model: PackedModel, drive: Drive
            ) -> tuple[float, float, float, float, float, float, float, float, float]:
    """What the node publishes about a state besides the state itself: the torques
    applied to pinion 1, the table (net, = I2·θ̈2) and pinion 3 (N·m; on the pinions the
    preload and the drive torque actually applied, :func:`pinion_torques`: the command
    itself below the drive's line with no lag), then δ (m), δ̇ (m/s) and
    the mesh force F (N) of mesh 1 and of mesh 3 (δ3 and δ̇3 also when pinion 3 is
    disengaged, with F3 = 0)."""
    p = model.p
    th1, th2, th3, w1, w2, w3 = y[0], y[1], y[2], y[3], y[4], y[5]
    _, _, _, t1, table, t3, f1, f3, _ = motion(t, y, model, drive, BY_LAW)
    _, _, d1, dd1, _ = mesh_motion(th1, w1, p[R1], p[Z1], th2, w2, t, model)
    _, _, d3, dd3, _ = mesh_motion(th3, w3, p[R3], p[Z3], th2, w2, t, model)
    return t1, table, t3, d1, dd1, f1, d3, dd3, f3


def rhs_vector(t: float, y: np.ndarray, model: PackedModel, drive: Drive) -> np.ndarray:
    """The same right-hand side on a state vector, for SciPy solvers: N_STATE long, or the
    mechanical state alone (the drives' lagged torques then 0), as long as ``y``."""
    lag = (y[6], y[7]) if len(y) > N_MECHANICAL else (0.0, 0.0)
    return np.array(rhs(t, (y[0], y[1], y[2], y[3], y[4], y[5], *lag), model, drive))[:len(y)]


def stiffest_linearization(params: TableParams) -> np.ndarray:
    """System matrix A (6×6, dy/dt = A·y) of the equations of motion linearized at their
    stiffest: every mesh that can carry force in contact at K = k_eff + k_a, with the
    longest pinion lever r + z·Σ n·|ε_n| (`angle` phase, see
    :func:`~screwgear_ros.params.table.ste_slope`) and the contact damping c; every other
    term at its speed derivative (:func:`off_mesh_damping`: the drive on its torque–speed
    line, whose slope −T_s/ω_nl acts as a damper on the pinion it drives, the viscous
    losses, …). Bearing friction's Stribeck slope is left out (docs/model_notes.md §14).
    Generalized mesh directions: δ1 = r1·θ1 − r2·θ2, δ3 = r3·θ3 − r2·θ2 (mesh 3 only
    in `anti_backlash`). Its eigenvalues bound the step an explicit method can take."""
    k = effective_stiffness(params) + params.mesh_stiffness_amplitude
    lever_1 = params.radius_pinion_1 + ste_slope(params, '1')
    lever_3 = params.radius_pinion_3 + ste_slope(params, '3')
    inertia = np.array([params.inertia_pinion_1, params.inertia_table, params.inertia_pinion_3])
    g = np.array([[lever_1, -params.radius_table, 0.0], [0.0, -params.radius_table, lever_3]])
    if params.mode is Mode.CONVENTIONAL:
        g = g[:1]
    stiffness = k * g.T @ g
    damping = params.mesh_damping * g.T @ g + off_mesh_damping(params)
    m_inv = np.diag(1.0 / inertia)
    return np.block([[np.zeros((3, 3)), np.eye(3)], [-m_inv @ stiffness, -m_inv @ damping]])


def off_mesh_damping(params: TableParams) -> np.ndarray:
    """−∂τ/∂ω (3×3, N·m·s/rad) of the torques of every term but the meshes'
    (:func:`~screwgear_ros.physics.torques.off_mesh_torques`) at rest, by central
    differences of unit speed steps (the terms are affine in the speeds on one piece of
    the drive line), with the drive on its torque–speed line where it has one and the
    current loops at their targets; each pinion's column in the direction that drives
    it (the larger damping of the two)."""
    model = pack(params)
    piece = DrivePiece.LINE if params.drive_no_load_speed > 0.0 else DrivePiece.COMMAND
    out = np.zeros((3, 3))
    for direction in (1.0, -1.0):
        for j in range(3):
            step = np.zeros(3)
            step[j] = 1.0
            column = (_off_mesh(model, -step, direction, piece)
                      - _off_mesh(model, step, direction, piece)) / 2.0
            if direction > 0.0 or column[j] > out[j, j]:
                out[:, j] = column
    return out


def _off_mesh(model: PackedModel, speeds: np.ndarray, direction: float,
              piece: DrivePiece) -> np.ndarray:
    w1, w2, w3 = (float(v) for v in speeds)
    lag1, lag3 = drive_targets(piece, w1, w3, 0.0, direction, model.p)
    terms = torque_terms(0.0, (0.0, 0.0, 0.0, w1, w2, w3, lag1, lag3), model,
                         Drive(0.0, direction, 0.0), ContactBranch.FROM_STATE,
                         ContactBranch.FROM_STATE, piece)[0]
    return np.array(off_mesh_torques(terms))


__all__ = [
    'BY_LAW',
    'Pieces',
    'bearings',
    'body_torques',
    'contact_branches',
    'effort_and_meshes',
    'friction_pieces',
    'motion',
    'off_mesh_damping',
    'pieces',
    'rhs',
    'rhs_vector',
    'state_rate',
    'stiffest_linearization',
]
