"""Stability margins of a sampled loop gain, and the linear plant as a sampled-data
controller sees it.

A controller that answers each tick's observation with an effort held over the next tick
sees the plant through a zero-order hold: the sequence of held efforts in, the sequence of
sampled outputs out. Between those sequences the linear model is the discrete system
``P(z) = C·(zI − Ad)⁻¹·Bd + D`` with ``Ad = exp(A·h)``, ``Bd = ∫₀ʰ exp(A·s) ds·B``
(:func:`held_response`): python-control's ``c2d(P, h, 'zoh')``. It holds at every
frequency below the Nyquist frequency of the tick rate, where a sampled sinusoid is still
one sinusoid.

:func:`margins` reads the gain margin, the phase margin and the peak of the sensitivity
|S| = 1/|1 + L| off a loop gain L sampled at rising frequencies.

Examples
--------
>>> import numpy as np
>>> f = np.geomspace(0.1, 100.0, 400)
>>> s = 2j * np.pi * f
>>> m = margins(f, 10.0 / (s * (s / 20.0 + 1.0) * (s / 60.0 + 1.0)))
>>> m.phase is not None and m.gain is not None and m.peak_sensitivity > 1.0
True
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

from .linear_model import LinearModel


@dataclass(frozen=True)
class Margins:
    """Gain margin (the factor by which the loop gain may grow, > 1, at the phase
    crossover (−180°) where |L| is largest below 1), phase margin (degrees, at the first
    gain crossover), None where the range holds no such crossover; the peak of
    |S| = 1/|1 + L| over the range with its frequency (None: no point); and the lower
    gain margin of a conditionally stable loop: at a phase crossover where |L| > 1 the
    loop is stable only because its gain is that large; it goes unstable if the gain
    *drops* by the factor ``lower_gain`` (< 1), the one nearest 1 of such crossovers."""

    gain: float | None
    gain_at_hz: float | None
    phase: float | None
    phase_at_hz: float | None
    peak_sensitivity: float | None = None
    peak_at_hz: float | None = None
    lower_gain: float | None = None
    lower_gain_at_hz: float | None = None

    def describe(self) -> str:
        phase = (f'phase margin {self.phase:.1f}° at {self.phase_at_hz:.3g} Hz'
                 if self.phase is not None else 'no gain crossover in the range')
        gain = (f'gain margin {self.gain:.3g} ({20 * math.log10(self.gain):.1f} dB) at '
                f'{self.gain_at_hz:.4g} Hz' if self.gain is not None
                else 'no phase crossover (−180°) with |L| < 1 in the range')
        peak = (f'; peak |S| {self.peak_sensitivity:.3g} '
                f'({20 * math.log10(self.peak_sensitivity):.1f} dB) at '
                f'{self.peak_at_hz:.4g} Hz' if self.peak_sensitivity is not None else '')
        lower = ''
        if self.lower_gain is not None:
            db = 20 * math.log10(self.lower_gain)
            lower = (f'; lower gain margin {self.lower_gain:.3g} ({db:.1f} dB) at '
                     f'{self.lower_gain_at_hz:.4g} Hz: the loop is conditionally stable, its '
                     f'phase passes −180° there while |L| > 1, so it goes unstable if the '
                     f'loop gain drops by {-db:.1f} dB (a smaller gain, a saturated drive), '
                     'not only if it grows')
        return f'{phase}; {gain}{peak}{lower}'


def loop_phase(loop: np.ndarray) -> np.ndarray:
    """The phase of a loop gain in degrees, unwrapped from the lowest frequency, the first
    one in (−360°, 0°]."""
    phase = np.degrees(np.unwrap(np.angle(loop)))
    return phase - 360.0 * np.ceil(phase[0] / 360.0)


def margins(frequency: np.ndarray, loop: np.ndarray) -> Margins:
    """Margins of a loop gain sampled at ``frequency`` (Hz, rising): crossings located by
    linear interpolation in log frequency, of log|L| and of :func:`loop_phase` (each
    −180° + n·360° crossing a phase crossover); the peak |S| is the largest of the
    samples."""
    frequency, loop = np.asarray(frequency, dtype=float), np.asarray(loop)
    if loop.size == 0:
        return Margins(None, None, None, None)
    logf = np.log(frequency)
    mag = np.log(np.abs(loop))
    phase = loop_phase(loop)
    pm = pm_hz = None
    crossings: list[tuple[float, float]] = []          # (gain factor, Hz)
    for k in range(len(frequency) - 1):
        if pm is None and mag[k] >= 0.0 > mag[k + 1]:
            s = mag[k] / (mag[k] - mag[k + 1])
            pm_hz = float(np.exp(logf[k] + s * (logf[k + 1] - logf[k])))
            pm = float(180.0 + phase[k] + s * (phase[k + 1] - phase[k]))
        if phase[k] == phase[k + 1]:
            continue
        # the −180° + n·360° lines between these two samples
        low, high = sorted((phase[k], phase[k + 1]))
        for n in range(math.ceil((low + 180.0) / 360.0), math.floor((high + 180.0) / 360.0) + 1):
            target = -180.0 + 360.0 * n
            s = (phase[k] - target) / (phase[k] - phase[k + 1])
            crossings.append((float(1.0 / np.exp(mag[k] + s * (mag[k + 1] - mag[k]))),
                              float(np.exp(logf[k] + s * (logf[k + 1] - logf[k])))))
    upper = min((c for c in crossings if c[0] >= 1.0), default=(None, None))
    lower = max((c for c in crossings if c[0] < 1.0), default=(None, None))
    sensitivity = 1.0 / np.abs(1.0 + loop)
    peak = int(np.argmax(sensitivity))
    return Margins(upper[0], upper[1], pm, pm_hz, float(sensitivity[peak]),
                   float(frequency[peak]), lower[0], lower[1])


def held_response(model: LinearModel, frequency_hz: np.ndarray, h: float) -> np.ndarray:
    """The response of ``model`` between inputs held for ``h`` s and outputs sampled
    every ``h`` s (module docstring), shape (outputs, inputs, frequencies): the output
    sample taken as the hold of the input sample starts, so it answers the holds before
    (the one tick a sampled-data plant takes to answer); through the model's joint
    sensors when it has them (:mod:`.loop_dynamics`: delay, speed filter, differenced
    speed, exact on the samples)."""
    n, m = model.b.shape
    block = np.zeros((n + m, n + m))
    block[:n, :n], block[:n, n:] = model.a * h, model.b * h
    exp = expm(block)
    ad, bd = exp[:n, :n], exp[:n, n:]
    f = np.atleast_1d(np.asarray(frequency_hz, dtype=float))
    eye = np.eye(n)
    out = np.empty((model.c.shape[0], m, len(f)), dtype=complex)
    for k, hz in enumerate(f):
        z = np.exp(2j * math.pi * hz * h)
        out[:, :, k] = model.c @ np.linalg.solve(z * eye - ad, bd) + model.d
    if model.sensors is not None:
        out = model.sensors.apply(out, f, h, model.outputs)
    return out


__all__ = ['Margins', 'held_response', 'loop_phase', 'margins']
