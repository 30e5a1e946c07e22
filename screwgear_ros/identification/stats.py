"""What the data say about the fitted values: ±2σ intervals and correlations from the
Jacobian at the optimum, the parameters the data cannot determine, and whether the
recordings and the starting points agree.

With residual variance s² = ‖r‖² / (m − p), inflated by (1 + ρ)/(1 − ρ) for residuals
whose lag-one autocorrelation is ρ (fewer independent samples than there are samples:
quantization and unmodelled slow effects are not white noise), the covariance of the
scaled parameters is s²·(JᵀJ)⁺ on the subspace the data determine: the directions whose
singular value (each column of J scaled to unit length) is at least :data:`SINGULAR` of
the largest. Each other direction is named; a parameter with a share of at least
:data:`SHARE` in one is undetermined (its interval unbounded), the others keep the
intervals of the determined subspace, so a parameter with no effect at all leaves the
rest as they are. A parameter is *determined* when its ±2σ interval is within
±:data:`DETERMINED` of its value (of its bounds' width for a value of 0), it does not
sit on a bound, and, where it needs one, the drive reversed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .parameters import FitParameter, Scale

#: Relative singular value below which a direction of the parameters is not determined.
SINGULAR = 1.0e-4
#: Share (component of the unit direction) that makes a parameter part of a direction.
SHARE = 0.1
#: The ±2σ half-width, relative to the value, within which a value is determined.
DETERMINED = 0.10
#: Distance from a bound, as a fraction of the bounds' width in scaled coordinates,
#: within which a value sits on it.
AT_BOUND = 1.0e-3
#: How many of its own σ a recording's estimate may lie from the joint fit before the
#: recordings are said to disagree (4σ: a chance of 6e-5 for a consistent recording).
DISAGREE_SIGMA = 4.0

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
    """One fitted value with its ±2σ interval (NaN: not computed, ±inf: unbounded) and
    whether the data determine it (and why not)."""

    name: str
    value: float
    base: float
    low: float
    high: float
    unit: str
    undetermined: str = ''
    at_bound: bool = False

    @property
    def excitation(self) -> str:
        return EXCITATION.get(self.name, DEFAULT_EXCITATION)

    @property
    def judged(self) -> bool:
        """Whether there is an interval to judge it by (not for an interrupted fit)."""
        return not (math.isnan(self.low) or math.isnan(self.high))

    @property
    def advice(self) -> str:
        """What to do about an undetermined value."""
        if self.at_bound:
            return f'widen --bounds {self.name}=LO:HI'
        return f'record {self.excitation}'

    @property
    def verdict(self) -> str:
        """'yes', 'no: why', or 'not judged: why' (never 'yes' beside NaN)."""
        if self.undetermined:
            return 'no: ' + self.undetermined
        if not self.judged:
            return 'not judged: no interval (the fit was interrupted)'
        return 'yes'


@dataclass(frozen=True)
class Statistics:
    estimates: tuple[Estimate, ...]
    correlation: np.ndarray
    singular_values: np.ndarray     # of the column-scaled Jacobian, largest first
    sigma: float                    # residual standard deviation (scaled units)
    directions: tuple[str, ...] = ()    # the undetermined directions, named
    warnings: tuple[str, ...] = field(default=())   # recordings or starts that disagree

    @property
    def undetermined(self) -> list[Estimate]:
        return [e for e in self.estimates if e.undetermined]

    @property
    def local(self) -> bool:
        """The intervals hold around this minimum only (the starts ended in others)."""
        return any(w.startswith('start') for w in self.warnings)


def _interval(p: FitParameter, x: float, sd: float) -> tuple[float, float]:
    if not math.isfinite(sd):
        return -math.inf, math.inf
    if p.scale is Scale.LOG:
        return math.exp(x - 2 * sd), math.exp(x + 2 * sd)
    return p.to_value(x - 2 * sd), p.to_value(x + 2 * sd)


@dataclass(frozen=True)
class _Decomposition:
    """The column-scaled SVD of a Jacobian: the covariance (in x, up to s²) of the
    determined subspace and the undetermined directions."""

    norms: np.ndarray
    singular: np.ndarray
    vt: np.ndarray
    weak: np.ndarray

    @classmethod
    def of(cls, jacobian: np.ndarray) -> _Decomposition:
        norms = np.linalg.norm(jacobian, axis=0)
        scaled = jacobian / np.where(norms > 0, norms, 1.0)
        _, singular, vt = np.linalg.svd(scaled, full_matrices=False)
        weak = ~(singular >= SINGULAR * singular[0]) if singular[0] > 0 else \
            np.ones(len(singular), bool)
        return cls(norms, singular, vt, weak)

    def pinv(self) -> np.ndarray:
        """(JᵀJ)⁺ restricted to the determined directions, in x coordinates."""
        strong = ~self.weak
        inner = (self.vt[strong].T / self.singular[strong] ** 2) @ self.vt[strong]
        scale = np.where(self.norms > 0, 1.0 / np.where(self.norms > 0, self.norms, 1.0), 0.0)
        return inner * np.outer(scale, scale)

    def step(self, residual: np.ndarray, jacobian: np.ndarray) -> np.ndarray:
        """The Gauss-Newton step −J⁺r within the determined subspace."""
        return -self.pinv() @ (jacobian.T @ residual)

    def undetermined(self) -> set[int]:
        return {j for k in np.flatnonzero(self.weak) for j in range(self.vt.shape[1])
                if abs(self.vt[k, j]) >= SHARE}


def _sigma(residual: np.ndarray, p: int, rho: float) -> float:
    m = len(residual)
    return math.sqrt(float(residual @ residual) / max(1, m - p) * (1 + rho) / (1 - rho))


def _direction_text(names: Sequence[str], v: np.ndarray) -> str:
    terms = [f'{c:+.2f}·{n}' for n, c in zip(names, v, strict=True) if abs(c) >= SHARE]
    return ' '.join(terms).lstrip('+')


def _on_bound(q: FitParameter, x: float, sd: float, gradient: float) -> str:
    lo, hi = q.x_bounds
    width = hi - lo
    for bound, side, outward in ((lo, 'lower', gradient > 0), (hi, 'upper', gradient < 0)):
        distance = abs(x - bound)
        if distance <= AT_BOUND * width or (distance < sd and outward):
            return side
    return ''


def statistics(fitted: Sequence[FitParameter], x: np.ndarray, residual: np.ndarray,
               jacobian: np.ndarray | None, lag_correlation: float = 0.0,
               reversals: int = 1) -> Statistics:
    """Intervals, correlations and identifiability at ``x`` (no Jacobian: every interval
    NaN, nothing judged); ``reversals``: how many reversals the node applied in the fit
    recordings."""
    p = len(fitted)
    names = [q.name for q in fitted]
    values = [q.to_value(float(v)) for q, v in zip(fitted, x, strict=True)]
    if jacobian is None:
        estimates = tuple(Estimate(q.name, v, q.base, math.nan, math.nan, q.unit)
                          for q, v in zip(fitted, values, strict=True))
        return Statistics(estimates, np.full((p, p), np.nan), np.full(p, np.nan), math.nan)
    sigma = _sigma(residual, p, lag_correlation)
    parts = _Decomposition.of(jacobian)
    cov = sigma ** 2 * parts.pinv()
    loose = parts.undetermined()
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    sd[list(loose)] = np.inf
    with np.errstate(invalid='ignore', divide='ignore'):
        correlation = cov / np.outer(sd, sd)
    correlation[list(loose), :] = np.nan
    correlation[:, list(loose)] = np.nan
    np.fill_diagonal(correlation, 1.0)
    gradient = jacobian.T @ residual
    directions = tuple(_direction_text(names, parts.vt[k]) for k in np.flatnonzero(parts.weak))
    found = []
    for j, (q, v) in enumerate(zip(fitted, values, strict=True)):
        low, high = _interval(q, float(x[j]), float(sd[j]))
        side = _on_bound(q, float(x[j]), float(sd[j]), float(gradient[j]))
        reference = abs(v) if v else q.high - q.low
        half = (high - low) / 2.0 / reference
        why = ''
        if parts.norms[j] == 0.0:
            why = 'the recordings do not depend on it at all'
        elif j in loose:
            why = ('in a direction the recordings cannot see (near-zero singular value): '
                   + next(d for k, d in zip(np.flatnonzero(parts.weak), directions,
                                            strict=True) if abs(parts.vt[k, j]) >= SHARE))
        elif side:
            bound = q.low if side == 'lower' else q.high
            why = f'at its {side} bound {bound:.6g}: widen --bounds'
        elif half > DETERMINED:
            why = (f'its ±2σ interval is ±{100 * half:.3g} % of its value (determined means '
                   f'within ±{100 * DETERMINED:g} %)')
        elif not reversals and q.name in NEEDS_REVERSAL:
            why = ('the drive never reversed in the recordings, so the gap is never crossed '
                   '(what is left of it shows only through the stiffness ripple)')
        found.append(Estimate(q.name, v, q.base, low, high, q.unit, why, bool(side)))
    return Statistics(tuple(found), correlation, parts.singular, sigma, directions)


def lag_correlation(residual: np.ndarray, columns: int = 1) -> float:
    """The lag-one autocorrelation of ``residual`` (``columns`` interleaved series,
    pooled), clipped to [0, 0.99]."""
    part = residual.reshape(-1, columns)
    den = float(np.sum(part * part))
    return max(0.0, min(0.99, float(np.sum(part[1:] * part[:-1])) / den)) if den > 0 else 0.0


def disagreements(fitted: Sequence[FitParameter], x: np.ndarray, residual: np.ndarray,
                  jacobian: np.ndarray, sizes: Sequence[int], paths: Sequence[str],
                  columns: int = 1) -> list[str]:
    """The recordings whose own data put a parameter more than :data:`DISAGREE_SIGMA` of
    their own σ from the joint fit: each recording's Gauss-Newton step from the joint
    optimum, on its rows of the residual and Jacobian (``columns`` joints interleaved),
    against the covariance of its own fit (its residual after the step: a misfit the
    joint fit forces on it is not counted as its noise)."""
    if len(sizes) < 2:
        return []
    out = []
    at = 0
    for size, path in zip(sizes, paths, strict=True):
        r, jac = residual[at:at + size], jacobian[at:at + size]
        at += size
        parts = _Decomposition.of(jac)
        step = parts.step(r, jac)
        own = r + jac @ step
        sd = _sigma(own, len(fitted), lag_correlation(own, columns)) * np.sqrt(
            np.clip(np.diag(parts.pinv()), 0.0, None))
        loose = parts.undetermined()
        for j, q in enumerate(fitted):
            if j in loose or not sd[j] > 0 or abs(step[j]) <= DISAGREE_SIGMA * sd[j]:
                continue
            alone = q.to_value(float(x[j] + step[j]))
            low, high = _interval(q, float(x[j] + step[j]), float(sd[j]))
            out.append(f'recording {path} alone puts {q.name} at {alone:.6g} [{low:.6g} … '
                       f'{high:.6g}] (±2σ), {abs(step[j]) / sd[j]:.3g}σ from the joint fit\'s '
                       f'{q.to_value(float(x[j])):.6g}: the recordings disagree (different '
                       'tables, or a change between them), and the joint intervals hold for '
                       'neither')
    return out


def start_disagreements(fitted: Sequence[FitParameter], estimates: Sequence[Estimate], points: Sequence[np.ndarray],
                        costs: Sequence[float]) -> list[str]:
    """The starts that ended outside the best one's ±2σ intervals (another minimum)."""
    out = []
    for k, (x, cost) in enumerate(zip(points, costs, strict=True)):
        off = [e.name for q, e, v in zip(fitted, estimates, x, strict=True)
               if e.judged and not (e.low <= q.to_value(float(v)) <= e.high)]
        if off:
            out.append(f'start {k + 1} ended at another minimum (cost {cost:.6g}; '
                       f'{", ".join(off)} outside the best one\'s ±2σ): the intervals are '
                       'local, they hold around the best minimum only')
    return out


__all__ = ['DETERMINED', 'EXCITATION', 'SINGULAR', 'Estimate', 'Statistics', 'disagreements',
           'lag_correlation', 'start_disagreements', 'statistics']
