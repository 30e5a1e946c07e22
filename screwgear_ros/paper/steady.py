"""Steady state and transient of forced normalized responses, for whole batches.

The steady state is the exact T-periodic solution (T = 2π/Ω) from the Floquet
monodromy (:func:`floquet.periodic_state`); the transient is the response minus
it, which for this linear equation is exactly the decaying free part.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from . import floquet
from .batch import Coefficients, concatenate, integrate
from .measures import half_range
from .normalized import NormalizedParams


def steps_for(c: Coefficients, samples: int) -> int:
    """RK4 steps per mesh period: a multiple of ``samples``, no step above floquet.MAX_STEP."""
    needed = floquet.steps_per_period(c.frequency_ratio)
    return samples * math.ceil(needed / samples)


@dataclass(frozen=True)
class SteadyPeriod:
    """One period of the periodic steady state, ``samples`` points without the end point."""

    phase: np.ndarray   # τ/T in [0, 1), (samples,)
    x: np.ndarray       # (samples, N)
    v: np.ndarray       # (samples, N)
    closure: float      # max |x(T) − x(0)| over the sets: the state is periodic


def steady_period(c: Coefficients, samples: int = 512) -> SteadyPeriod:
    """The periodic steady state of every set over one period 2π/Ω."""
    n_steps = steps_for(c, samples)
    x0, v0 = floquet.periodic_state(c, steps=n_steps)
    _, x, v = integrate(c, n_steps, 2.0 * math.pi / c.frequency_ratio / n_steps,
                        stride=n_steps // samples, x0=x0, v0=v0)
    closure = float(np.max(np.abs(x[-1] - x[0])))
    return SteadyPeriod(np.arange(samples) / samples, x[:-1], v[:-1], closure)


@dataclass(frozen=True)
class Transient:
    """Response from the sets' own initial state, its steady state, and the difference."""

    tau: np.ndarray        # (m,)
    x: np.ndarray          # (m, N)
    v: np.ndarray          # (m, N)
    steady_x: np.ndarray   # (m, N)
    steady_v: np.ndarray   # (m, N)

    @property
    def transient(self) -> np.ndarray:
        return self.x - self.steady_x


def transient(c: Coefficients, tau_end: float, sample_step: float = 0.05,
              progress: str | None = None) -> Transient:
    """Response and steady state of every set (same Ω for all) from τ = 0 to ``tau_end``."""
    omega = float(c.frequency_ratio[0])
    if np.any(c.frequency_ratio != omega):
        raise ValueError('transient() needs one frequency ratio Ω for the whole batch')
    period = 2.0 * math.pi / omega
    per_sample = max(1, math.ceil(sample_step / floquet.MAX_STEP))
    samples = math.ceil(period / (per_sample * floquet.MAX_STEP))
    n_steps = samples * per_sample
    x0, v0 = floquet.periodic_state(c, steps=n_steps)
    both = concatenate([c, c])
    n = len(c)
    total = per_sample * math.ceil(tau_end / (period / samples))
    tau, x, v = integrate(both, total, period / n_steps, stride=per_sample,
                          x0=np.concatenate([c.initial_displacement, x0]),
                          v0=np.concatenate([c.initial_velocity, v0]), progress=progress)
    return Transient(tau, x[:, :n], v[:, :n], x[:, n:], v[:, n:])




@dataclass(frozen=True)
class SteadyMap:
    """Steady-state measures over a (ζ, k_a') grid, arrays of shape (len(zetas), len(kas))."""

    zetas: np.ndarray
    kas: np.ndarray
    mean: np.ndarray
    amplitude: np.ndarray   # (max − min)/2
    thd: np.ndarray         # total harmonic distortion


@lru_cache(maxsize=4)
def steady_map(zetas: tuple[float, ...], kas: tuple[float, ...],
               samples: int = 256) -> SteadyMap:
    """Periodic steady state of the paper's normalized case over ζ × k_a' (cached)."""
    c, shape = Coefficients.grid(NormalizedParams(), damping_ratio=np.array(zetas),
                                 stiffness_fluctuation=np.array(kas))
    sp = steady_period(c, samples)
    spectrum = np.fft.rfft(sp.x, axis=0) / samples
    amplitudes = 2.0 * np.abs(spectrum[1:samples // 2])
    thd = np.sqrt(np.sum(amplitudes[1:] ** 2, axis=0)) / amplitudes[0]
    return SteadyMap(np.array(zetas), np.array(kas), spectrum[0].real.reshape(shape),
                     half_range(sp.x).reshape(shape), thd.reshape(shape))


__all__ = [
    'SteadyMap',
    'SteadyPeriod',
    'Transient',
    'steady_map',
    'steady_period',
    'steps_for',
    'transient',
]
