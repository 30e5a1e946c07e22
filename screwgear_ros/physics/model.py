"""The 3-DOF double screw gear model of ``shared/spec/model.md``: mesh law, drive
torques per mode, equations of motion.

State y = (θ1, θ2, θ3, ω1, ω2, ω3): pinion 1, table, pinion 3 angles in rad and
speeds in rad/s, pinion angles counted in the sense that drives the table forward.
Input u = (torque, direction, load): drive torque magnitude T ≥ 0 in N·m on the
active pinion, direction d = ±1, external table load T_load in N·m.

The drives' current loops add two states (:data:`N_STATE` in all): y[6] and y[7], the
torque the drive of pinion 1 and of pinion 3 applies besides the preload (N·m, signed in
the sense that drives the table forward), each lagging its command with the time
constant τ_d (``drive_time_constant``). With τ_d = 0 they stay 0 and are not used: the
command acts at once.

The functions are scalar and compiled with numba (``NUMBA_DISABLE_JIT=1`` runs the
same source as plain Python). What the equations of motion take travels as named tuples,
each declared once here and passed whole through the integrators, so a new parameter
array, input or held piece is one field of one tuple rather than a parameter of every
kernel: the model (:class:`PackedModel`, from :func:`pack`: one packed float array and the
STE harmonics, so the compiled code sees no Python objects), the drive input
(:class:`Drive`) and the pieces of the law a step holds (:class:`Pieces`). The state y
is a tuple of :data:`N_STATE` floats.

Why one module of this length: the mesh law, the drive line and the equations of motion
are one set of equations over one packed parameter layout and one set of contact
branches; the integrators and the reference all take their right-hand side from here.
"""

from __future__ import annotations

import math
from enum import IntEnum
from typing import NamedTuple

import numpy as np

from ..numerics.jit import kernel
from ..params.declarations import kernel_fields
from ..params.table import (
    MeshFormulation,
    MeshPhase,
    Mode,
    TableParams,
    effective_stiffness,
    ste_slope,
)
from .friction import FrictionPiece, friction_on, friction_piece

# Layout of the packed parameter array: the kernel=True fields of TableParams in their
# declaration order, then three derived slots. Looking the indices up by name means a
# field the kernel uses cannot be left out of pack() (the import would fail).
KERNEL = kernel_fields(TableParams)
_AT = {name: index for index, name in enumerate(KERNEL)}
I1, I2, I3 = _AT['inertia_pinion_1'], _AT['inertia_table'], _AT['inertia_pinion_3']
R1, R2, R3 = _AT['radius_pinion_1'], _AT['radius_table'], _AT['radius_pinion_3']
Z1, Z3 = _AT['teeth_pinion_1'], _AT['teeth_pinion_3']
K_A, PHI_K = _AT['mesh_stiffness_amplitude'], _AT['mesh_stiffness_phase']
C, B, TP = _AT['mesh_damping'], _AT['backlash'], _AT['preload_torque']
TV, WV = _AT['torque_fluctuation_amplitude'], _AT['torque_fluctuation_frequency']
CT, WE = _AT['table_damping'], _AT['mesh_frequency']
WNL, TS = _AT['drive_no_load_speed'], _AT['drive_stall_torque']
TC2, TS2, WS2 = (_AT['table_coulomb_torque'], _AT['table_static_torque'],
                 _AT['table_stribeck_speed'])
TCP, TSP, WSP, CP = (_AT['pinion_coulomb_torque'], _AT['pinion_static_torque'],
                     _AT['pinion_stribeck_speed'], _AT['pinion_damping'])
TAU, TCOG, NCOG = (_AT['drive_time_constant'], _AT['cogging_amplitude'],
                   _AT['cogging_order'])
K_EFF, MODE, PHASE, FORMULATION = range(len(KERNEL), len(KERNEL) + 4)   # derived: k_eff, enums
N_PACKED = len(KERNEL) + 4

#: Length of the state: θ1, θ2, θ3, ω1, ω2, ω3, then the lagged drive torques L1, L3.
N_STATE = 8
#: Of it, the mechanical state (what joint_states carries and a recording starts from).
N_MECHANICAL = 6

MODE_ANTI_BACKLASH = 0.0
MODE_CONVENTIONAL = 1.0
PHASE_ANGLE = 0.0
PHASE_TIME = 1.0
FORM_PAPER = 0.0
FORM_ENERGY = 1.0


class ContactBranch(IntEnum):
    """Which branch of the contact law (model.md §2) a mesh is on. Within one branch the
    mesh force and the spring deflection f(δ) are smooth functions of the state; the
    law jumps or kinks only where a mesh changes branch, so the integrator locates those
    changes (:mod:`screwgear_ros.numerics.integrator`) and integrates each branch on its own."""

    GAP = 0               # |δ| ≤ b: no contact, F = 0, f = 0
    FORWARD = 1           # δ > b on the forward flank: F = K·(δ − b) + c·δ̇ > 0
    REVERSE = 2           # δ < −b on the reverse flank: F = K·(δ + b) + c·δ̇ < 0
    FORWARD_LIFTING = 3   # δ > b, the flank separating faster than the damper lets it push:
    REVERSE_LIFTING = 4   #   F = 0 (the force never pulls), f = δ ∓ b
    LINEAR = 5            # b = 0: F = K·δ + c·δ̇ at every δ, one branch
    DISENGAGED = 6        # mesh 3 in `conventional` mode: no force ever
    FROM_STATE = -1       # not a branch: the contact law picks it from the state


class DrivePiece(IntEnum):
    """Which piece of the drive's torque–speed line (the smaller of the command and
    T_s·(1 − ω/ω_nl), :func:`drive_piece`) delivers the torque: the delivered torque is smooth on each and kinks where the
    command meets the line, so the integrator locates that too."""

    COMMAND = 0           # the command itself (below the line, no command, ideal source)
    LINE = 1              # the line T_s·(1 − ω/ω_nl), below the command
    FROM_STATE = -1       # not a piece: picked from the speed


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


class PackedModel(NamedTuple):
    """What the compiled code needs: packed scalars and the STE harmonic arrays. A tuple,
    so the kernels take it whole."""

    p: np.ndarray          # float64[N_PACKED]
    ste_amp: np.ndarray    # ε_n, m
    ste_phase: np.ndarray  # ϕ_n, rad


class Drive(NamedTuple):
    """The input as the compiled code takes it: drive torque T ≥ 0 (N·m), direction ±1,
    table load T_load (N·m), all floats."""

    torque: float
    direction: float
    load: float


def pack(params: TableParams) -> PackedModel:
    """Pack validated parameters for the compiled model."""
    p = np.zeros(N_PACKED)
    p[:len(KERNEL)] = [getattr(params, name) for name in KERNEL]
    p[K_EFF] = effective_stiffness(params)
    p[MODE] = MODE_CONVENTIONAL if params.mode is Mode.CONVENTIONAL else MODE_ANTI_BACKLASH
    p[PHASE] = PHASE_TIME if params.mesh_phase is MeshPhase.TIME else PHASE_ANGLE
    p[FORMULATION] = (FORM_ENERGY if params.mesh_formulation is MeshFormulation.ENERGY_CONSISTENT
                      else FORM_PAPER)
    return PackedModel(p, np.array(params.ste_amplitudes, dtype=np.float64),
                       np.array(params.ste_phases, dtype=np.float64))


@kernel
def mesh_phase(theta_pinion: float, omega_pinion: float, teeth: float, t: float,
               p: np.ndarray) -> tuple[float, float]:
    """Mesh phase φ (rad) and its rate φ̇ (rad/s): z·θ (`angle`) or ω_e·t (`time`)."""
    if p[PHASE] == PHASE_TIME:
        return p[WE] * t, p[WE]
    return teeth * theta_pinion, teeth * omega_pinion


@kernel
def static_transmission_error(phi: float, ste_amp: np.ndarray,
                              ste_phase: np.ndarray) -> tuple[float, float]:
    """ε(φ) = Σ ε_n·sin(n·φ + ϕ_n), m, and its derivative dε/dφ, m/rad."""
    eps = 0.0
    deps = 0.0
    for n in range(ste_amp.shape[0]):
        arg = (n + 1) * phi + ste_phase[n]
        eps += ste_amp[n] * math.sin(arg)
        deps += ste_amp[n] * (n + 1) * math.cos(arg)
    return eps, deps


@kernel
def mesh_stiffness(phi: float, p: np.ndarray) -> float:
    """K(φ) = k_eff + k_a·cos(φ + ϕ_k), N/m."""
    return p[K_EFF] + p[K_A] * math.cos(phi + p[PHI_K])


@kernel
def contact_branch(delta: float, delta_dot: float, stiffness: float, damping: float,
                   backlash: float) -> ContactBranch:
    """The branch of the contact law a mesh is on at total transmission error δ (m) and
    rate δ̇ (m/s): b = 0 is linear; b > 0: the gap for |δ| ≤ b, else the flank while
    the spring and damper push (K·(δ ∓ b) + c·δ̇ away from the gap), lifting off when
    they would pull.
    """
    if backlash <= 0.0:
        return ContactBranch.LINEAR
    if delta > backlash:
        if stiffness * (delta - backlash) + damping * delta_dot > 0.0:
            return ContactBranch.FORWARD
        return ContactBranch.FORWARD_LIFTING
    if delta < -backlash:
        if stiffness * (delta + backlash) + damping * delta_dot < 0.0:
            return ContactBranch.REVERSE
        return ContactBranch.REVERSE_LIFTING
    return ContactBranch.GAP


@kernel
def branch_force(branch: ContactBranch, delta: float, delta_dot: float, stiffness: float,
                 damping: float, backlash: float) -> float:
    """Mesh force F, N, on a given branch of the contact law (smooth in the state)."""
    if branch == ContactBranch.FORWARD:
        return stiffness * (delta - backlash) + damping * delta_dot
    if branch == ContactBranch.REVERSE:
        return stiffness * (delta + backlash) + damping * delta_dot
    if branch == ContactBranch.LINEAR:
        return stiffness * delta + damping * delta_dot
    return 0.0


@kernel
def mesh_force(delta: float, delta_dot: float, stiffness: float, damping: float,
               backlash: float) -> float:
    """Mesh force F along the line of action, N, for total transmission error δ (m).

    b = 0: F = K·δ + c·δ̇. b > 0: no contact for |δ| ≤ b; in contact the spring acts
    on the penetration, damping only while in contact, and the force never pulls
    (Modelica's ElastoBacklash law): :func:`branch_force` on the
    :func:`contact_branch` of the state.
    """
    return branch_force(contact_branch(delta, delta_dot, stiffness, damping, backlash),
                        delta, delta_dot, stiffness, damping, backlash)


@kernel
def mesh_motion(theta_pinion: float, omega_pinion: float, radius_pinion: float, teeth: float,
                theta2: float, omega2: float, t: float, model: PackedModel
                ) -> tuple[float, float, float, float, float]:
    """Mesh phase φ (rad), STE slope dε/dφ (m/rad), δ (m), δ̇ (m/s) and stiffness K
    (N/m) of one mesh: what its force depends on."""
    p = model.p
    phi, phi_dot = mesh_phase(theta_pinion, omega_pinion, teeth, t, p)
    eps, deps = static_transmission_error(phi, model.ste_amp, model.ste_phase)
    delta = radius_pinion * theta_pinion - p[R2] * theta2 - eps
    delta_dot = radius_pinion * omega_pinion - p[R2] * omega2 - deps * phi_dot
    return phi, deps, delta, delta_dot, mesh_stiffness(phi, p)


@kernel
def branch_penetration(branch: ContactBranch, delta: float, backlash: float) -> float:
    """f(δ), m, on a given branch: δ (linear), δ ∓ b on or lifting off a flank, 0 in
    the gap (on the branch :func:`contact_branch` gives, the spring's deflection at δ)."""
    if branch == ContactBranch.FORWARD or branch == ContactBranch.FORWARD_LIFTING:
        return delta - backlash
    if branch == ContactBranch.REVERSE or branch == ContactBranch.REVERSE_LIFTING:
        return delta + backlash
    if branch == ContactBranch.LINEAR:
        return delta
    return 0.0


@kernel
def mesh_stiffness_slope(phi: float, p: np.ndarray) -> float:
    """dK/dφ = −k_a·sin(φ + ϕ_k), N/m per rad."""
    return -p[K_A] * math.sin(phi + p[PHI_K])


@kernel
def mesh_load_on(theta_pinion: float, omega_pinion: float, radius_pinion: float, teeth: float,
                 theta2: float, omega2: float, t: float, model: PackedModel,
                 branch: ContactBranch) -> tuple[float, float, ContactBranch]:
    """Mesh force F (N, on the table: r2·F) and the torque Q (N·m) the mesh exerts
    against its pinion (I·θ̈ = T − Q), per ``mesh_formulation``, on contact ``branch``
    (ContactBranch.FROM_STATE: the branch the contact law picks), and that branch.

    `paper`, and both formulations in `time` phase: Q = r·F (model.md §3).
    `energy_consistent` in `angle` phase (φ = z·θ), from the potential ½·K(φ)·f(δ)²
    (docs/model_notes.md §9): Q = (r − z·ε'(φ))·F + ½·z·K'(φ)·f(δ)², F the contact
    force of :func:`mesh_force` (spring and contact damping) acting along ∂δ/∂θ.
    """
    p = model.p
    phi, deps, delta, delta_dot, stiffness = mesh_motion(
        theta_pinion, omega_pinion, radius_pinion, teeth, theta2, omega2, t, model)
    if branch == ContactBranch.FROM_STATE:
        branch = contact_branch(delta, delta_dot, stiffness, p[C], p[B])
    force = branch_force(branch, delta, delta_dot, stiffness, p[C], p[B])
    if p[FORMULATION] != FORM_ENERGY or p[PHASE] == PHASE_TIME:
        return force, radius_pinion * force, branch
    f = branch_penetration(branch, delta, p[B])
    return force, ((radius_pinion - teeth * deps) * force
                   + 0.5 * teeth * mesh_stiffness_slope(phi, p) * f * f), branch


@kernel
def drive_piece(torque: float, speed: float, p: np.ndarray) -> DrivePiece:
    """The piece of the drive's torque–speed line that delivers command ``torque`` at
    the active pinion's ``speed`` (rad/s, positive in the sense it drives): the smaller of
    the command and T_s·(1 − ω/ω_nl), which falls to zero at the no-load speed ω_nl and
    brakes beyond it. A zero command is a drive switched off; ω_nl = 0: the command itself
    (ideal torque source)."""
    if p[WNL] <= 0.0 or torque <= 0.0:
        return DrivePiece.COMMAND
    return DrivePiece.COMMAND if torque <= p[TS] * (1.0 - speed / p[WNL]) else DrivePiece.LINE


@kernel
def drive_on(piece: DrivePiece, torque: float, speed: float, p: np.ndarray) -> float:
    """Drive torque delivered, N·m, on a given piece of the drive's line (:func:`drive_piece`)."""
    if piece == DrivePiece.LINE:
        return p[TS] * (1.0 - speed / p[WNL])
    return torque


@kernel
def active_speed(w1: float, w3: float, direction: float, p: np.ndarray) -> float:
    """Speed of the driving pinion in the sense it drives, rad/s: d·ω1 (`conventional`),
    ω1 (path 1) or −ω3 (path 3, `anti_backlash`)."""
    if p[MODE] == MODE_CONVENTIONAL:
        return direction * w1
    return w1 if direction > 0.0 else -w3


@kernel
def applied_torques(t: float, w1: float, w3: float, torque: float, direction: float,
                    p: np.ndarray) -> tuple[float, float]:
    """Torques (T1, T3) on pinions 1 and 3, N·m, with the drive's torque–speed line:
    :func:`drive_torques` of the torque the drive's line delivers (:func:`drive_piece`)."""
    return applied_torques_on(DrivePiece.FROM_STATE, t, w1, w3, torque, direction, p)[:2]


@kernel
def applied_torques_on(piece: DrivePiece, t: float, w1: float, w3: float, torque: float,
                       direction: float, p: np.ndarray) -> tuple[float, float, DrivePiece]:
    """:func:`applied_torques` with the drive on ``piece`` (DrivePiece.FROM_STATE: the
    piece the speed picks), and that piece."""
    speed = active_speed(w1, w3, direction, p)
    if piece == DrivePiece.FROM_STATE:
        piece = drive_piece(torque, speed, p)
    t1, t3 = drive_torques(t, drive_on(piece, torque, speed, p), direction, p)
    return t1, t3, piece


@kernel
def drive_torques(t: float, torque: float, direction: float,
                  p: np.ndarray) -> tuple[float, float]:
    """Torques (T1, T3) on pinions 1 and 3, N·m, for the commanded drive.

    The drive torque T + T_v·sin(ω_v·t) acts on the active pinion. `anti_backlash`:
    T1 = T_p (+ drive if d = +1), T3 = −T_p (− drive if d = −1). `conventional`:
    T1 = d·drive, T3 = 0.
    """
    drive = torque if p[TV] == 0.0 else torque + p[TV] * math.sin(p[WV] * t)
    if p[MODE] == MODE_CONVENTIONAL:
        return direction * drive, 0.0
    if direction > 0.0:
        return p[TP] + drive, -p[TP]
    return p[TP], -p[TP] - drive


@kernel
def drive_targets(piece: DrivePiece, w1: float, w3: float, torque: float, direction: float,
                  p: np.ndarray) -> tuple[float, float]:
    """What each drive's current loop is commanded (N·m, signed in the sense that drives
    the table forward, preload and fluctuation excluded): the torque the drive's line
    delivers on ``piece`` (:func:`drive_on`; a servo drive limits its torque reference by
    the speed) on the active pinion, 0 on the other."""
    delivered = drive_on(piece, torque, active_speed(w1, w3, direction, p), p)
    if p[MODE] == MODE_CONVENTIONAL:
        return direction * delivered, 0.0
    if direction > 0.0:
        return delivered, 0.0
    return 0.0, -delivered


@kernel
def lag_state(y: tuple) -> tuple[float, float]:
    """The drives' lagged torques L1, L3 (N·m) of state y: y[6], y[7], or 0 for a
    mechanical state alone (six entries; the length is known when the kernel compiles)."""
    if len(y) > 6:
        return y[6], y[7]
    return 0.0, 0.0


@kernel
def lag_rates(y: tuple, torque: float, direction: float, piece: DrivePiece,
              p: np.ndarray) -> tuple[float, float]:
    """dL1/dt, dL3/dt (N·m/s) of the lagged drive torques y[6], y[7]: (target − L)/τ_d
    toward :func:`drive_targets`; 0 with τ_d = 0 (no lag, the states unused)."""
    if p[TAU] == 0.0:
        return 0.0, 0.0
    m1, m3 = drive_targets(piece, y[3], y[5], torque, direction, p)
    lag1, lag3 = lag_state(y)
    return (m1 - lag1) / p[TAU], (m3 - lag3) / p[TAU]


@kernel
def lagged_torques(t: float, lag1: float, lag3: float, direction: float,
                   p: np.ndarray) -> tuple[float, float]:
    """(T1, T3), N·m, with τ_d > 0: the preload (the nuts', so not through the current
    loops) plus each drive's lagged torque L1, L3, and the fluctuation T_v·sin(ω_v·t) on
    the active pinion as :func:`drive_torques` adds it."""
    fluctuation = 0.0 if p[TV] == 0.0 else p[TV] * math.sin(p[WV] * t)
    if p[MODE] == MODE_CONVENTIONAL:
        return lag1 + direction * fluctuation, 0.0
    if direction > 0.0:
        return p[TP] + lag1 + fluctuation, -p[TP] + lag3
    return p[TP] + lag1, -p[TP] + lag3 - fluctuation


@kernel
def cogging(th1: float, th3: float, t1: float, t3: float,
            p: np.ndarray) -> tuple[float, float]:
    """(T1, T3) with each motor's cogging ripple T_cog·sin(n_cog·θ) added at its pinion
    angle θ: the magnets' pull, there with or without current, so on every pinion a motor
    drives (pinion 1 alone in `conventional` mode)."""
    t1 = t1 + p[TCOG] * math.sin(p[NCOG] * th1)
    if p[MODE] != MODE_CONVENTIONAL:
        t3 = t3 + p[TCOG] * math.sin(p[NCOG] * th3)
    return t1, t3


@kernel
def pinion_torques(piece: DrivePiece, t: float, y: tuple, torque: float, direction: float,
                   p: np.ndarray) -> tuple[float, float, DrivePiece]:
    """Torques (T1, T3), N·m, the drives apply to pinions 1 and 3 at state y with the
    drive's line on ``piece`` (FROM_STATE: the piece the speed picks), and that piece:
    τ_d = 0, :func:`applied_torques_on` of the command; τ_d > 0, the lagged torques y[6],
    y[7] (:func:`lagged_torques`); then the cogging ripple (:func:`cogging`)."""
    if p[TAU] == 0.0:
        t1, t3, piece = applied_torques_on(piece, t, y[3], y[5], torque, direction, p)
    else:
        lag1, lag3 = lag_state(y)
        t1, t3 = lagged_torques(t, lag1, lag3, direction, p)
        if piece == DrivePiece.FROM_STATE:
            piece = drive_piece(torque, active_speed(y[3], y[5], direction, p), p)
    if p[TCOG] != 0.0:
        t1, t3 = cogging(y[0], y[2], t1, t3, p)
    return t1, t3, piece


@kernel
def body_torques(t: float, y: tuple, model: PackedModel, drive: Drive, held: Pieces
                 ) -> tuple[float, float, float, float, float, float, float, ContactBranch,
                            ContactBranch, DrivePiece]:
    """The torque on each body from everything but its bearing friction at state y, the
    meshes on the contact branches and the drive on the piece of its line ``held`` names
    (FROM_STATE: the ones the contact law and the drive line pick at this state):

    τ1 = T1 − Q1 − c_p·θ̇1;  τ3 = T3 − Q3 − c_p·θ̇3;  τ2 = r2·(F1 + F3) − T_load − c_t·θ̇2,

    Q = r·F (`paper`) or the energy-consistent pinion load (:func:`mesh_load_on`); T1, T3
    those of :func:`pinion_torques` (through the drive's torque–speed line; lagged by the
    current loops; with cogging). In `conventional` mode pinion 3 is disengaged
    (F3 = Q3 = 0).

    Returns (τ1, τ2, τ3, T1, T3 in N·m, F1, F3 in N, branch of mesh 1, branch of mesh 3,
    drive piece).
    """
    p = model.p
    th1, th2, th3, w1, w2, w3 = y[0], y[1], y[2], y[3], y[4], y[5]
    t1, t3, piece = pinion_torques(held.drive, t, y, drive.torque, drive.direction, p)
    f1, q1, branch_1 = mesh_load_on(th1, w1, p[R1], p[Z1], th2, w2, t, model, held.branch_1)
    if p[MODE] == MODE_CONVENTIONAL:
        f3, q3, branch_3 = 0.0, 0.0, ContactBranch.DISENGAGED
    else:
        f3, q3, branch_3 = mesh_load_on(th3, w3, p[R3], p[Z3], th2, w2, t, model,
                                        held.branch_3)
    tau1 = t1 - q1
    tau3 = t3 - q3
    if p[CP] != 0.0:
        tau1 -= p[CP] * w1
        tau3 -= p[CP] * w3
    table = p[R2] * (f1 + f3) - drive.load - p[CT] * w2
    return tau1, table, tau3, t1, t3, f1, f3, branch_1, branch_3, piece


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
    p = model.p
    tau1, tau2, tau3, t1, t3, f1, f3, branch_1, branch_3, piece = body_torques(
        t, y, model, drive, held)
    friction_1, friction_2, friction_3 = held.friction_1, held.friction_2, held.friction_3
    if friction_1 == FrictionPiece.FROM_STATE:
        friction_1 = friction_piece(friction_1, y[3], tau1, p[TSP])
    if friction_2 == FrictionPiece.FROM_STATE:
        friction_2 = friction_piece(friction_2, y[4], tau2, p[TS2])
    if friction_3 == FrictionPiece.FROM_STATE:
        friction_3 = friction_piece(friction_3, y[5], tau3, p[TSP])
    a1 = friction_on(friction_1, y[3], tau1, p[I1], p[TCP], p[TSP], p[WSP])[0]
    a2, table_friction = friction_on(friction_2, y[4], tau2, p[I2], p[TC2], p[TS2], p[WS2])
    a3 = friction_on(friction_3, y[5], tau3, p[I3], p[TCP], p[TSP], p[WSP])[0]
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
    :func:`~screwgear_ros.params.table.ste_slope`), mesh and table damping included, and the
    drive's torque–speed line on every pinion it can drive (its slope −T_s/ω_nl acts as
    a damper on the driven pinion; :func:`drive_piece`) with the pinions' viscous bearing
    loss c_p. Bearing friction's Stribeck slope is left out (docs/model_notes.md §14).
    Generalized mesh directions: δ1 = r1·θ1 − r2·θ2, δ3 = r3·θ3 − r2·θ2 (mesh 3 only
    in `anti_backlash`). Its eigenvalues bound the step an explicit method can take."""
    k = effective_stiffness(params) + params.mesh_stiffness_amplitude
    lever_1 = params.radius_pinion_1 + ste_slope(params, '1')
    lever_3 = params.radius_pinion_3 + ste_slope(params, '3')
    inertia = np.array([params.inertia_pinion_1, params.inertia_table, params.inertia_pinion_3])
    g = np.array([[lever_1, -params.radius_table, 0.0], [0.0, -params.radius_table, lever_3]])
    drive = (params.drive_stall_torque / params.drive_no_load_speed
             if params.drive_no_load_speed > 0.0 else 0.0)
    driven = np.array([drive + params.pinion_damping, 0.0, drive + params.pinion_damping])
    if params.mode is Mode.CONVENTIONAL:
        g, driven[2] = g[:1], 0.0
    stiffness = k * g.T @ g
    damping = params.mesh_damping * g.T @ g + np.diag(driven + [0.0, params.table_damping, 0.0])
    m_inv = np.diag(1.0 / inertia)
    return np.block([[np.zeros((3, 3)), np.eye(3)], [-m_inv @ stiffness, -m_inv @ damping]])


def active_path(mode: Mode, direction: int) -> int:
    """Drive path carrying the commanded torque: 1 (forward) or 3 (reverse, anti-backlash)."""
    return 3 if Mode(mode) is Mode.ANTI_BACKLASH and direction < 0 else 1


class EquilibriumNotFound(ArithmeticError):
    """Newton's method found no static equilibrium: ``what`` was solved for, the last
    Newton ``step`` and ``residual`` after ``iterations`` iterations."""

    def __init__(self, what: str, iterations: int, step: float, residual: float):
        self.what, self.iterations, self.step, self.residual = what, iterations, step, residual
        super().__init__(f'no static equilibrium found: {what} did not converge in '
                         f'{iterations} Newton iterations (last step {step:.3g}, residual '
                         f'{residual:.3g})')

    def __reduce__(self):
        return (EquilibriumNotFound, (self.what, self.iterations, self.step, self.residual))


#: Newton iterations allowed for a pinion's equilibrium angle (it takes 3–6), either
#: formulation.
NEWTON_ITERATIONS = 100


def _pinion_angle_for(delta_target_sign: float, radius: float, teeth: float,
                      model: PackedModel) -> float:
    """Pinion angle θ (rad) with θ2 = 0 at which the mesh sits at its preload equilibrium.

    Solves g(θ) = r·θ − ε(φ(θ)) − s·(b + T_p / (r·K(φ(θ)))) = 0 by Newton's method;
    φ = z·θ in `angle` phase, φ = 0 (t = 0) in `time` phase. Converged once a step is
    below 1e-17·max(1, |θ|), or, at the rounding floor, below 64 float spacings of the
    solution's scale; otherwise :class:`EquilibriumNotFound`.
    """
    p = model.p
    tp = p[TP] if p[MODE] == MODE_ANTI_BACKLASH else 0.0
    theta = delta_target_sign * p[B] / radius
    # |θ| the answer is made of: backlash, preload deflection and STE, over the radius
    scale = (p[B] + tp / (radius * (p[K_EFF] - p[K_A])) + float(np.sum(np.abs(model.ste_amp)))
             ) / radius
    step = g = math.nan
    for _ in range(NEWTON_ITERATIONS):
        angle_phase = p[PHASE] == PHASE_ANGLE
        phi = teeth * theta if angle_phase else 0.0
        dphi = teeth if angle_phase else 0.0
        eps, deps = static_transmission_error(phi, model.ste_amp, model.ste_phase)
        k = mesh_stiffness(phi, p)
        dk = mesh_stiffness_slope(phi, p) * dphi
        target = delta_target_sign * (p[B] + tp / (radius * k))
        dtarget = -delta_target_sign * tp * dk / (radius * k * k)
        g = radius * theta - eps - target
        dg = radius - deps * dphi - dtarget
        step = g / dg
        theta -= step
        if abs(step) <= 1e-17 * max(1.0, abs(theta)):
            return theta
    if abs(step) <= 64.0 * np.spacing(max(abs(theta), scale)):
        return theta
    flank = 'forward' if delta_target_sign > 0.0 else 'reverse'
    raise EquilibriumNotFound(f'the angle of the pinion resting on its {flank} flank',
                              NEWTON_ITERATIONS, step, g)


def _energy_pinion_angle(sign: float, radius: float, teeth: float, theta2: float,
                         theta: float, model: PackedModel) -> tuple[float, float]:
    """`energy_consistent`, `angle` phase: pinion angle θ (rad) at which the static mesh
    load Q = (r − z·ε')·K·f + ½·z·K'·f² holds the preload s·T_p at table angle θ2, by
    Newton's method from ``theta``; returns (θ, K·f), the static mesh force (N).

    With φ = z·θ, L = dδ/dθ = r − z·ε'(φ):
    dQ/dθ = −z²·ε''·K·f + K·L² + 2·z·K'·f·L + ½·z²·K''·f².
    """
    p, amp, phase = model.p, model.ste_amp, model.ste_phase
    n = np.arange(1, len(amp) + 1)
    for _ in range(NEWTON_ITERATIONS):
        phi = teeth * theta
        eps, deps = static_transmission_error(phi, amp, phase)
        d2eps = -float(np.sum(amp * n * n * np.sin(n * phi + phase)))
        k, dk = mesh_stiffness(phi, p), mesh_stiffness_slope(phi, p)
        d2k = -p[K_A] * math.cos(phi + p[PHI_K])
        f = radius * theta - p[R2] * theta2 - eps - sign * p[B]
        lever = radius - teeth * deps
        g = lever * k * f + 0.5 * teeth * dk * f * f - sign * p[TP]
        dg = (-teeth * teeth * d2eps * k * f + k * lever * lever + 2.0 * teeth * dk * f * lever
              + 0.5 * teeth * teeth * d2k * f * f)
        step = g / dg
        theta -= step
        if abs(step) <= 1e-15:     # quadratic convergence: θ is now at the rounding floor
            phi = teeth * theta
            f = radius * theta - p[R2] * theta2 - static_transmission_error(
                phi, amp, phase)[0] - sign * p[B]
            return theta, mesh_stiffness(phi, p) * f
    raise EquilibriumNotFound(f'the energy-consistent angle of the pinion of sign {sign:+g} '
                              f'at table angle {theta2!r} rad', NEWTON_ITERATIONS, step, g)


def _energy_equilibrium(params: TableParams, model: PackedModel,
                        paper: np.ndarray) -> np.ndarray:
    """Static equilibrium of the `energy_consistent` preloaded gear, `angle` phase.

    The potential ½·K(φ)·f(δ)² varies along a rigid rotation of the gear (through K and
    the STE lever), so the preload holds the table only at some angles ("cogging"): for
    each table angle θ2 both pinions are solved to hold ±T_p
    (:func:`_energy_pinion_angle`), and θ2 is moved, starting at 0 from the `paper`
    equilibrium, in the sense of the table torque r2·(F1 + F3) until that torque changes
    sign; bisection then finds the root, where the torque falls with θ2 (a stable rest).
    """
    r1, r3, z1, z3 = (params.radius_pinion_1, params.radius_pinion_3,
                      float(params.teeth_pinion_1), float(params.teeth_pinion_3))

    def solve(theta2: float, guess: tuple[float, float]) -> tuple[float, float, float]:
        th1, f1 = _energy_pinion_angle(1.0, r1, z1, theta2, guess[0], model)
        th3, f3 = _energy_pinion_angle(-1.0, r3, z3, theta2, guess[1], model)
        return th1, th3, f1 + f3

    tooth = 2.0 * math.pi / (z1 * params.radius_table / r1)    # table angle of one tooth
    lo, lo_state = 0.0, solve(0.0, (paper[0], paper[2]))
    if lo_state[2] == 0.0:        # a rest at θ2 = 0 (symmetric phases): is it stable?
        probe = solve(1e-6 * tooth, lo_state[:2])
        if probe[2] <= 0.0:
            return np.array([lo_state[0], 0.0, lo_state[1], 0.0, 0.0, 0.0])
        lo, lo_state = 1e-6 * tooth, probe
    sense = 1.0 if lo_state[2] > 0.0 else -1.0
    step = sense * tooth / 64.0
    for _ in range(4 * 64):
        hi = lo + step
        hi_state = solve(hi, lo_state[:2])
        if hi_state[2] * sense <= 0.0:
            break
        lo, lo_state = hi, hi_state
    else:
        raise EquilibriumNotFound('the rest angle of the energy-consistent preloaded table '
                                  '(no sign change of the table torque within 4 teeth)',
                                  4 * 64, step, lo_state[2])
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid in (lo, hi):
            break
        mid_state = solve(mid, lo_state[:2])
        if mid_state[2] * sense > 0.0:
            lo, lo_state = mid, mid_state
        else:
            hi, hi_state = mid, mid_state
    theta2, (th1, th3, _) = min(((lo, lo_state), (hi, hi_state)), key=lambda c: abs(c[1][2]))
    return np.array([th1, theta2, th3, 0.0, 0.0, 0.0])


def equilibrium_state(params: TableParams) -> np.ndarray:
    """Static equilibrium under the preload, everything at rest, θ2 = 0.

    `anti_backlash`: δ1 = b + T_p/(r1·K1), δ3 = −b − T_p/(r3·K3) with K at the
    starting mesh phase. `conventional`: no preload, mesh 1 touching its forward
    flank (δ1 = b, F1 = 0), pinion 3 idle at δ3 = −b. `energy_consistent` with a
    preload in `angle` phase: the nearest stable rest of :func:`_energy_equilibrium`
    (θ2 ≠ 0 in general).
    """
    model = pack(params)
    th1 = _pinion_angle_for(1.0, params.radius_pinion_1, params.teeth_pinion_1, model)
    th3 = _pinion_angle_for(-1.0, params.radius_pinion_3, params.teeth_pinion_3, model)
    state = np.array([th1, 0.0, th3, 0.0, 0.0, 0.0])
    if (params.mesh_formulation is MeshFormulation.ENERGY_CONSISTENT
            and params.mode is Mode.ANTI_BACKLASH and params.mesh_phase is MeshPhase.ANGLE
            and params.preload_torque > 0.0):
        return _energy_equilibrium(params, model, state)   # θ2 ≠ 0 in general
    return state


__all__ = [
    'BY_LAW',
    'CP',
    'CT',
    'FORMULATION',
    'FORM_ENERGY',
    'FORM_PAPER',
    'I1',
    'I2',
    'I3',
    'K_A',
    'K_EFF',
    'MODE',
    'MODE_ANTI_BACKLASH',
    'MODE_CONVENTIONAL',
    'NCOG',
    'NEWTON_ITERATIONS',
    'N_MECHANICAL',
    'N_PACKED',
    'N_STATE',
    'PHASE',
    'PHASE_ANGLE',
    'PHASE_TIME',
    'PHI_K',
    'R1',
    'R2',
    'R3',
    'TAU',
    'TC2',
    'TCOG',
    'TCP',
    'TP',
    'TS',
    'TS2',
    'TSP',
    'TV',
    'WE',
    'WNL',
    'WS2',
    'WSP',
    'WV',
    'Z1',
    'Z3',
    'B',
    'C',
    'ContactBranch',
    'Drive',
    'DrivePiece',
    'EquilibriumNotFound',
    'PackedModel',
    'Pieces',
    'active_path',
    'active_speed',
    'applied_torques',
    'applied_torques_on',
    'body_torques',
    'branch_force',
    'branch_penetration',
    'cogging',
    'contact_branch',
    'contact_branches',
    'drive_on',
    'drive_piece',
    'drive_targets',
    'drive_torques',
    'equilibrium_state',
    'friction_pieces',
    'lag_rates',
    'lag_state',
    'lagged_torques',
    'mesh_force',
    'mesh_load_on',
    'mesh_motion',
    'mesh_phase',
    'mesh_stiffness',
    'mesh_stiffness_slope',
    'motion',
    'outputs',
    'pack',
    'pieces',
    'pinion_torques',
    'rhs',
    'rhs_vector',
    'state_rate',
    'static_transmission_error',
    'stiffest_linearization',
]
