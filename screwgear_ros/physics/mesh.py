"""The mesh law of ``shared/spec/model.md`` §2: mesh phase, static transmission error,
time-varying stiffness, the contact law with backlash and its branches, and the load a
mesh puts on its pinion in either formulation. Compiled kernels on the packed model
(:mod:`.packed`).
"""

from __future__ import annotations

import math
from enum import IntEnum

import numpy as np

from .jit import kernel
from .packed import (
    FORM_ENERGY,
    FORMULATION,
    K_A,
    K_EFF,
    PHASE,
    PHASE_TIME,
    PHI_K,
    R2,
    WE,
    B,
    C,
    PackedModel,
)


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


__all__ = [
    'ContactBranch',
    'branch_force',
    'branch_penetration',
    'contact_branch',
    'mesh_force',
    'mesh_load_on',
    'mesh_motion',
    'mesh_phase',
    'mesh_stiffness',
    'mesh_stiffness_slope',
    'static_transmission_error',
]
