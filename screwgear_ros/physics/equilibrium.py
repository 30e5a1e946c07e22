"""The static equilibrium of the preloaded gear at rest (:func:`equilibrium_state`), by
Newton's method on the mesh law (:mod:`.mesh`), and :class:`EquilibriumNotFound` when it
does not converge.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ScrewgearError
from ..params.table import MeshFormulation, MeshPhase, Mode, TableParams
from .mesh import mesh_stiffness, mesh_stiffness_slope, static_transmission_error
from .packed import (
    K_A,
    K_EFF,
    MODE,
    MODE_ANTI_BACKLASH,
    PHASE,
    PHASE_ANGLE,
    PHI_K,
    R2,
    TP,
    B,
    PackedModel,
    pack,
)


class EquilibriumNotFound(ScrewgearError, ArithmeticError):
    """Newton's method found no static equilibrium: ``what`` was solved for, the last
    Newton ``step`` and ``residual`` after ``iterations`` iterations."""

    def __init__(self, what: str, iterations: int, step: float, residual: float):
        self.what, self.iterations, self.step, self.residual = what, iterations, step, residual
        super().__init__(f'no static equilibrium found: {what} did not converge in '
                         f'{iterations} Newton iterations (last step {step:.3g}, residual '
                         f'{residual:.3g})')

    def __reduce__(self) -> tuple[type[EquilibriumNotFound], tuple[str, int, float, float]]:
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
        # quadratic convergence: θ is now at the rounding floor (a few float spacings of
        # θ where θ is large, which 1e-15 alone would not reach on every CPU)
        if abs(step) <= max(1e-15, 4.0 * np.spacing(abs(theta))):
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
    'NEWTON_ITERATIONS',
    'EquilibriumNotFound',
    'equilibrium_state',
]
