"""An open-loop excitation for identification, as a scenario controller factory
(``controller: {use: screwgear_ros.identification.excitation:make, parameters: {...}}``).

The drive torque (cmd_effort, whose sign is the direction) cycles through four phases:
a chirp plus a PRBS around +bias (path 1 driving), the same around −bias (a reversal,
path 3 driving), then slow moves at ±``slow`` N·m (friction at low speed, and reversals
that cross the gap slowly). The chirp and PRBS amplitudes are kept below the bias, so
the direction changes only at the phase boundaries.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np


def make(setpoint: Any = None, *, bias: float = 5.0, chirp: float = 2.5,
         chirp_start: float = 0.5, chirp_end: float = 40.0, prbs: float = 1.5,
         prbs_period: float = 0.01, slow: float = 1.5, phase: float = 1.5,
         slow_phase: float = 0.75, seed: int = 1) -> Callable[[Any], float]:
    """The excitation controller: observation → signed drive torque, N·m.

    Parameters
    ----------
    setpoint : ignored
        Scenario factories take the setpoint first; an excitation tracks none.
    bias : float
        Torque the chirp and PRBS ride on, N·m (its sign alternates each phase).
    chirp, chirp_start, chirp_end : float
        Amplitude (N·m) and the frequencies (Hz) of a linear sweep over one phase.
    prbs, prbs_period : float
        Amplitude (N·m) of a seeded ±1 sequence, held ``prbs_period`` s per bit.
    slow, slow_phase : float
        Torque (N·m) and length (s) of each slow move.
    phase : float
        Length of each chirp phase, s.
    seed : int
        Seed of the PRBS.

    Returns
    -------
    callable
        ``controller(observation) -> float``.

    Raises
    ------
    ValueError
        Chirp plus PRBS not below the bias (the direction would flip within a phase).

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> c = make(bias=5.0, chirp=2.5, prbs=1.5)
    >>> 1.0 <= c(SimpleNamespace(time=0.3)) <= 9.0
    True
    """
    if chirp + prbs >= bias:
        raise ValueError(f'chirp + prbs ({chirp + prbs:g} N·m) must stay below the bias '
                         f'({bias:g} N·m)')
    cycle = 2 * phase + 2 * slow_phase
    bits = np.where(np.random.default_rng(seed).random(1 << 16) < 0.5, -1.0, 1.0)
    rate = (chirp_end - chirp_start) / phase

    def controller(observation: Any) -> float:
        t = float(observation.time) % cycle
        if t < 2 * phase:
            sign, tau = (1.0, t) if t < phase else (-1.0, t - phase)
            sweep = chirp * math.sin(2 * math.pi * (chirp_start * tau + 0.5 * rate * tau * tau))
            bit = prbs * bits[int(observation.time / prbs_period) % len(bits)]
            return sign * bias + sweep + bit
        return slow if t < 2 * phase + slow_phase else -slow

    return controller


__all__ = ['make']
