"""What the data say about the fitted values: ±2σ intervals and correlations from the
Jacobian at the optimum, and the parameters the data cannot determine.

With residual variance s² = ‖r‖² / (m − p), inflated by (1 + ρ)/(1 − ρ) for residuals
whose lag-one autocorrelation is ρ (fewer independent samples than there are samples:
quantization and unmodelled slow effects are not white noise), the covariance of the scaled parameters is
s²·(JᵀJ)⁻¹ (from the singular values of J, so a singular J gives infinite variances
rather than an error). A parameter is undetermined when it dominates a direction whose
singular value is near zero (below :data:`SINGULAR` of the largest, after each column is
scaled to unit length), or when its ±2σ interval is wider than its value.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .parameters import FitParameter, Scale

#: Relative singular value below which a direction of the parameters is not determined.
SINGULAR = 1.0e-4

#: What excites each parameter, for the report of one the data cannot determine.
EXCITATION = {
    'backlash': 'direction reversals (the drive torque through zero, slowly, in both '
                'directions), so that the gap is crossed',
    'preload_torque': 'reversals and moves in both directions, so that each pinion takes '
                      'the load in turn',
    'mesh_stiffness_mean': 'a torque chirp or PRBS through the mesh resonance, with the '
                           'pinion and table encoders both recorded',
    'mesh_damping': 'a torque chirp or PRBS through the mesh resonance (its peak height '
                    'sets the damping)',
    'inertia_table': 'torque steps or a chirp below the mesh resonance (the acceleration '
                     'per torque)',
    'inertia_pinion_1': 'a chirp above the mesh resonance, driven on path 1',
    'inertia_pinion_3': 'a chirp above the mesh resonance, driven on path 3 (reverse)',
    'table_coulomb_torque': 'slow constant-torque moves in both directions and reversals',
    'table_static_torque': 'starts from rest (breakaway) in both directions',
    'table_stribeck_speed': 'slow moves at a few times the Stribeck speed',
    'table_damping': 'moves at several constant speeds',
    'pinion_coulomb_torque': 'slow moves in both directions, on both paths',
    'pinion_static_torque': 'starts from rest in both directions',
    'pinion_stribeck_speed': 'slow moves at a few times the Stribeck speed',
    'pinion_damping': 'moves at several constant speeds',
    'drive_time_constant': 'a PRBS or chirp of the torque up to the current loop\'s '
                           'bandwidth (fast torque changes)',
}
#: Parameters whose effect needs a reversal of the drive: in recordings without one they are
#: named undetermined whatever the Jacobian says (with preload, a gap that is never
#: crossed shows only through the stiffness ripple, which pins it to the ripple's model).
NEEDS_REVERSAL = frozenset({'backlash'})
DEFAULT_EXCITATION = 'a recording where this parameter changes the motion: see ' \
                     'docs/identification.md'


@dataclass(frozen=True)
class Estimate:
    """One fitted value with its ±2σ interval (NaN: not computed) and whether the data
    determine it (and why not)."""

    name: str
    value: float
    base: float
    low: float
    high: float
    unit: str
    undetermined: str = ''

    @property
    def excitation(self) -> str:
        return EXCITATION.get(self.name, DEFAULT_EXCITATION)


@dataclass(frozen=True)
class Statistics:
    estimates: tuple[Estimate, ...]
    correlation: np.ndarray
    singular_values: np.ndarray     # of the column-scaled Jacobian, largest first
    sigma: float                    # residual standard deviation (scaled units)

    @property
    def undetermined(self) -> list[Estimate]:
        return [e for e in self.estimates if e.undetermined]


def _interval(p: FitParameter, x: float, sd: float) -> tuple[float, float]:
    if not math.isfinite(sd):
        return -math.inf if p.scale is Scale.LINEAR else 0.0, math.inf
    if p.scale is Scale.LOG:
        return math.exp(x - 2 * sd), math.exp(x + 2 * sd)
    return p.to_value(x - 2 * sd), p.to_value(x + 2 * sd)


def statistics(fitted: Sequence[FitParameter], x: np.ndarray, residual: np.ndarray,
               jacobian: np.ndarray | None, lag_correlation: float = 0.0,
               reversals: int = 1) -> Statistics:
    """Intervals, correlations and identifiability at ``x`` (no Jacobian: every interval
    NaN, nothing judged); ``reversals``: how many the fit recordings hold."""
    p = len(fitted)
    values = [q.to_value(float(v)) for q, v in zip(fitted, x, strict=True)]
    if jacobian is None:
        estimates = tuple(Estimate(q.name, v, q.base, math.nan, math.nan, q.unit)
                          for q, v in zip(fitted, values, strict=True))
        return Statistics(estimates, np.full((p, p), np.nan), np.full(p, np.nan), math.nan)
    m = len(residual)
    rho = lag_correlation
    sigma = math.sqrt(float(residual @ residual) / max(1, m - p) * (1 + rho) / (1 - rho))
    norms = np.linalg.norm(jacobian, axis=0)
    scaled = jacobian / np.where(norms > 0, norms, 1.0)
    _, singular, vt = np.linalg.svd(scaled, full_matrices=False)
    weak = singular < SINGULAR * max(singular[0], 1e-300)
    # covariance of the column-scaled parameters, then back to x
    inverse = np.where(weak, np.inf, 1.0 / np.where(weak, 1.0, singular) ** 2)
    with np.errstate(invalid='ignore'):
        cov_scaled = (vt.T * inverse) @ vt
        cov_scaled = np.where(np.isnan(cov_scaled), np.inf, cov_scaled)
        denom = np.where(norms > 0, norms, 0.0)
        cov = sigma ** 2 * cov_scaled / np.outer(denom, denom)
    variances = np.diag(cov)
    sd = np.sqrt(np.where(np.isfinite(variances) & (variances >= 0), variances, np.inf))
    with np.errstate(invalid='ignore', divide='ignore'):
        correlation = cov / np.outer(sd, sd)
    np.fill_diagonal(correlation, 1.0)
    dominant = {int(np.argmax(np.abs(vt[k]))) for k in np.flatnonzero(weak)}
    dominant |= {j for k in np.flatnonzero(weak) for j in range(p) if abs(vt[k, j]) > 0.5}
    found = []
    for j, (q, v) in enumerate(zip(fitted, values, strict=True)):
        low, high = _interval(q, float(x[j]), float(sd[j]))
        why = ''
        if norms[j] == 0.0:
            why = 'the recordings do not depend on it at all'
        elif j in dominant:
            why = 'near-zero singular value: the recordings cannot tell it apart'
        elif (high - low) / 2.0 > abs(v):
            why = 'its ±2σ interval is wider than its value'
        elif not reversals and q.name in NEEDS_REVERSAL:
            why = ('the recordings never reverse the drive, so the gap is never crossed '
                   '(what is left of it shows only through the stiffness ripple)')
        found.append(Estimate(q.name, v, q.base, low, high, q.unit, why))
    return Statistics(tuple(found), correlation, singular, sigma)


__all__ = ['EXCITATION', 'SINGULAR', 'Estimate', 'Statistics', 'statistics']
