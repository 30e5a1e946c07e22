"""RK4's stability on the linearized model: the largest stable step, and the check that
refuses a larger one.

It sits above :mod:`screwgear_ros.physics.motion` (it linearizes the model), so that the parameter
types below the model stay free of it.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..params.table import ParameterError, TableParams, effective_stiffness
from ..physics.motion import stiffest_linearization
from .rk import amplification


def rk4_amplification(z: complex | np.ndarray) -> complex | np.ndarray:
    """RK4's amplification factor R(z) = 1 + z + z²/2 + z³/6 + z⁴/24 for z = λ·dt
    (:func:`screwgear_ros.numerics.rk.amplification`)."""
    return amplification(z)


@lru_cache(maxsize=16)
def max_stable_dt(p: TableParams) -> float:
    """Largest dt, s, for which RK4 is stable on the linearized 3-DOF model.

    Takes every eigenvalue λ of the model linearized at its stiffest
    (:func:`screwgear_ros.physics.motion.stiffest_linearization`) and bisects dt on
    max |R(λ·dt)| ≤ 1. Remembered per parameter set (an eigenvalue problem and a
    bisection are too slow for the real-time thread): the node validates a change on its
    executor thread, and the plant that takes the change on
    the pacing thread finds the answer ready.
    """
    lam = np.linalg.eigvals(stiffest_linearization(p))
    lam = lam[np.abs(lam) > 1e-6 * np.max(np.abs(lam))]  # drop the rigid-body mode
    if p.drive_time_constant > 0.0:        # each current loop: dL/dt = −L/τ_d + ...
        lam = np.append(lam, -1.0 / p.drive_time_constant)

    def stable(dt: float) -> bool:
        return bool(np.all(np.abs(rk4_amplification(lam * dt)) <= 1.0 + 1e-12))

    lo, hi = 0.0, 10.0 / float(np.max(np.abs(lam)))
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    return lo


def check_step(p: TableParams, dt: float) -> None:
    """Refuse a step dt, s, that RK4 cannot integrate stably at this stiffness (and drive
    time constant)."""
    limit = max_stable_dt(p)
    if dt > limit:
        raise ParameterError(
            'dt', dt, f'RK4 is unstable above dt = {limit:.4g} s at this stiffness '
            f'(k_eff + k_a = {effective_stiffness(p) + p.mesh_stiffness_amplitude:g} N/m'
            + (f', drive_time_constant {p.drive_time_constant:g} s'
               if p.drive_time_constant > 0.0 else '') + '); use a smaller step')


__all__ = ['check_step', 'max_stable_dt', 'rk4_amplification']
