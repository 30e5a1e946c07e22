"""Measurements on normalized responses: settling time, spectrum, distortion.

Pure functions on sampled signals (dimensionless τ and x), shared by the report
sections and checked by the tests against closed forms.
"""

from __future__ import annotations

import math

import numpy as np


def settling_time(tau: np.ndarray, transient: np.ndarray, fraction: float = 0.01) -> float:
    """τ after which |transient| stays below ``fraction`` of its initial size.

    The initial size is max |transient| over the first natural period (τ ≤ 2π);
    the answer is interpolated linearly at the last down-crossing of that level
    (τ[-1] if it is never crossed, 0 if never exceeded after τ = 0).
    """
    first = tau <= tau[0] + 2.0 * math.pi
    level = fraction * float(np.max(np.abs(transient[first])))
    above = np.nonzero(np.abs(transient) > level)[0]
    if above.size == 0:
        return float(tau[0])
    i = int(above[-1])
    if i == len(tau) - 1:
        return float(tau[-1])
    a, b = abs(transient[i]), abs(transient[i + 1])
    return float(tau[i] + (a - level) / (a - b) * (tau[i + 1] - tau[i]))


def first_overshoot(tau: np.ndarray, transient: np.ndarray) -> float:
    """The transient's first swing past zero, opposite to its start, within τ ≤ 2π."""
    first = tau <= tau[0] + 2.0 * math.pi
    sign = 1.0 if transient[0] >= 0.0 else -1.0
    return float(np.max(-sign * transient[first]))


def harmonics(period_samples: np.ndarray, count: int = 8) -> tuple[float, np.ndarray]:
    """(mean, amplitudes A_1…A_count) of one exact period sampled uniformly.

    ``period_samples`` holds N samples of one period without its end point
    (x(0), x(T/N), …, x((N−1)T/N)); A_n is the amplitude of the n-th harmonic.
    """
    n = period_samples.shape[0]
    spectrum = np.fft.rfft(period_samples) / n
    return float(spectrum[0].real), 2.0 * np.abs(spectrum[1:count + 1])


def thd(amplitudes: np.ndarray) -> float:
    """Total harmonic distortion √(Σ_{n≥2} A_n²) / A_1."""
    return float(np.sqrt(np.sum(amplitudes[1:] ** 2)) / amplitudes[0])


def quasi_static_thd(ka: float) -> float:
    """THD of f0/(1 + k_a'·cos s): successive harmonics fall by r = (1 − √(1 − k²))/k.

    The paper's response at Ω = 0.043 ≪ 1 is quasi-static; this is its distortion
    when the STE forcing is small against f0. THD = r/√(1 − r²).
    """
    if ka == 0.0:
        return 0.0
    r = (1.0 - math.sqrt(1.0 - ka * ka)) / ka
    return r / math.sqrt(1.0 - r * r)


def half_range(x: np.ndarray, axis: int = 0) -> np.ndarray:
    """(max − min)/2 along ``axis``: the oscillation amplitude of a sampled signal."""
    return 0.5 * (np.max(x, axis=axis) - np.min(x, axis=axis))


__all__ = [
    'first_overshoot',
    'half_range',
    'harmonics',
    'quasi_static_thd',
    'settling_time',
    'thd',
]
