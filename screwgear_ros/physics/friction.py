"""Bearing friction of one body with exact sticking (docs/model_notes.md §14).

A body (pinion 1, the table, pinion 3) of inertia I turns at speed ω under the torque τ
of everything else that acts on it (drive, mesh, load, viscous loss). Its bearing adds
the friction torque T_f, piecewise as Modelica's ``Rotational.Components.BearingFriction``:

- slipping forward (ω > 0):  T_f = −(τ_C + (τ_S − τ_C)·exp(−ω/ω_S))
- slipping backward (ω < 0): T_f = +(τ_C + (τ_S − τ_C)·exp(+ω/ω_S))
- stuck (ω = 0 and |τ| ≤ τ_S): T_f = −τ, so the body does not accelerate: ω̇ = 0.

τ_C is the Coulomb (sliding) torque, τ_S ≥ τ_C the static (breakaway) torque, ω_S the
Stribeck speed over which the sliding torque falls from τ_S to τ_C (ω_S = 0: at once).
The viscous part of the bearing loss is the body's own viscous coefficient, already in τ.

Which piece holds depends on the piece the body is on (:class:`FrictionPiece`): a stuck
body stays stuck while |τ| ≤ τ_S and breaks away in the sense of τ when it exceeds it; a
slipping body sticks (or reverses, if |τ| > τ_S there) when its speed reaches zero. On
each piece the law is smooth, so the integrator holds a body on its piece through an RK4
step and locates the changes as it does the contact law's (:mod:`.integrator`).

τ_S = 0 means no bearing friction: :data:`FrictionPiece.NONE`, whose acceleration is τ/I
computed exactly as without this module.
"""

from __future__ import annotations

import math
from enum import IntEnum

from .jit import kernel


class FrictionPiece(IntEnum):
    """Which piece of the friction law a body is on."""

    NONE = 0              # no bearing friction on this body (τ_S = 0)
    SLIP_FORWARD = 1      # ω > 0: T_f = −(τ_C + (τ_S − τ_C)·exp(−ω/ω_S))
    STUCK = 2             # ω = 0, |τ| ≤ τ_S: T_f = −τ, ω̇ = 0
    SLIP_BACKWARD = 3     # ω < 0: T_f = +(τ_C + (τ_S − τ_C)·exp(ω/ω_S))
    FROM_STATE = -1       # not a piece: picked from the speed and torque alone


@kernel
def at_rest(torque: float, static: float) -> FrictionPiece:
    """The piece of a body at rest under ``torque`` (N·m): stuck while |τ| ≤ τ_S, else
    breaking away in the sense of τ."""
    if torque > static:
        return FrictionPiece.SLIP_FORWARD
    if torque < -static:
        return FrictionPiece.SLIP_BACKWARD
    return FrictionPiece.STUCK


@kernel
def friction_piece(held: FrictionPiece, speed: float, torque: float,
                   static: float) -> FrictionPiece:
    """The piece the law puts a body on, coming from piece ``held``, at ``speed`` (rad/s)
    under ``torque`` (N·m, all but friction) with static torque ``static`` (τ_S, N·m).

    A slipping body stays on its piece while it keeps its sense of motion; a stuck body
    (its speed held at exactly 0) and a body whose speed has reached or crossed zero are
    judged at rest (:func:`at_rest`). From FROM_STATE (no history: the start of a run, or
    the reference's right-hand side) the sign of the speed decides, and ω = 0 is at rest.
    """
    if static <= 0.0:
        return FrictionPiece.NONE
    if held == FrictionPiece.STUCK or speed == 0.0:
        return at_rest(torque, static)
    if speed > 0.0:
        if held == FrictionPiece.SLIP_BACKWARD:       # crossed zero upwards
            return through_zero(held, torque, static)
        return FrictionPiece.SLIP_FORWARD
    if held == FrictionPiece.SLIP_FORWARD:            # crossed zero downwards
        return through_zero(held, torque, static)
    return FrictionPiece.SLIP_BACKWARD


@kernel
def through_zero(held: FrictionPiece, torque: float, static: float) -> FrictionPiece:
    """The piece of a body whose speed has crossed zero on the slip piece ``held``, under
    ``torque`` (N·m) where it is judged: :func:`at_rest`, but never ``held`` itself.

    A crossing is always a change, so that the event search (a bisection on "the pieces
    differ from ``held``") finds it. At the crossing itself |τ| ≤ τ_S or τ is against
    the old sense (the body could not have slowed to zero otherwise), but a state judged
    past it may be under a torque that has since grown beyond τ_S in the old sense: a
    step that spans a whole short sticking episode ends there with its speed of the
    wrong sign on its old piece. Calling that "breaking away in the old sense" would
    hide the crossing and the episode; it is STUCK instead, and if the torque still
    exceeds τ_S where the crossing is located the body breaks away from rest at once.
    """
    piece = at_rest(torque, static)
    if piece == held:
        return FrictionPiece.STUCK
    return piece


@kernel
def speed_dip(piece: FrictionPiece, w0: float, a0: float, w1: float, a1: float,
              h: float) -> float:
    """The first θ in (0, 1) at which a body on slip piece ``piece`` has, on the cubic
    Hermite interpolant of its speed over a step of h seconds (ω0, ω̇0 at its start, ω1,
    ω̇1 at its end: :func:`screwgear_ros.numerics.rk.hermite`), an extremum on the wrong side of
    zero; 1.0 if there is none (or the body is not slipping).

    A speed that crosses zero and comes back inside one step ends the step with its sign
    and its piece unchanged, so the check at the step's end cannot see it; but the law
    stops the body at the first crossing (it sticks while |τ| ≤ τ_S, breaks away later).
    The interpolant's extremum past zero is a point the crossing precedes, so a bisection
    between the step's start and it finds the crossing.
    """
    if piece == FrictionPiece.SLIP_FORWARD:
        sense = 1.0
    elif piece == FrictionPiece.SLIP_BACKWARD:
        sense = -1.0
    else:
        return 1.0
    # ω(θ) = ω0 + θ·(h·ω̇0 + θ·(q + θ·c)); its extrema: 3c·θ² + 2q·θ + h·ω̇0 = 0
    delta = w1 - w0
    q = 3.0 * delta - h * (2.0 * a0 + a1)
    c = h * (a0 + a1) - 2.0 * delta
    qa, qb, qc = 3.0 * c, 2.0 * q, h * a0
    r1, r2 = 2.0, 2.0                       # no root: outside (0, 1)
    if qa == 0.0:
        if qb != 0.0:
            r1 = -qc / qb
    else:
        disc = qb * qb - 4.0 * qa * qc
        if disc >= 0.0:
            half = -0.5 * (qb + math.copysign(math.sqrt(disc), qb))
            if half != 0.0:
                r1, r2 = half / qa, qc / half
            else:
                r1 = 0.0
    first, second = min(r1, r2), max(r1, r2)
    for theta in (first, second):
        if 0.0 < theta < 1.0 and sense * (w0 + theta * (h * a0 + theta * (q + theta * c))) < 0.0:
            return theta
    return 1.0


@kernel
def sliding_torque(piece: FrictionPiece, speed: float, coulomb: float, static: float,
                   stribeck: float) -> float:
    """Friction torque T_f (N·m) on a slipping piece, continued smoothly past ω = 0 (an
    RK4 stage may overshoot the zero the integrator then locates); 0 off the slip
    pieces."""
    if piece == FrictionPiece.SLIP_FORWARD:
        if stribeck > 0.0:
            return -(coulomb + (static - coulomb) * math.exp(-speed / stribeck))
        return -coulomb
    if piece == FrictionPiece.SLIP_BACKWARD:
        if stribeck > 0.0:
            return coulomb + (static - coulomb) * math.exp(speed / stribeck)
        return coulomb
    return 0.0


@kernel
def friction_on(piece: FrictionPiece, speed: float, torque: float, inertia: float,
                coulomb: float, static: float, stribeck: float) -> tuple[float, float]:
    """(ω̇ in rad/s², friction torque T_f in N·m) of a body on ``piece`` under ``torque``
    (N·m, all but friction): τ/I exactly when there is no friction (NONE), 0 and −τ when
    stuck, (τ + T_f)/I when slipping (:func:`sliding_torque`)."""
    if piece == FrictionPiece.NONE:
        return torque / inertia, 0.0
    if piece == FrictionPiece.STUCK:
        return 0.0, -torque
    friction = sliding_torque(piece, speed, coulomb, static, stribeck)
    return (torque + friction) / inertia, friction


__all__ = [
    'FrictionPiece',
    'at_rest',
    'friction_on',
    'friction_piece',
    'sliding_torque',
    'speed_dip',
    'through_zero',
]
