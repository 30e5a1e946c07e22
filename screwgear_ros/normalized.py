"""The paper's normalized single-degree-of-freedom equation (model.md §5).

    x'' + 2ζ·x' + [κ + k_a'·cos(Ωτ + ϕ_k)]·x
        = f0 + f_v·sin(Ω_v·τ) + Σ_n fa_n·n²·Ω²·sin(nΩτ + ϕ_n)

τ = ω0·t, ω0 = √(k_m/m_e), u = δ = l·x. κ = k_eff/k_m is 1 in the paper (no thermal
derating, no preload stiffness); it keeps the reduction from the 3-DOF model exact
when those are set. Everything here is dimensionless.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import yaml
from numba import njit

from .params import (ParameterError, TableParams, effective_stiffness, equivalent_mass,
                     mean_mesh_force, natural_frequency)

# Layout of the packed coefficient array.
ZETA, KAPPA, KA, PHI_K, OMEGA, F0, FV, OMEGA_V = range(8)


@dataclass(frozen=True)
class NormalizedParams:
    """Coefficients of the normalized equation; defaults = the paper's normalized case."""

    damping_ratio: float = 0.05                 # ζ
    stiffness_fluctuation: float = 0.1          # k_a'
    frequency_ratio: float = 0.043              # Ω = ω_e/ω0
    mean_load: float = 512.8                    # f0
    excitation_amplitudes: tuple[float, ...] = (1538.4,)  # fa_n = ε_n/l
    excitation_phases: tuple[float, ...] = (0.0,)         # ϕ_n, rad
    load_fluctuation_amplitude: float = 0.0     # f_v
    load_fluctuation_frequency: float = 0.0     # Ω_v
    stiffness_ratio: float = 1.0                # κ = k_eff/k_m
    stiffness_phase: float = 0.0                # ϕ_k, rad
    initial_displacement: float = 0.5           # x(0)
    initial_velocity: float = 0.5               # x'(0)

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            values = value if isinstance(value, (tuple, list)) else (value,)
            for v in values:
                if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                    raise ParameterError(name, value, 'must be finite numbers')
        object.__setattr__(self, 'excitation_amplitudes',
                           tuple(float(v) for v in self.excitation_amplitudes))
        object.__setattr__(self, 'excitation_phases',
                           tuple(float(v) for v in self.excitation_phases))
        if len(self.excitation_amplitudes) != len(self.excitation_phases):
            raise ParameterError('excitation_phases', list(self.excitation_phases),
                                 'needs one phase per excitation harmonic')
        if self.damping_ratio < 0.0:
            raise ParameterError('damping_ratio', self.damping_ratio, 'must be >= 0')
        if self.frequency_ratio < 0.0:
            raise ParameterError('frequency_ratio', self.frequency_ratio, 'must be >= 0')

    def packed(self) -> np.ndarray:
        """Scalar coefficients for the compiled right-hand side."""
        c = np.empty(8)
        c[ZETA], c[KAPPA], c[KA] = self.damping_ratio, self.stiffness_ratio, self.stiffness_fluctuation
        c[PHI_K], c[OMEGA], c[F0] = self.stiffness_phase, self.frequency_ratio, self.mean_load
        c[FV], c[OMEGA_V] = self.load_fluctuation_amplitude, self.load_fluctuation_frequency
        return c

    def harmonics(self) -> tuple[np.ndarray, np.ndarray]:
        """(fa_n, ϕ_n) as float arrays."""
        return (np.array(self.excitation_amplitudes, dtype=np.float64),
                np.array(self.excitation_phases, dtype=np.float64))


def from_table(p: TableParams, drive_torque: float, length_scale: float = 1e-6,
               initial_displacement: float = 0.0,
               initial_velocity: float = 0.0) -> NormalizedParams:
    """The normalized coefficients of a 3-DOF parameter set (`time` mesh phase).

    drive_torque T1 in N·m gives F_m = T1/r1; length_scale l in m. The torque
    fluctuation T_v acts on pinion 1 only (the table load stays T1·r2/r1), so it
    enters δ̈ as r1·T_v/I1: f_v = m_e·r1·T_v / (I1·k_m·l), not T_v/(r1·k_m·l).
    """
    k_m = p.mesh_stiffness_mean
    w0 = natural_frequency(p)
    m_e = equivalent_mass(p)
    return NormalizedParams(
        damping_ratio=p.mesh_damping / (2.0 * m_e * w0),
        stiffness_fluctuation=p.mesh_stiffness_amplitude / k_m,
        frequency_ratio=p.mesh_frequency / w0,
        mean_load=mean_mesh_force(p, drive_torque) / (k_m * length_scale),
        excitation_amplitudes=tuple(a / length_scale for a in p.ste_amplitudes),
        excitation_phases=p.ste_phases,
        load_fluctuation_amplitude=m_e * p.radius_pinion_1 * p.torque_fluctuation_amplitude / (
            p.inertia_pinion_1 * k_m * length_scale),
        load_fluctuation_frequency=p.torque_fluctuation_frequency / w0,
        stiffness_ratio=effective_stiffness(p) / k_m,
        stiffness_phase=p.mesh_stiffness_phase,
        initial_displacement=initial_displacement, initial_velocity=initial_velocity)


@njit(cache=True, error_model="numpy")
def rhs(tau: float, x: float, v: float, c: np.ndarray, fa: np.ndarray,
        phases: np.ndarray) -> tuple[float, float]:
    """(x', x'') of the normalized equation at dimensionless time τ."""
    omega = c[OMEGA]
    forcing = c[F0] + c[FV] * math.sin(c[OMEGA_V] * tau)
    for k in range(fa.shape[0]):
        n = k + 1
        forcing += fa[k] * n * n * omega * omega * math.sin(n * omega * tau + phases[k])
    stiffness = c[KAPPA] + c[KA] * math.cos(omega * tau + c[PHI_K])
    return v, forcing - 2.0 * c[ZETA] * v - stiffness * x


@njit(cache=True, error_model="numpy")
def integrate(x0: float, v0: float, tau0: float, dtau: float, stride: int, out: np.ndarray,
              c: np.ndarray, fa: np.ndarray, phases: np.ndarray) -> None:
    """Fixed-step RK4; out[j] = (x, x') after (j + 1)·stride steps of dtau from τ0."""
    x, v = x0, v0
    h = 0.5 * dtau
    step = 0
    for j in range(out.shape[0]):
        for _ in range(stride):
            tau = tau0 + step * dtau
            k1x, k1v = rhs(tau, x, v, c, fa, phases)
            k2x, k2v = rhs(tau + h, x + h * k1x, v + h * k1v, c, fa, phases)
            k3x, k3v = rhs(tau + h, x + h * k2x, v + h * k2v, c, fa, phases)
            k4x, k4v = rhs(tau + dtau, x + dtau * k3x, v + dtau * k3v, c, fa, phases)
            x += dtau / 6.0 * (k1x + 2.0 * (k2x + k3x) + k4x)
            v += dtau / 6.0 * (k1v + 2.0 * (k2v + k3v) + k4v)
            step += 1
        out[j, 0] = x
        out[j, 1] = v


def response(params: NormalizedParams, tau_end: float, dtau: float = 0.01,
             stride: int = 10) -> tuple[np.ndarray, np.ndarray]:
    """RK4 response from τ = 0: (τ samples, states (n, 2) of x and x'), sample 0 = x(0)."""
    n = int(round(tau_end / (dtau * stride)))
    out = np.empty((n, 2))
    fa, phases = params.harmonics()
    integrate(params.initial_displacement, params.initial_velocity, 0.0, dtau, stride, out,
              params.packed(), fa, phases)
    tau = np.arange(n + 1) * dtau * stride
    states = np.vstack([[params.initial_displacement, params.initial_velocity], out])
    return tau, states


def load_yaml(path: str | Path) -> NormalizedParams:
    """Load ``config/paper_normalized.yaml`` (a mapping of the field names)."""
    with open(path, encoding='utf-8') as stream:
        document: Mapping[str, Any] = yaml.safe_load(stream) or {}
    return NormalizedParams(**document)


__all__ = ['NormalizedParams', 'from_table', 'rhs', 'integrate', 'response', 'load_yaml']
