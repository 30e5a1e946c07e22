"""Vectorized RK4 of the normalized equation over many parameter sets at once.

The same equation and coefficients as :mod:`screwgear_ros.paper.normalized` (model.md §5),

    x'' + 2ζ·x' + [κ + k_a'·cos(Ωτ + ϕ_k)]·x
        = f0 + f_v·sin(Ω_v·τ) + Σ_n fa_n·n²·Ω²·sin(nΩτ + ϕ_n),

with every coefficient an array of N parameter sets (:class:`Coefficients`, one
entry per :class:`~screwgear_ros.paper.normalized.NormalizedParams`). The arithmetic is
done in the same order as the scalar compiled :func:`normalized.rhs`, and both step
with :func:`screwgear_ros.numerics.rk.step`, so both give the same numbers to rounding. Used by
the sweeps of the paper report and by :mod:`screwgear_ros.paper.floquet`. Dimensionless.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, fields
from typing import Any

import numpy as np
from tqdm import tqdm

from ..numerics import rk
from ..params.declarations import Kind, declared
from .normalized import NormalizedParams

#: The scalar coefficients, in declaration order (the fields of :class:`Coefficients`
#: are NormalizedParams' own, as arrays; a test holds them equal).
_SCALAR_FIELDS = tuple(p.name for p in declared(NormalizedParams) if p.kind is Kind.FLOAT)


@dataclass(frozen=True)
class Coefficients:
    """N parameter sets of the normalized equation (NormalizedParams fields as arrays).

    Scalar fields have shape (N,); the STE harmonics fa_n and ϕ_n have shape (N, H)
    (sets with fewer harmonics are padded with zero amplitude).
    """

    damping_ratio: np.ndarray                # ζ
    stiffness_fluctuation: np.ndarray        # k_a'
    frequency_ratio: np.ndarray              # Ω
    mean_load: np.ndarray                    # f0
    load_fluctuation_amplitude: np.ndarray   # f_v
    load_fluctuation_frequency: np.ndarray   # Ω_v
    stiffness_ratio: np.ndarray              # κ
    stiffness_phase: np.ndarray              # ϕ_k, rad
    initial_displacement: np.ndarray         # x(0)
    initial_velocity: np.ndarray             # x'(0)
    excitation_amplitudes: np.ndarray        # fa_n, (N, H)
    excitation_phases: np.ndarray            # ϕ_n, rad, (N, H)

    def __post_init__(self) -> None:
        n = np.asarray(self.damping_ratio).size
        for name in _SCALAR_FIELDS:
            value = np.array(getattr(self, name), dtype=np.float64).reshape(-1)
            if value.size == 1 and n > 1:
                value = np.full(n, value[0])
            if value.shape != (n,):
                raise ValueError(f'{name} has {value.size} entries, expected {n}')
            object.__setattr__(self, name, value)
        for name in ('excitation_amplitudes', 'excitation_phases'):
            value = np.atleast_2d(np.array(getattr(self, name), dtype=np.float64))
            if value.shape[0] == 1 and n > 1:
                value = np.repeat(value, n, axis=0)
            if value.ndim != 2 or value.shape[0] != n:
                raise ValueError(f'{name} must have shape ({n}, harmonics)')
            object.__setattr__(self, name, value)
        if self.excitation_amplitudes.shape != self.excitation_phases.shape:
            raise ValueError('excitation_phases needs one phase per excitation harmonic')

    def __len__(self) -> int:
        return self.damping_ratio.shape[0]

    @classmethod
    def stack(cls, params: Sequence[NormalizedParams]) -> Coefficients:
        """The parameter sets ``params`` side by side (harmonics zero-padded)."""
        h = max(len(p.excitation_amplitudes) for p in params)
        fa = np.zeros((len(params), h))
        ph = np.zeros((len(params), h))
        for i, p in enumerate(params):
            fa[i, :len(p.excitation_amplitudes)] = p.excitation_amplitudes
            ph[i, :len(p.excitation_phases)] = p.excitation_phases
        scalars = {name: np.array([getattr(p, name) for p in params]) for name in _SCALAR_FIELDS}
        return cls(**scalars, excitation_amplitudes=fa, excitation_phases=ph)

    @classmethod
    def grid(cls, base: NormalizedParams, **axes: np.ndarray) -> tuple[Coefficients, tuple]:
        """``base`` with scalar fields swept over a grid: (coefficients, grid shape).

        ``Coefficients.grid(p, damping_ratio=z, stiffness_fluctuation=k)`` gives
        len(z)·len(k) sets in ``np.meshgrid(z, k, indexing='ij')`` order; reshape a
        result of length N with ``.reshape(shape)``.
        """
        unknown = set(axes) - set(_SCALAR_FIELDS)
        if unknown:
            raise ValueError(f'cannot sweep {sorted(unknown)}: not a scalar coefficient')
        mesh = np.meshgrid(*(np.asarray(v, dtype=np.float64) for v in axes.values()),
                           indexing='ij')
        shape = mesh[0].shape if mesh else ()
        n = int(np.prod(shape))
        values = {name: np.full(n, float(getattr(base, name))) for name in _SCALAR_FIELDS}
        for name, m in zip(axes, mesh, strict=True):
            values[name] = m.reshape(-1)
        fa, ph = base.harmonics()
        return cls(**values, excitation_amplitudes=np.tile(fa, (n, 1)),
                   excitation_phases=np.tile(ph, (n, 1))), shape

    def with_values(self, **changes: np.ndarray | float) -> Coefficients:
        """A copy with some fields replaced (scalars broadcast to all sets)."""
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        values.update(changes)
        return Coefficients(**values)

    def select(self, index: np.ndarray | slice) -> Coefficients:
        """The parameter sets at ``index``."""
        return Coefficients(**{f.name: getattr(self, f.name)[index] for f in fields(self)})

    def params(self, i: int) -> NormalizedParams:
        """Parameter set i as a NormalizedParams (for the scalar integrator)."""
        return NormalizedParams(
            **{name: float(getattr(self, name)[i]) for name in _SCALAR_FIELDS},
            excitation_amplitudes=tuple(self.excitation_amplitudes[i]),
            excitation_phases=tuple(self.excitation_phases[i]))


def concatenate(parts: Sequence[Coefficients]) -> Coefficients:
    """Several batches as one (same number of harmonics)."""
    return Coefficients(**{f.name: np.concatenate([getattr(p, f.name) for p in parts])
                           for f in fields(Coefficients)})


def rhs(tau: np.ndarray | float, x: np.ndarray, v: np.ndarray,
        c: Coefficients) -> tuple[np.ndarray, np.ndarray]:
    """(x', x'') of all N equations at dimensionless time τ (scalar or (N,))."""
    omega = c.frequency_ratio
    forcing = c.mean_load + c.load_fluctuation_amplitude * np.sin(
        c.load_fluctuation_frequency * tau)
    for k in range(c.excitation_amplitudes.shape[1]):
        n = k + 1
        forcing = forcing + c.excitation_amplitudes[:, k] * n * n * omega * omega * np.sin(
            n * omega * tau + c.excitation_phases[:, k])
    stiffness = c.stiffness_ratio + c.stiffness_fluctuation * np.cos(
        omega * tau + c.stiffness_phase)
    return v, forcing - 2.0 * c.damping_ratio * v - stiffness * x


def slope(tau: np.ndarray | float, y: np.ndarray, c: Coefficients) -> np.ndarray:
    """d/dτ of the states y = (x, x') stacked as a (2, N) array: :func:`rhs`."""
    return np.stack(rhs(tau, y[0], y[1], c))


def integrate(c: Coefficients, n_steps: int, dtau: float | np.ndarray, stride: int = 1,
              keep_from: int = 0, tau0: float = 0.0, x0: np.ndarray | None = None,
              v0: np.ndarray | None = None,
              progress: str | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fixed-step RK4 (:func:`screwgear_ros.numerics.rk.step`) of all N equations over ``n_steps``
    steps of ``dtau``.

    ``dtau`` is one step for all sets or an (N,) array (one step per set, e.g. a
    fixed number of steps per mesh period). States are kept every ``stride`` steps
    from step ``keep_from`` on (step 0 = the initial state). Returns (τ, x, x'):
    x and x' of shape (m, N); τ of shape (m,) for a scalar ``dtau``, (m, N) for an
    array. Step k starts at τ0 + k·dtau exactly (no accumulated time), as in
    :func:`normalized.integrate`. ``progress`` names a tqdm bar (None = no bar).
    """
    y = np.stack([c.initial_displacement if x0 is None else np.asarray(x0, dtype=np.float64),
                  c.initial_velocity if v0 is None else np.asarray(v0, dtype=np.float64)])
    h_all: Any = dtau if np.ndim(dtau) == 0 else np.asarray(dtau, dtype=np.float64)
    kept_steps = [k for k in range(keep_from, n_steps + 1) if k % stride == 0]
    xs = np.empty((len(kept_steps), len(c)))
    vs = np.empty_like(xs)
    j = 0
    if kept_steps and kept_steps[0] == 0:
        xs[0], vs[0] = y
        j = 1
    bar = tqdm(total=n_steps, desc=progress, unit='step', leave=False,
               disable=progress is None, mininterval=0.5)
    for step in range(n_steps):
        y = rk.step(slope, tau0 + step * h_all, y, h_all, c)
        if j < len(kept_steps) and kept_steps[j] == step + 1:
            xs[j], vs[j] = y
            j += 1
        if step % 256 == 255:
            bar.update(256)
    bar.close()
    steps = np.array(kept_steps, dtype=np.float64)
    tau_out = tau0 + (steps if np.ndim(dtau) == 0 else steps[:, None]) * h_all
    return tau_out, xs, vs


def response(c: Coefficients, tau_end: float, dtau: float = 0.01, stride: int = 10,
             progress: str | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """RK4 response of all N sets from τ = 0, sampled like :func:`normalized.response`.

    Returns (τ (m,), x (m, N), x' (m, N)), sample 0 = the initial state.
    """
    n = round(tau_end / (dtau * stride))
    return integrate(c, n * stride, dtau, stride, progress=progress)


__all__ = ['Coefficients', 'concatenate', 'integrate', 'response', 'rhs', 'slope']
