"""Floquet analysis of the normalized equation (model.md §7).

The homogeneous equation x'' + 2ζ·x' + [κ + k_a'·cos(Ωτ + ϕ_k)]·x = 0 is linear
with period T = 2π/Ω. Its monodromy matrix M maps (x, x') at τ = 0 to τ = T; its
eigenvalues μ (the Floquet multipliers) decide stability exactly: every solution
decays when max |μ| < 1. M is found by integrating the fundamental matrix (the
solutions from (1, 0) and (0, 1)) over one period with RK4 (:func:`screwgear_ros.numerics.rk.step`
on :func:`screwgear_ros.paper.normalized.rhs`, forcing set to zero) in a compiled kernel,
parallel over any grid of (ζ, k_a', Ω, κ, ϕ_k). Liouville's formula gives
det M = exp(−2ζT) exactly, a check on the integration.

The same M gives the periodic steady state of the forced equation when the
forcing has period T: y_p(0) = (I − M)⁻¹·y_f(T), with y_f the response from rest.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit, prange, set_parallel_chunksize
from tqdm import tqdm

from ..numerics import rk
from ..physics.jit import OPTIONS, inline_kernel
from . import normalized
from .batch import Coefficients, integrate

_OPTIONS: dict[str, Any] = dict(OPTIONS)
_UNCACHED: dict[str, Any] = {**OPTIONS, 'cache': False}

#: Default largest step in τ: 0.05 of the unit natural period 2π (~126 steps per
#: natural period; RK4 error over a period ~1e-7).
MAX_STEP = 0.05


def steps_per_period(omega: np.ndarray | float, max_step: float = MAX_STEP) -> int:
    """Steps per mesh period 2π/Ω so that no step exceeds ``max_step`` (at least 64)."""
    period = 2.0 * math.pi / float(np.min(omega))
    return max(64, math.ceil(period / max_step))


#: :func:`normalized.rhs` itself (its Python source), compiled to be inlined here, so that
#: the compiler sees equal cos(Ωτ + ϕ_k) calls: one for both solutions at a stage time,
#: one for stages 1 and 2 of a step (both at τ + Δτ/2). 3 cosines a step instead of 8.
#: Not cached: it has normalized.rhs's source and name, whose cache entries it would share.
_rhs = njit(inline='always', **_UNCACHED)(
    getattr(normalized.rhs, 'py_func', normalized.rhs))     # plain with NUMBA_DISABLE_JIT=1


@inline_kernel
def _fundamental_slope(tau: float, y: tuple[float, float, float, float],
                       args: tuple) -> tuple[float, float, float, float]:
    """d/dτ of two solutions of the equation side by side, y = (x, x', x̃, x̃'):
    :func:`normalized.rhs` for each; args = (c, fa, phases) as there."""
    dx, dv = _rhs(tau, y[0], y[1], args[0], args[1], args[2])
    dx2, dv2 = _rhs(tau, y[2], y[3], args[0], args[1], args[2])
    return dx, dv, dx2, dv2


#: Grid points a thread takes at a time (dynamic scheduling: on a shared machine a thread
#: whose core is busy takes fewer chunks instead of holding up the others).
_THREAD_CHUNK = 16


@njit(parallel=True, **_OPTIONS)
def _monodromy_kernel(coefficients: np.ndarray, n_steps: int, out: np.ndarray) -> None:
    """out[i] = M of the homogeneous equation with the packed coefficients
    ``coefficients[i]`` (:data:`normalized.KERNEL` layout, forcing zero): ``n_steps``
    RK4 steps over the period 2π/Ω, step k from τ = k·Δτ, parallel over i."""
    no_harmonics = np.zeros(0)
    for i in prange(coefficients.shape[0]):
        c = coefficients[i]
        dtau = 2.0 * math.pi / c[normalized.OMEGA] / n_steps
        args = (c, no_harmonics, no_harmonics)
        y = (1.0, 0.0, 0.0, 1.0)
        for k in range(n_steps):
            y = rk.step(_fundamental_slope, k * dtau, y, dtau, args)
        out[i, 0, 0] = y[0]
        out[i, 1, 0] = y[1]
        out[i, 0, 1] = y[2]
        out[i, 1, 1] = y[3]


#: Grid points per kernel call when a progress bar is shown.
_PROGRESS_CHUNK = 2048


def monodromy(zeta: np.ndarray | float, ka: np.ndarray | float, omega: np.ndarray | float,
              kappa: np.ndarray | float = 1.0, phase: np.ndarray | float = 0.0,
              steps: int | None = None, max_step: float = MAX_STEP,
              progress: str | None = None) -> np.ndarray:
    """Monodromy matrices M, shape (..., 2, 2), over the broadcast shape of the inputs.

    ζ = damping ratio, k_a' = stiffness fluctuation, Ω > 0 = frequency ratio (period
    2π/Ω), κ = mean stiffness ratio, ϕ_k = stiffness phase (rad). ``steps`` RK4 steps
    per period for every set (default: :func:`steps_per_period` for the smallest Ω).
    Column j of M is the state after one period from the unit state e_j.
    ``progress`` names a tqdm bar over the grid points (None = no bar).
    """
    arrays = np.broadcast_arrays(*(np.asarray(a, dtype=np.float64)
                                   for a in (zeta, ka, omega, kappa, phase)))
    shape = arrays[0].shape
    flat = [a.reshape(-1) for a in arrays]
    if np.any(flat[2] <= 0.0):
        raise ValueError('the frequency ratio Ω must be > 0 (period 2π/Ω)')
    n_steps = steps if steps is not None else steps_per_period(flat[2], max_step)
    if n_steps < 1:
        raise ValueError(f'need at least one step per period, not {n_steps}')
    n = flat[0].size
    packed = np.zeros((n, len(normalized.KERNEL)))     # mean load, load fluctuation: 0
    for index, values in zip((normalized.ZETA, normalized.KA, normalized.OMEGA,
                              normalized.KAPPA, normalized.PHI_K), flat, strict=True):
        packed[:, index] = values
    m = np.empty((n, 2, 2))
    chunk = n if progress is None else _PROGRESS_CHUNK
    previous = set_parallel_chunksize(_THREAD_CHUNK)
    try:
        with tqdm(total=n, desc=progress, unit='point', leave=False,
                  disable=progress is None, mininterval=0.5) as bar:
            for start in range(0, n, max(chunk, 1)):
                stop = min(n, start + chunk)
                _monodromy_kernel(packed[start:stop], n_steps, m[start:stop])
                bar.update(stop - start)
    finally:
        set_parallel_chunksize(previous)
    return m.reshape(shape + (2, 2))


def multipliers(m: np.ndarray) -> np.ndarray:
    """Floquet multipliers μ (complex, shape (..., 2)) of monodromy matrices M (..., 2, 2)."""
    return np.linalg.eigvals(m)


def spectral_radius(m: np.ndarray) -> np.ndarray:
    """max |μ| of each monodromy matrix: < 1 stable, > 1 unstable."""
    return np.max(np.abs(multipliers(m)), axis=-1)


def growth_rate(m: np.ndarray, omega: np.ndarray | float) -> np.ndarray:
    """Largest Floquet exponent ln(max |μ|)/T per unit τ (T = 2π/Ω); −ζ when k_a' = 0."""
    return np.log(spectral_radius(m)) * np.asarray(omega) / (2.0 * math.pi)


def periodic_state(c: Coefficients, steps: int | None = None,
                   max_step: float = MAX_STEP) -> tuple[np.ndarray, np.ndarray]:
    """(x, x') at τ = 0 of the T-periodic steady response of each forced set, T = 2π/Ω.

    Needs forcing of period T: f_v = 0 or Ω_v a whole multiple of Ω. Solves
    y_p(0) = M·y_p(0) + y_f(T), y_f = the response from rest over one period.
    """
    omega = c.frequency_ratio
    if np.any(omega <= 0.0):
        raise ValueError('the frequency ratio Ω must be > 0 for a periodic steady state')
    ratio = c.load_fluctuation_frequency / omega
    periodic = (c.load_fluctuation_amplitude == 0.0) | (
        np.abs(ratio - np.round(ratio)) < 1e-9)
    if not np.all(periodic):
        raise ValueError('the load fluctuation frequency Ω_v must be a multiple of Ω')
    n_steps = steps if steps is not None else steps_per_period(omega, max_step)
    m = monodromy(c.damping_ratio, c.stiffness_fluctuation, omega, c.stiffness_ratio,
                  c.stiffness_phase, steps=n_steps)
    zero = np.zeros(len(c))
    _, xs, vs = integrate(c, n_steps, 2.0 * math.pi / omega / n_steps, stride=n_steps,
                          keep_from=n_steps, x0=zero, v0=zero)
    rhs = np.stack([xs[-1], vs[-1]], axis=-1)[..., None]
    y0 = np.linalg.solve(np.eye(2) - m, rhs)[..., 0]
    return y0[:, 0], y0[:, 1]


__all__ = [
    'MAX_STEP',
    'growth_rate',
    'monodromy',
    'multipliers',
    'periodic_state',
    'spectral_radius',
    'steps_per_period',
]
