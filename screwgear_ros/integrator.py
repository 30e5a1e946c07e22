"""Fixed-step classical RK4 over the 3-DOF model: the node's hot loop.

:func:`advance` integrates ``n`` steps of ``dt`` seconds in one compiled call on six
scalars, with no allocation per step. Time is never accumulated: step k starts at
t = (step0 + k)·dt, so long runs do not drift and a run is reproducible from the
integer step at which each input took effect. The input (torque, direction, load)
is constant over a call; it changes only at step boundaries.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .model import rhs


@njit(cache=True, error_model="numpy")
def advance(state: np.ndarray, step0: int, n: int, dt: float, p: np.ndarray,
            ste_amp: np.ndarray, ste_phase: np.ndarray, torque: float, direction: float,
            load: float) -> None:
    """Advance ``state`` (θ1, θ2, θ3 in rad, ω1, ω2, ω3 in rad/s) in place by n RK4 steps.

    Step k runs from t = (step0 + k)·dt to (step0 + k + 1)·dt, s.
    """
    y0, y1, y2, y3, y4, y5 = state[0], state[1], state[2], state[3], state[4], state[5]
    h = 0.5 * dt
    for k in range(n):
        t = (step0 + k) * dt
        a0, a1, a2, a3, a4, a5 = rhs(t, y0, y1, y2, y3, y4, y5, p, ste_amp, ste_phase,
                                     torque, direction, load)
        b0, b1, b2, b3, b4, b5 = rhs(t + h, y0 + h * a0, y1 + h * a1, y2 + h * a2,
                                     y3 + h * a3, y4 + h * a4, y5 + h * a5,
                                     p, ste_amp, ste_phase, torque, direction, load)
        c0, c1, c2, c3, c4, c5 = rhs(t + h, y0 + h * b0, y1 + h * b1, y2 + h * b2,
                                     y3 + h * b3, y4 + h * b4, y5 + h * b5,
                                     p, ste_amp, ste_phase, torque, direction, load)
        d0, d1, d2, d3, d4, d5 = rhs(t + dt, y0 + dt * c0, y1 + dt * c1, y2 + dt * c2,
                                     y3 + dt * c3, y4 + dt * c4, y5 + dt * c5,
                                     p, ste_amp, ste_phase, torque, direction, load)
        s = dt / 6.0
        y0 += s * (a0 + 2.0 * (b0 + c0) + d0)
        y1 += s * (a1 + 2.0 * (b1 + c1) + d1)
        y2 += s * (a2 + 2.0 * (b2 + c2) + d2)
        y3 += s * (a3 + 2.0 * (b3 + c3) + d3)
        y4 += s * (a4 + 2.0 * (b4 + c4) + d4)
        y5 += s * (a5 + 2.0 * (b5 + c5) + d5)
    state[0], state[1], state[2], state[3], state[4], state[5] = y0, y1, y2, y3, y4, y5


@njit(cache=True, error_model="numpy")
def trajectory(state: np.ndarray, step0: int, dt: float, stride: int, out: np.ndarray,
               p: np.ndarray, ste_amp: np.ndarray, ste_phase: np.ndarray, torque: float,
               direction: float, load: float) -> None:
    """Advance ``state`` by ``out.shape[0]·stride`` steps, storing it every ``stride`` steps.

    ``out[j]`` is the state after (j + 1)·stride steps; ``state`` ends at the last row.
    """
    for j in range(out.shape[0]):
        advance(state, step0 + j * stride, stride, dt, p, ste_amp, ste_phase,
                torque, direction, load)
        out[j, :] = state


__all__ = ['advance', 'trajectory']
