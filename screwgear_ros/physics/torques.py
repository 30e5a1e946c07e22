"""The generalized torques on the three bodies, term by term: the one place each term of
the equations of motion is written (``shared/spec/model.md`` §3, docs/model_notes.md).

:func:`torque_terms` gives each term's torque on pinion 1, the table and pinion 3
(N·m, each in the sense its body's angle is counted) at a state: the drives (with the
preload, the torque–speed line, the fluctuation and the current loops' lag), the motors'
cogging, the meshes, the table load and the viscous bearing losses. Bearing friction,
which depends on the sum of the others (a stuck body is held by whatever acts on it),
is the one term applied after them (:func:`~screwgear_ros.physics.motion.bearings`).

Everything else derives from these terms: the right-hand side sums them
(:func:`net_torques`; :mod:`.motion`), the energy audit integrates each term's power
(:mod:`screwgear_ros.sim.energy`), the rigid steady motion solves their balance
(:mod:`.steady`: the operating point, the terminal speed), and the linearizations take
their differences (:func:`~screwgear_ros.physics.motion.stiffest_linearization`,
:mod:`screwgear_ros.design.linearize`). A new term is one more field of :class:`Terms`
and its line in :func:`torque_terms`; ``test/unit/physics/test_torques.py`` fails if a
derived quantity misses it.

A term that does not act on a body is :data:`NOTHING` there, −0.0: the exact identity of
floating-point addition (x + −0.0 is x for every x, signed zeros included), so the sum
of the terms is bit for bit the sum of those that act.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from .drive import DrivePiece, pinion_torques
from .jit import inline_kernel, kernel
from .mesh import ContactBranch, mesh_load_on
from .packed import (
    CP,
    CT,
    MODE,
    MODE_CONVENTIONAL,
    NCOG,
    R1,
    R2,
    R3,
    TCOG,
    Z1,
    Z3,
    Drive,
    PackedModel,
)

#: What a term adds to a body it does not act on: −0.0, the exact identity of addition.
NOTHING = -0.0

#: A term's torques on (pinion 1, table, pinion 3), N·m.
Triple = tuple[float, float, float]


class Terms(NamedTuple):
    """Each term of the equations of motion as its torques on (pinion 1, table,
    pinion 3), N·m, in the order they are summed (:func:`net_torques`)."""

    drive: Triple      # the drives: preload, command through the line, fluctuation, lag
    cogging: Triple    # the motors' cogging ripple T_cog·sin(n_cog·θ)
    mesh: Triple       # −Q1, r2·(F1 + F3), −Q3 (:func:`~screwgear_ros.physics.mesh.mesh_load_on`)
    load: Triple       # the external table load −T_load
    viscous: Triple    # the viscous bearing losses −c_p·ω1, −c_t·ω2, −c_p·ω3


#: The names of the terms, in :class:`Terms`' order.
TERM_NAMES: tuple[str, ...] = Terms._fields
#: Where the mesh term is in :class:`Terms` (its work is the mesh's stored energy, its
#: damping and its phase work: :mod:`screwgear_ros.sim.energy`).
MESH_TERM = TERM_NAMES.index('mesh')


@kernel
def torque_terms(t: float, y: tuple, model: PackedModel, drive: Drive,
                 branch_1: ContactBranch, branch_3: ContactBranch, piece: DrivePiece
                 ) -> tuple[Terms, float, float, ContactBranch, ContactBranch, DrivePiece]:
    """Every term's torques on the three bodies at state y (module docstring), the meshes
    on contact ``branch_1``, ``branch_3`` and the drive on ``piece`` of its line
    (FROM_STATE: the ones the contact law and the line pick at y).

    Returns (the :class:`Terms`, F1, F3 in N, the branches of mesh 1 and mesh 3, the drive
    piece). In `conventional` mode pinion 3 is disengaged (F3 = Q3 = 0) and has no motor.
    """
    p = model.p
    th1, th2, th3, w1, w2, w3 = y[0], y[1], y[2], y[3], y[4], y[5]
    t1, t3, piece = pinion_torques(piece, t, y, drive.torque, drive.direction, p)
    cog1 = cog3 = NOTHING
    if p[TCOG] != 0.0:
        cog1 = p[TCOG] * math.sin(p[NCOG] * th1)
        if p[MODE] != MODE_CONVENTIONAL:
            cog3 = p[TCOG] * math.sin(p[NCOG] * th3)
    f1, q1, branch_1 = mesh_load_on(th1, w1, p[R1], p[Z1], th2, w2, t, model, branch_1)
    if p[MODE] == MODE_CONVENTIONAL:
        f3, q3, branch_3 = 0.0, 0.0, ContactBranch.DISENGAGED
    else:
        f3, q3, branch_3 = mesh_load_on(th3, w3, p[R3], p[Z3], th2, w2, t, model, branch_3)
    pinion_1 = pinion_3 = NOTHING
    if p[CP] != 0.0:
        pinion_1, pinion_3 = -(p[CP] * w1), -(p[CP] * w3)
    terms = Terms((t1, NOTHING, t3),
                  (cog1, NOTHING, cog3),
                  (-q1, p[R2] * (f1 + f3), -q3),
                  (NOTHING, -drive.load, NOTHING),
                  (pinion_1, -(p[CT] * w2), pinion_3))
    return terms, f1, f3, branch_1, branch_3, piece


@inline_kernel
def net_torques(terms: Terms) -> Triple:
    """The sum of the terms on each body, N·m, in :class:`Terms`' order."""
    tau1, tau2, tau3 = terms[0]
    for k in range(1, len(terms)):
        tau1 += terms[k][0]
        tau2 += terms[k][1]
        tau3 += terms[k][2]
    return tau1, tau2, tau3


@kernel
def off_mesh_torques(terms: Terms) -> Triple:
    """The sum of every term but the mesh's on each body, N·m: what acts on the gear
    from outside the meshes (the meshes only pass it between the bodies)."""
    tau1 = tau2 = tau3 = NOTHING
    for k in range(len(terms)):
        if k != MESH_TERM:
            tau1 += terms[k][0]
            tau2 += terms[k][1]
            tau3 += terms[k][2]
    return tau1, tau2, tau3


__all__ = [
    'MESH_TERM',
    'NOTHING',
    'TERM_NAMES',
    'Terms',
    'Triple',
    'net_torques',
    'off_mesh_torques',
    'torque_terms',
]
